//! The GLSL optics and sampling functions agree with their unit-tested host mirrors.

use crate::support;

use glam::Vec3;
use rqr::render::reference::optics;
use rqr::render::sampling;
use rqr::vk::{vk, Binding, Buffer, ComputePipeline, MemoryLocation};

#[test]
fn glsl_optics_and_sequences_match_the_host() {
    let ctx = support::gpu();
    let count = 256u32;
    let out = Buffer::new(
        &ctx,
        "math",
        u64::from(count) * 64,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    let pipeline = ComputePipeline::new(
        &ctx,
        "shader math",
        rqr::shaders::SHADER_MATH_COMP,
        &[Binding::StorageBuffer],
        4,
    )
    .unwrap();
    let set = pipeline.allocate_set().unwrap();
    set.buffer(0, &out, Binding::StorageBuffer);
    ctx.run("shader math", |cmd| {
        pipeline.dispatch(
            cmd,
            Some(&set),
            &count.to_le_bytes(),
            [count.div_ceil(64), 1, 1],
        );
        Ok(())
    })
    .unwrap();
    let v: Vec<f32> = out.read(&ctx).unwrap();
    let close = |a: f32, b: f32, what: &str, i: u32| {
        assert!((a - b).abs() <= 2e-5, "{what} at {i}: gpu {a} vs host {b}")
    };
    let mut tir = 0;
    for i in 0..count {
        let o = i as usize * 16;
        let angle = 1.5f32 * i as f32 / count as f32;
        let inc = Vec3::new(angle.sin(), -angle.cos(), 0.0);
        let into = optics::refract(inc, Vec3::Y, 1.0 / 1.5);
        assert_eq!(v[o] == 1.0, into.is_some(), "air→glass TIR flag at {i}");
        let t = into.unwrap();
        close(v[o + 1], t.x, "refract x", i);
        close(v[o + 2], t.y, "refract y", i);
        let out_of = optics::refract(inc, Vec3::Y, 1.5);
        assert_eq!(
            v[o + 3] == 1.0,
            out_of.is_some(),
            "glass→air TIR flag at {i} ({} deg)",
            angle.to_degrees()
        );
        if let Some(t) = out_of {
            close(v[o + 4], t.x, "refract out x", i);
            close(v[o + 5], t.y, "refract out y", i);
        } else {
            tir += 1;
        }
        let r = optics::reflect(inc, Vec3::Y);
        close(v[o + 6], r.x, "reflect x", i);
        close(v[o + 7], r.y, "reflect y", i);
        close(
            v[o + 8],
            optics::fresnel_schlick(0.04, angle.cos()),
            "fresnel",
            i,
        );
        let h = sampling::halton_2_3(i + 1);
        close(v[o + 9], h[0], "halton 2", i);
        close(v[o + 10], h[1], "halton 3", i);
        let s = sampling::sobol_owen(i, 1234);
        close(v[o + 11], s[0], "sobol x", i);
        close(v[o + 12], s[1], "sobol y", i);
        assert_eq!(
            v[o + 13],
            (sampling::hash_u32(i) >> 8) as f32,
            "hash at {i}"
        );
    }
    // Angles above asin(1/1.5) = 0.7297 rad of the 1.5 rad sweep are totally reflected: ~131 of 256.
    assert!((126..136).contains(&tir), "{tir} TIR cases");
    support::assert_validation_clean(&ctx);
}

//! Rust `repr(C)` records vs their GLSL declarations in `shaders/common/scene.glsl`: every
//! field read on the GPU must come back equal to the bytes Rust wrote.

mod common;

use bytemuck::Pod;
use rqr::scene::layout::*;
use rqr::vk::{vk, Binding, Buffer, ComputePipeline, MemoryLocation};

/// Fills a record with distinct words (so a shifted field cannot match by accident).
fn distinct<T: Pod>(seed: u32) -> T {
    let mut value = T::zeroed();
    for (i, w) in bytemuck::cast_slice_mut::<T, u32>(std::slice::from_mut(&mut value))
        .iter_mut()
        .enumerate()
    {
        *w = seed.wrapping_mul(1000).wrapping_add(i as u32 + 1);
    }
    value
}

fn words<T: Pod>(v: &T) -> Vec<u32> {
    bytemuck::cast_slice::<T, u32>(std::slice::from_ref(v)).to_vec()
}

#[test]
fn scene_records_match_glsl_layout() {
    let ctx = common::gpu();
    let vertex: GpuVertex = distinct(2);
    let geometry: GpuGeometry = distinct(3);
    let instance: GpuInstance = distinct(4);
    let material: GpuMaterial = distinct(5);
    let light: GpuLight = distinct(6);
    let none = vk::BufferUsageFlags::empty();
    let positions = Buffer::from_slice(&ctx, "positions", &[[0f32; 3]], none).unwrap();
    let attributes = Buffer::from_slice(&ctx, "attributes", &[vertex], none).unwrap();
    let indices = Buffer::from_slice(&ctx, "indices", &[0u32; 3], none).unwrap();
    let geometries = Buffer::from_slice(&ctx, "geometries", &[geometry], none).unwrap();
    let instances = Buffer::from_slice(&ctx, "instances", &[instance], none).unwrap();
    let materials = Buffer::from_slice(&ctx, "materials", &[material], none).unwrap();
    let lights = Buffer::from_slice(&ctx, "lights", &[light], none).unwrap();
    let mut refs: GpuSceneRefs = distinct(1);
    refs.positions = positions.address();
    refs.attributes = attributes.address();
    refs.indices = indices.address();
    refs.geometries = geometries.address();
    refs.instances = instances.address();
    refs.materials = materials.address();
    refs.lights = lights.address();
    let refs_buf =
        Buffer::from_slice(&ctx, "refs", &[refs], vk::BufferUsageFlags::UNIFORM_BUFFER).unwrap();

    let expected: Vec<u32> = [
        words(&refs),
        words(&vertex),
        words(&geometry),
        words(&instance),
        words(&material),
        words(&light),
    ]
    .concat();
    let out = Buffer::new(
        &ctx,
        "out",
        expected.len() as u64 * 4,
        none,
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    let pipeline = ComputePipeline::new(
        &ctx,
        "layout",
        rqr::shaders::LAYOUT_COMP,
        &[
            Binding::UniformBuffer,
            Binding::SampledImages(1),
            Binding::StorageBuffer,
        ],
        0,
    )
    .unwrap();
    let set = pipeline.allocate_set().unwrap();
    set.buffer(0, &refs_buf, Binding::UniformBuffer)
        .buffer(2, &out, Binding::StorageBuffer);
    ctx.run("layout", |cmd| {
        pipeline.dispatch(cmd, Some(&set), &[], [1, 1, 1]);
        Ok(())
    })
    .unwrap();
    let got: Vec<u32> = out.read(&ctx).unwrap();
    let names = [
        "SceneRefs",
        "GpuVertex",
        "GpuGeometry",
        "GpuInstance",
        "GpuMaterial",
        "GpuLight",
    ];
    let sizes = [
        words(&refs).len(),
        words(&vertex).len(),
        words(&geometry).len(),
        words(&instance).len(),
        words(&material).len(),
        words(&light).len(),
    ];
    let mut at = 0;
    for (name, size) in names.iter().zip(sizes) {
        assert_eq!(
            got[at..at + size],
            expected[at..at + size],
            "{name} layout differs between Rust and GLSL"
        );
        at += size;
    }
    common::assert_validation_clean(&ctx);
}

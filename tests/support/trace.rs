//! Traces rays through `shaders/test/bvh_trace.comp` with either ray backend.

use bytemuck::{Pod, Zeroable};
use rqr::accel::bvh::cpu::Ray;
use rqr::scene::gpu::GpuScene;
use rqr::scene::Scene;
use rqr::vk::{vk, Binding, Buffer, ComputePipeline, Context, DescriptorSet, MemoryLocation};

/// A ray as `bvh_trace.comp` reads it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TestRay {
    pub origin: [f32; 3],
    pub tmin: f32,
    pub dir: [f32; 3],
    pub tmax: f32,
}

/// `trace_closest` and `trace_any` of one ray as `bvh_trace.comp` writes them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct TestHit {
    pub t: f32,
    pub instance: i32,
    pub primitive: i32,
    pub barycentrics: [f32; 2],
    pub any_hit: u32,
}

/// Traces `rays` with the shader variant `spirv`, whose binding 2 has type `accel_binding`
/// and is written by `bind_accel` (which keeps the acceleration structure alive until the
/// dispatch finished).
pub fn trace_with(
    ctx: &Context,
    scene: &Scene,
    rays: &[Ray],
    spirv: &[u8],
    accel_binding: Binding,
    bind_accel: impl FnOnce(&DescriptorSet, &GpuScene) -> Box<dyn std::any::Any>,
) -> Vec<TestHit> {
    let gpu_scene = GpuScene::upload(ctx, scene, 0).unwrap();
    let input: Vec<TestRay> = rays
        .iter()
        .map(|r| TestRay {
            origin: r.origin.to_array(),
            tmin: r.tmin,
            dir: r.dir.to_array(),
            tmax: r.tmax,
        })
        .collect();
    let ray_buf = Buffer::from_slice(ctx, "rays", &input, vk::BufferUsageFlags::empty()).unwrap();
    let hit_buf = Buffer::new(
        ctx,
        "hits",
        (rays.len() * std::mem::size_of::<TestHit>()) as u64,
        vk::BufferUsageFlags::empty(),
        MemoryLocation::GpuOnly,
    )
    .unwrap();
    let pipeline = ComputePipeline::new(
        ctx,
        "bvh trace",
        spirv,
        &[
            Binding::UniformBuffer,
            Binding::SampledImages(1),
            accel_binding,
            Binding::StorageBuffer,
            Binding::StorageBuffer,
        ],
        4,
    )
    .unwrap();
    let set = pipeline.allocate_set().unwrap();
    gpu_scene.bind(&set);
    set.buffer(3, &ray_buf, Binding::StorageBuffer)
        .buffer(4, &hit_buf, Binding::StorageBuffer);
    let _keep_alive = bind_accel(&set, &gpu_scene);
    let count = rays.len() as u32;
    ctx.run("bvh trace", |cmd| {
        pipeline.dispatch(
            cmd,
            Some(&set),
            &count.to_le_bytes(),
            [count.div_ceil(64), 1, 1],
        );
        Ok(())
    })
    .unwrap();
    hit_buf.read(ctx).unwrap()
}

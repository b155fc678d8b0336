//! Device limits and GPU faults in the library: memory estimates checked before allocating
//! (render targets, acceleration structures, BVH), storage-buffer range, and a fence timeout
//! in the middle of a frame that leaves the device usable and validation clean.

use std::time::Duration;

use crate::support::{assert_validation_clean, gpu};
use glam::Mat4;
use rqr::accel::bvh::{BvhBuildOptions, BvhError, GpuBvh};
use rqr::accel::{hw::HwAccel, Backend};
use rqr::render::drivers::sequence::{CameraPath, Sequence, SequenceOptions};
use rqr::render::passes::draw_list;
use rqr::render::passes::gbuffer::GbufferLayout;
use rqr::render::readback::readback_bytes;
use rqr::render::temporal::{Reprojector, ReuseOptions};
use rqr::render::RenderPath;
use rqr::render::{RenderSettings, Renderer};
use rqr::scene::gpu::GpuScene;
use rqr::scene::procedural::{assemble, cornell, look_at, sphere};
use rqr::scene::textures::GpuTextures;
use rqr::scene::{ImageData, Instance, Material, Scene};
use rqr::vk::VkError;

/// Bytes of one pixel's AOV record.
const AOV: u64 = std::mem::size_of::<rqr::interface::Aov>() as u64;

fn settings(width: u32, height: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        spp,
        ..Default::default()
    }
}

/// One sphere of about 2 × `segments`² triangles.
fn dense_sphere(segments: u32) -> Scene {
    assemble(
        vec![sphere(0, segments, segments)],
        vec![Instance {
            geometry: 0,
            transform: Mat4::IDENTITY,
            node: 0,
        }],
        vec![Material::default()],
        Vec::new(),
        vec![look_at(
            glam::Vec3::new(0.0, 0.0, 4.0),
            glam::Vec3::ZERO,
            45.0,
        )],
    )
}

#[test]
fn render_estimates_grow_with_what_they_allocate() {
    let s = settings(640, 480, 1);
    let rt = s.estimate_bytes(RenderPath::RayTraced, true);
    // Colour (16 B) + AOVs (80 B) + tonemap (4 B) per pixel, plus the adaptive corners, plus
    // the readback slot: tonemapped and linear colour (20 B) and the AOVs again (80 B).
    assert!(rt >= 640 * 480 * (16 + AOV + 4 + 16 + 20 + AOV), "{rt}");
    assert!(rt <= 640 * 480 * 300, "{rt}");
    // The readback slot is what the frame allocates (counters, 20 B per pixel, AOVs).
    let counters = 4 * rqr::render::readback::RING_COUNTERS as u64;
    for aov in [false, true] {
        assert_eq!(
            readback_bytes(&s, aov),
            counters + 640 * 480 * if aov { 20 + AOV } else { 20 }
        );
    }
    // Without AOVs, no AOV buffer (a one-element placeholder is bound instead) and none in
    // the readback slot.
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        assert_eq!(
            s.estimate_bytes(path, true) - s.estimate_bytes(path, false),
            640 * 480 * 2 * AOV,
            "{path:?}"
        );
    }
    // The ray-traced path reuses its buffers for every sample; hybrid adds a G-buffer each.
    assert_eq!(
        settings(640, 480, 64).estimate_bytes(RenderPath::RayTraced, true),
        rt
    );
    let per_sample = |layout: GbufferLayout| {
        let at = |spp| {
            RenderSettings {
                gbuffer: layout,
                ..settings(640, 480, spp)
            }
            .estimate_bytes(RenderPath::Hybrid, true)
        };
        (at(4) - at(1)) / 3
    };
    assert_eq!(
        per_sample(GbufferLayout::Full),
        640 * 480 * (5 * 16 + 2 * 8 + 4),
        "7 targets + depth"
    );
    assert_eq!(
        per_sample(GbufferLayout::Visibility),
        640 * 480 * (8 + 4),
        "visibility + depth"
    );
    assert!(settings(1280, 960, 1).estimate_bytes(RenderPath::RayTraced, true) > 3 * rt);
    // The largest storage buffer is the AOV array; without AOVs, the adaptive corners.
    assert_eq!(s.largest_buffer_bytes(true), 640 * 480 * AOV);
    assert_eq!(s.largest_buffer_bytes(false), 641 * 481 * 16);
    // Absurd requests saturate instead of overflowing.
    let huge = settings(16384, 16384, 4096).estimate_bytes(RenderPath::Hybrid, true);
    assert!(huge > 1 << 40);
}

#[test]
fn memory_checks_refuse_work_before_allocating() {
    let mut ctx = gpu();
    let scene = dense_sphere(300); // ~180k triangles
    let gpu_scene = GpuScene::upload(&ctx, &scene, 0).unwrap();

    // Scene buffers and textures: checked against what is left of the heap.
    ctx.limit_device_memory(ctx.allocated_bytes() + (4 << 20));
    let err = GpuScene::upload(&ctx, &scene, 0)
        .err()
        .expect("~10 MB of mesh data in 4 MiB");
    assert!(
        err.to_string().contains("the scene's meshes need about"),
        "{err}"
    );
    assert!(GpuScene::upload(&ctx, &cornell(), 0).is_ok());
    let mut textured = cornell();
    textured.images.push(ImageData {
        width: 2048,
        height: 2048,
        rgba8: vec![255; 2048 * 2048 * 4],
        mips: Vec::new(),
        srgb: true,
        ktx2: None,
    });
    let err = GpuTextures::upload(&ctx, &textured)
        .err()
        .expect("a 16 MiB texture in 4 MiB");
    assert!(
        err.to_string().contains("the scene's textures need about"),
        "{err}"
    );

    // Acceleration structures and the BVH: checked against the heap before building.
    ctx.limit_device_memory(4 << 20);

    let err = GpuBvh::build(&ctx, &scene, &BvhBuildOptions::default())
        .err()
        .expect("a ~20 MB BVH in a 4 MiB heap");
    assert!(
        matches!(err, BvhError::TooLarge { heap, what: "estimate", .. } if heap == 4 << 20),
        "{err}"
    );
    assert!(err.to_string().contains("largest device heap"), "{err}");

    if ctx.features().ray_query {
        let err = HwAccel::build(&ctx, &scene, &gpu_scene)
            .err()
            .expect("~18 MB of BLAS in a 4 MiB heap");
        assert!(
            matches!(&err, VkError::Limit { what, needed, available } if what.contains("acceleration structures need about") && needed > available),
            "{err}"
        );
    }
    // Renderer::new reports the backend's error, for either backend.
    for backend in [Backend::Bvh, Backend::Hw] {
        if backend == Backend::Hw && !ctx.features().ray_query {
            continue;
        }
        let err = Renderer::new(&ctx, &scene, backend).err().expect("too big");
        assert!(
            err.to_string().contains("MiB") || err.to_string().contains("bytes"),
            "{err}"
        );
    }
    assert_validation_clean(&ctx);
}

#[test]
fn render_targets_are_checked_against_the_heap_and_the_storage_range() {
    let mut ctx = gpu();
    let scene = cornell();
    let camera = scene.cameras[0];
    let draws = draw_list::draws(&scene);
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();

    // Leave 1 MiB of the heap beyond what is allocated now.
    ctx.limit_device_memory(ctx.allocated_bytes() + (1 << 20));
    let err = renderer
        .render_rt(&ctx, &settings(256, 256, 1), &camera, false)
        .err()
        .expect("256² needs ~5 MiB");
    let msg = err.to_string();
    assert!(
        msg.contains("256x256") && msg.contains("of device memory"),
        "{msg}"
    );
    let full_gbuffer = RenderSettings {
        gbuffer: GbufferLayout::Full,
        ..settings(32, 32, 64)
    };
    let err = renderer
        .render_hybrid(&ctx, &draws, &full_gbuffer, &camera, false)
        .err()
        .expect("64 full G-buffers of 32² need ~7 MiB");
    assert!(err.to_string().contains("--spp"), "{err}");
    // Small frames still fit.
    let out = renderer
        .render_rt(&ctx, &settings(32, 32, 1), &camera, false)
        .unwrap();
    assert_eq!(out.color.len(), 32 * 32);

    // A resolution whose AOV buffer exceeds maxStorageBufferRange (lavapipe: 128 MiB).
    let info = ctx.info();
    let side = ((u64::from(info.max_storage_buffer_range) / AOV) as f64).sqrt() as u32 + 2;
    if side <= info.max_image_dimension_2d {
        let err = renderer
            .render_rt(&ctx, &settings(side, side, 1), &camera, true)
            .err()
            .expect("AOV buffer beyond maxStorageBufferRange");
        assert!(err.to_string().contains("maxStorageBufferRange"), "{err}");
        // Without AOVs the same resolution passes the device's storage range (checked, not
        // rendered: slow on lavapipe). The heap was limited above: lift that for this check.
        let mut info = info.clone();
        for heap in &mut info.memory_heaps {
            heap.size_bytes = 64 << 30;
        }
        let s = settings(side, side, 1);
        for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
            s.check_device(&info, path, false, 0).unwrap();
            assert!(s.check_device(&info, path, true, 0).is_err());
        }
    }
    assert_validation_clean(&ctx);
}

/// A size whose passes' buffers fit the heap but whose readback slot does not is refused
/// before anything is allocated, with the size and the way out, not by a failed allocation.
#[test]
fn the_readback_slot_is_counted_before_allocating() {
    let s = settings(512, 512, 1);
    let ring = readback_bytes(&s, false);
    assert!(ring >= 512 * 512 * 20, "{ring}");
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        // A device of its own per path: heap limits only ever shrink.
        let mut ctx = gpu();
        let scene = cornell();
        let camera = scene.cameras[0];
        let draws = draw_list::draws(&scene);
        let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
        let render = |ctx: &rqr::vk::Context| match path {
            RenderPath::RayTraced => renderer.render_rt(ctx, &s, &camera, false),
            RenderPath::Hybrid => renderer.render_hybrid(ctx, &draws, &s, &camera, false),
        };
        let needed = s.estimate_bytes(path, false);
        // With room for the estimate, the frame renders.
        ctx.limit_device_memory(ctx.allocated_bytes() + needed + (1 << 20));
        let out = render(&ctx).unwrap_or_else(|e| panic!("{path:?} with room: {e}"));
        assert_eq!(out.color.len(), 512 * 512);
        // Room for the passes' buffers, not for the readback slot on top.
        let in_use = ctx.allocated_bytes();
        ctx.limit_device_memory(in_use + needed - ring / 2);
        let err = render(&ctx)
            .err()
            .unwrap_or_else(|| panic!("{path:?}: fits only without its readback slot"));
        let msg = err.to_string();
        let mib = needed.div_ceil(1 << 20);
        assert!(
            msg.contains("512x512 at 1 spp")
                && msg.contains(&format!("needs about {mib} MiB of device memory"))
                && msg.contains("lower the resolution"),
            "{path:?}: {msg}"
        );
        assert!(!msg.contains("out of memory allocating"), "{msg}");
        assert_eq!(
            ctx.allocated_bytes(),
            in_use,
            "{path:?}: allocated before failing"
        );
        assert_validation_clean(&ctx);
    }
}

/// With geometry that moves between frames, the samples' anchors (2 × 16 bytes per pixel) are
/// checked with the sample cache before anything is allocated: a heap that holds the cache
/// only without them refuses the sequence up front, naming the anchors.
#[test]
fn reprojection_anchors_are_checked_before_allocating() {
    let s = settings(256, 256, 1);
    let anchors = Reprojector::anchor_bytes(&s);
    assert_eq!(anchors, 256 * 256 * 2 * 16);
    assert_eq!(
        Reprojector::estimate_bytes(&s, true) - Reprojector::estimate_bytes(&s, false),
        anchors
    );
    let mut ctx = gpu();
    let scene = cornell();
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let new_sequence = |ctx: &rqr::vk::Context, moving_geometry: bool| {
        let mut options = sequence_options(true);
        options.reuse.moving_geometry = moving_geometry;
        Sequence::new(
            ctx,
            &renderer,
            &scene,
            &s,
            scene.cameras[0],
            CameraPath::Static,
            options,
        )
    };
    // The same check on a device description: fits without the anchors only.
    let mut info = lavapipe_storage_range(&ctx);
    let static_total =
        Reprojector::estimate_bytes(&s, false) + s.estimate_bytes(RenderPath::RayTraced, false);
    for heap in &mut info.memory_heaps {
        heap.size_bytes = static_total + anchors / 2;
    }
    Reprojector::check_device(&s, &info, RenderPath::RayTraced, false, 0).unwrap();
    let msg = Reprojector::check_device(&s, &info, RenderPath::RayTraced, true, 0)
        .expect_err("the anchors do not fit")
        .to_string();
    assert!(msg.contains("with the anchors"), "{msg}");

    // Through Sequence::new on the device: made with the anchors allocated when they fit...
    let seq = new_sequence(&ctx, true).unwrap();
    drop(seq);
    // ...refused before allocating anything when only the static cache fits.
    let in_use = ctx.allocated_bytes();
    ctx.limit_device_memory(in_use + static_total + anchors / 2);
    let err = new_sequence(&ctx, true)
        .err()
        .expect("room for the static cache only");
    let msg = err.to_string();
    assert!(
        msg.contains("256x256 with reuse between frames")
            && msg.contains("with the anchors that move samples with their objects"),
        "{msg}"
    );
    assert_eq!(ctx.allocated_bytes(), in_use, "allocated before failing");
    assert_validation_clean(&ctx);
}

/// The device as lavapipe reports it (maxStorageBufferRange 128 MiB), with a heap and an image
/// limit that are not in the way.
fn lavapipe_storage_range(ctx: &rqr::vk::Context) -> rqr::vk::DeviceInfo {
    let mut info = ctx.info().clone();
    info.max_storage_buffer_range = 128 << 20;
    info.max_image_dimension_2d = 16384;
    for heap in &mut info.memory_heaps {
        heap.size_bytes = 64 << 30;
    }
    info
}

#[test]
fn aovs_alone_exceed_the_storage_range_at_2048() {
    let ctx = gpu();
    let info = lavapipe_storage_range(&ctx);
    let s = settings(2048, 2048, 1);
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        // Colour and corners: 16 B per pixel, 64 MiB.
        s.check_device(&info, path, false, 0)
            .unwrap_or_else(|e| panic!("{path:?} without AOVs: {e}"));
        // AOVs: 80 B per pixel, 320 MiB.
        let err = s
            .check_device(&info, path, true, 0)
            .expect_err("320 MiB of AOVs in a 128 MiB storage range");
        let msg = err.to_string();
        for needle in [
            "resolution 2048x2048 with AOVs needs a 320 MiB per-pixel buffer",
            "at most 128 MiB per storage buffer (maxStorageBufferRange)",
            "render without AOVs",
        ] {
            assert!(msg.contains(needle), "'{needle}' not in: {msg}");
        }
    }
    // Beyond what colour alone can bind, dropping AOVs is no way out: the hint says so.
    let err = settings(4096, 4096, 1)
        .check_device(&info, RenderPath::RayTraced, true, 0)
        .expect_err("256 MiB of colour");
    assert!(!err.to_string().contains("without AOVs"), "{err}");
    assert!(err.to_string().ends_with("lower the resolution"), "{err}");
}

#[test]
fn renders_without_aovs_bind_a_placeholder() {
    let ctx = gpu();
    let scene = cornell();
    let camera = scene.cameras[0];
    let draws = draw_list::draws(&scene);
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let s = settings(48, 32, 1);
    let rt = renderer.render_rt(&ctx, &s, &camera, false).unwrap();
    assert!(rt.aov.is_empty());
    assert_eq!(rt.color.len(), 48 * 32);
    assert!(rt.color.iter().any(|c| c[0] > 0.0));
    // The same frame with AOVs: identical colour, and the AOVs are all there.
    let rt_aov = renderer.render_rt(&ctx, &s, &camera, true).unwrap();
    assert_eq!(rt_aov.aov.len(), 48 * 32);
    assert!(rt_aov.aov.iter().any(|a| a.instance() >= 0));
    assert_eq!(rt_aov.color, rt.color);
    // Hybrid, with either raster layout (different shading shaders).
    for layout in [GbufferLayout::Visibility, GbufferLayout::Full] {
        let s = RenderSettings {
            gbuffer: layout,
            ..s.clone()
        };
        let hy = renderer
            .render_hybrid(&ctx, &draws, &s, &camera, false)
            .unwrap();
        assert!(hy.aov.is_empty(), "{layout:?}");
        assert!(hy.color.iter().any(|c| c[0] > 0.0), "{layout:?}");
        let hy_aov = renderer
            .render_hybrid(&ctx, &draws, &s, &camera, true)
            .unwrap();
        assert_eq!(hy_aov.aov.len(), 48 * 32, "{layout:?}");
        assert!(hy_aov.aov.iter().any(|a| a.instance() >= 0), "{layout:?}");
        assert_eq!(hy_aov.color, hy.color, "{layout:?}");
    }
    assert_validation_clean(&ctx);
}

#[test]
fn fence_timeout_mid_frame_defers_destruction_and_recovers() {
    let mut ctx = gpu();
    let scene = cornell();
    let camera = scene.cameras[0];
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    ctx.set_fence_timeout(Duration::from_millis(1));
    let err = renderer
        .render_rt(&ctx, &settings(256, 256, 16), &camera, false)
        .err()
        .expect("a 256² 16-spp frame takes more than 1 ms");
    assert!(
        matches!(&err, rqr::Error::Vk(VkError::Timeout { pass, timeout_ms: 1 }) if pass == "ray-traced frame"),
        "{err}"
    );
    // The frame's buffers and pipelines were dropped while the GPU still used them: their
    // destruction waits for the work, so the validation layer saw nothing in use destroyed.
    ctx.wait_idle().unwrap();
    assert_validation_clean(&ctx);
    ctx.set_fence_timeout(Duration::from_secs(120));
    let out = renderer
        .render_rt(&ctx, &settings(32, 32, 1), &camera, false)
        .unwrap();
    assert!(out.color.iter().any(|c| c[0] > 0.0));
    assert_validation_clean(&ctx);
}

/// Options of a sequence on the ray-traced path, with or without reprojection.
fn sequence_options(reproject: bool) -> SequenceOptions {
    SequenceOptions {
        path: RenderPath::RayTraced,
        reuse: ReuseOptions {
            reproject,
            ..Default::default()
        },
        reference: true,
    }
}

#[test]
fn reprojection_cache_is_checked_with_the_full_render() {
    let ctx = gpu();
    let mut info = lavapipe_storage_range(&ctx);
    // The sample caches hold 36 bytes per pixel: 2100² needs 152 MiB per cache, more than
    // lavapipe's 128 MiB maxStorageBufferRange, but the caches are reached through buffer
    // references, not descriptors: only the allocation limit bounds them.
    let entry = std::mem::size_of::<rqr::interface::reproject::CacheEntry>() as u64;
    assert_eq!(entry, 36);
    let s = settings(2100, 2100, 1);
    assert_eq!(Reprojector::largest_buffer_bytes(&s), 2100 * 2100 * entry);
    info.max_memory_allocation_size = 2 << 30;
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        s.check_device(&info, path, false, 0).unwrap();
        Reprojector::check_device(&s, &info, path, false, 0)
            .unwrap_or_else(|e| panic!("{path:?}: a 152 MiB cache in a 2 GiB allocation: {e}"));
    }
    info.max_memory_allocation_size = 128 << 20;
    for path in [RenderPath::RayTraced, RenderPath::Hybrid] {
        let err = Reprojector::check_device(&s, &info, path, false, 0)
            .expect_err("a 152 MiB cache in 128 MiB allocations")
            .to_string();
        for needle in [
            "resolution 2100x2100 with reuse between frames needs a 152 MiB sample cache",
            "allocates at most 128 MiB at once (maxMemoryAllocationSize)",
            "--reproject",
        ] {
            assert!(err.contains(needle), "'{needle}' not in: {err}");
        }
        Reprojector::check_device(&settings(1024, 1024, 1), &info, path, false, 0).unwrap();
    }
    info.max_memory_allocation_size = 2 << 30;

    // The heap: the cache and its per-pixel buffers (two 36-byte caches and more per pixel)
    // come on top of the full render.
    let s = settings(512, 512, 1);
    let full = s.estimate_bytes(RenderPath::RayTraced, false);
    let cache = Reprojector::estimate_bytes(&s, false);
    assert!(cache >= 512 * 512 * 2 * entry, "{cache}");
    for heap in &mut info.memory_heaps {
        heap.size_bytes = full + cache - 1;
    }
    s.check_device(&info, RenderPath::RayTraced, false, 0)
        .unwrap();
    let err = Reprojector::check_device(&s, &info, RenderPath::RayTraced, false, 0)
        .expect_err("one byte short")
        .to_string();
    assert!(
        err.contains("for the sample cache and its per-pixel buffers")
            && err.contains("of device memory"),
        "{err}"
    );
    for heap in &mut info.memory_heaps {
        heap.size_bytes = full + cache;
    }
    Reprojector::check_device(&s, &info, RenderPath::RayTraced, false, 0).unwrap();
}

#[test]
fn reuse_refuses_scenes_with_more_materials_than_cache_entries_index() {
    let ctx = gpu();
    let mut scene = cornell();
    let limit = rqr::interface::reproject::MAX_CACHE_MATERIALS as usize;
    let copy = scene.materials[0].clone();
    scene.materials.resize(limit + 1, copy);
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let s = settings(32, 32, 1);
    let new_sequence = |reproject: bool| {
        Sequence::new(
            &ctx,
            &renderer,
            &scene,
            &s,
            scene.cameras[0],
            CameraPath::Static,
            sequence_options(reproject),
        )
        .map(|_| ())
    };
    let err = new_sequence(true)
        .expect_err("65537 materials with reuse")
        .to_string();
    assert!(
        err.contains("16-bit material index") && err.contains("65537 materials"),
        "{err}"
    );
    // Without reuse the cache's material index is never read.
    new_sequence(false).unwrap();
    assert_validation_clean(&ctx);
}

#[test]
fn sequences_check_the_reprojection_cache_before_allocating() {
    let mut ctx = gpu();
    let scene = cornell();
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let new_sequence = |ctx: &rqr::vk::Context, s: &RenderSettings, reproject: bool| {
        Sequence::new(
            ctx,
            &renderer,
            &scene,
            s,
            scene.cameras[0],
            CameraPath::Static,
            sequence_options(reproject),
        )
        .map(|_| ())
    };

    // A side whose sample cache exceeds the device's maxStorageBufferRange (lavapipe: 1932)
    // but not its maxMemoryAllocationSize: the caches are not bound as descriptors, so the
    // sequence is made (nothing is allocated before the first frame).
    let info = ctx.info();
    let side = ((u64::from(info.max_storage_buffer_range)
        / std::mem::size_of::<rqr::interface::reproject::CacheEntry>() as u64)
        as f64)
        .sqrt() as u32
        + 2;
    let s = settings(side, side, 1);
    if side <= info.max_image_dimension_2d
        && s.check_device(info, RenderPath::RayTraced, false, ctx.allocated_bytes())
            .is_ok()
        && Reprojector::largest_buffer_bytes(&s) <= info.max_memory_allocation_size
    {
        new_sequence(&ctx, &s, true).unwrap_or_else(|e| panic!("{side}x{side} with reuse: {e}"));
    }

    // Leave 8 MiB: a 256² frame fits, its sample cache (~17 MiB) does not.
    ctx.limit_device_memory(ctx.allocated_bytes() + (8 << 20));
    let before = ctx.allocated_bytes();
    let err = new_sequence(&ctx, &settings(256, 256, 1), true).expect_err("cache beyond the heap");
    let msg = err.to_string();
    assert!(
        msg.contains("256x256 with reuse between frames") && msg.contains("of device memory"),
        "{msg}"
    );
    assert_eq!(ctx.allocated_bytes(), before, "allocated before failing");
    new_sequence(&ctx, &settings(256, 256, 1), false).unwrap();
    // A sequence without reuse is checked up front too.
    let err = new_sequence(&ctx, &settings(1024, 1024, 1), false).expect_err("~37 MiB frames");
    assert!(err.to_string().contains("of device memory"), "{err}");
    assert_validation_clean(&ctx);
}

/// 2048×2048 pixels are 65 536 tonemap workgroups of 64, one more than a device must launch in
/// one dimension (`maxComputeWorkGroupCount[0]`, lavapipe's 65 535): the pass dispatches them
/// in rows, and every pixel is tonemapped (validation reported the dispatch before).
#[test]
fn frames_wider_than_one_row_of_workgroups_are_tonemapped_whole() {
    let ctx = gpu();
    let scene = cornell();
    let renderer = Renderer::new(&ctx, &scene, Backend::Bvh).unwrap();
    let s = RenderSettings {
        max_depth: 1,
        ..settings(2048, 2048, 1)
    };
    let draws = draw_list::draws(&scene);
    let mut targets =
        rqr::render::FrameTargets::new(&ctx, &renderer, RenderPath::RayTraced, &s, &draws, false)
            .unwrap();
    let out = targets.render(&ctx, &scene.cameras[0]).unwrap();
    assert_eq!(out.rgba8.len(), 2048 * 2048 * 4);
    // Every pixel written (the tonemap writes them opaque), the last one included.
    let unwritten = out.rgba8.chunks(4).filter(|p| p[3] != 255).count();
    assert_eq!(unwritten, 0, "pixels the tonemap did not write");
    assert_validation_clean(&ctx);
}

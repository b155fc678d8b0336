//! Flat memory over many assets in one process: load -> upload -> render -> drop cycles of
//! tiny scenes on one device. After a warm-up, resident memory stays within +5 % of its
//! level then, and the device allocator's bytes return to their baseline after every cycle.
//! `RQR_SOAK_CYCLES` sets the number of measured cycles (default 1000).

use crate::support;

use std::path::Path;

use rqr::batch::{BatchDevice, DeviceOptions, ViewOptions};
use rqr::render::RenderPath;

/// Cycles before the baseline is taken: allocator pools, driver caches and lazily built
/// pipelines settle.
const WARM_UP: usize = 40;

/// Resident set size in bytes (Linux `/proc/self/statm`, second field, in pages).
fn rss_bytes() -> u64 {
    let statm = std::fs::read_to_string("/proc/self/statm").expect("/proc/self/statm");
    let pages: u64 = statm.split_whitespace().nth(1).unwrap().parse().unwrap();
    pages * 4096
}

#[test]
fn memory_stays_flat_over_many_load_render_drop_cycles() {
    // Resident memory is the whole process's, and the other tests of this binary run in
    // threads beside this one: the cycles run in a process of their own.
    if !support::in_own_process(
        module_path!(),
        "memory_stays_flat_over_many_load_render_drop_cycles",
        &[],
    ) {
        return;
    }
    let cycles: usize = std::env::var("RQR_SOAK_CYCLES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(1000);
    let device = BatchDevice::open(&DeviceOptions {
        autotune: false,
        validation: Some(true),
        ..Default::default()
    })
    .expect(support::INSTALL_HINT);
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/gltf");
    let scenes = [
        assets.join("Box/Box.glb"),
        assets.join("BoxTextured/BoxTextured.glb"),
    ];
    let ctx = device.context();
    assert!(ctx.validation_enabled(), "{}", support::INSTALL_HINT);
    let empty = ctx.allocated_bytes();
    let cycle = |k: usize| {
        let scene = device.load_scene(&scenes[k % 2]).unwrap();
        let cameras = scene.orbit(1, [20.0, 20.0], 40.0, k as u64, 1.0);
        let options = ViewOptions {
            width: 16,
            height: 16,
            mode: match k % 4 < 2 {
                true => RenderPath::RayTraced,
                false => RenderPath::Hybrid,
            },
            aovs: k % 3 == 0,
            ..Default::default()
        };
        let views = scene.render_views(&device, &cameras, &options).unwrap();
        assert_eq!(views[0].rgba8.len(), 16 * 16 * 4);
    };
    for k in 0..WARM_UP {
        cycle(k);
    }
    let baseline_rss = rss_bytes();
    let baseline_gpu = ctx.allocated_bytes();
    let mut peak_rss = baseline_rss;
    let started = std::time::Instant::now();
    for k in WARM_UP..WARM_UP + cycles {
        cycle(k);
        assert_eq!(
            ctx.allocated_bytes(),
            baseline_gpu,
            "device memory after cycle {k} (empty device: {empty} bytes)"
        );
        peak_rss = peak_rss.max(rss_bytes());
    }
    let end_rss = rss_bytes();
    eprintln!(
        "{cycles} cycles in {:.1} s: RSS {:.1} MiB at the baseline, peak {:.1} MiB, end {:.1} MiB; device allocator {} bytes",
        started.elapsed().as_secs_f64(),
        baseline_rss as f64 / 1048576.0,
        peak_rss as f64 / 1048576.0,
        end_rss as f64 / 1048576.0,
        baseline_gpu
    );
    assert!(
        peak_rss as f64 <= baseline_rss as f64 * 1.05,
        "RSS grew from {baseline_rss} to {peak_rss} bytes over {cycles} cycles"
    );
    support::assert_validation_clean(ctx);
}

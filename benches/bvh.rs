//! Compute-BVH benchmark: host build time and size, then primary and one-bounce diffuse ray
//! throughput on a mesh with GPU timestamps (on lavapipe "GPU time" is CPU time).
//!
//! ```sh
//! . scripts/env.sh
//! cargo bench --bench bvh -- [--mesh PATH] [--size 512] [--iters 5] [--backend bvh|hw|both]
//!     [--leaf N] [--collapse-cost X] [--reinsertion X] [--build-only] [--build-mesh PATH]...
//!     [--spv VARIANT.spv [--wg XxY] [--stats]] [--timeout-s N]
//! ```
//! Defaults: `/work/shared/meshes/bumpy_sphere_100k.glb`, 512x512, camera at (0, 0, 2.5)
//! looking at the origin, vertical fov 45 degrees (the Embree reference set-up).

use std::path::PathBuf;
use std::time::Instant;

use rqr::accel::bvh::testing::{load_mesh, scene_of};
use rqr::accel::bvh::{BvhBuildOptions, BvhData, GpuBvh};
use rqr::accel::hw::HwAccel;
use rqr::interface::{BenchHit, BenchPush as Push, BINDING_BENCH_BOUNCE, BINDING_BENCH_PRIMARY};
use rqr::scene::gpu::GpuScene;
use rqr::scene::Scene;
use rqr::vk::MemoryLocation;
use rqr::vk::{vk, Binding, Buffer, ComputePipeline, Context, ContextOptions, GpuProfiler};

struct Args {
    mesh: PathBuf,
    size: u32,
    iters: usize,
    backends: Vec<&'static str>,
    opts: BvhBuildOptions,
    build_only: bool,
    build_meshes: Vec<PathBuf>,
    spv: Option<PathBuf>,
    workgroup: [u32; 2],
    timeout_s: u64,
    stats: bool,
}

fn parse() -> Args {
    let mut a = Args {
        mesh: PathBuf::from("/work/shared/meshes/bumpy_sphere_100k.glb"),
        size: 512,
        iters: 5,
        backends: vec!["bvh"],
        opts: BvhBuildOptions::default(),
        build_only: false,
        build_meshes: Vec::new(),
        spv: None,
        workgroup: [8, 8],
        timeout_s: 60,
        stats: false,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut val = || it.next().expect("missing value");
        match arg.as_str() {
            "--mesh" => a.mesh = val().into(),
            "--size" => a.size = val().parse().expect("--size N"),
            "--iters" => a.iters = val().parse().expect("--iters N"),
            "--leaf" => a.opts.max_leaf_size = val().parse().expect("--leaf N"),
            "--collapse-cost" => {
                a.opts.collapse_traversal_cost = val().parse().expect("--collapse-cost X")
            }
            "--reinsertion" => a.opts.reinsertion_ratio = val().parse().expect("--reinsertion X"),
            "--backend" => {
                a.backends = match val().as_str() {
                    "hw" => vec!["hw"],
                    "both" => vec!["bvh", "hw"],
                    _ => vec!["bvh"],
                }
            }
            "--build-only" => a.build_only = true,
            // With a shader compiled with -DBVH_STATS (see --spv): per-ray traversal counts.
            "--stats" => a.stats = true,
            "--timeout-s" => a.timeout_s = val().parse().expect("--timeout-s N"),
            // Experiments: a bvh variant compiled outside build.rs, and its workgroup size.
            "--spv" => a.spv = Some(val().into()),
            "--wg" => {
                let v = val();
                let (x, y) = v.split_once('x').expect("--wg XxY");
                a.workgroup = [x.parse().unwrap(), y.parse().unwrap()];
            }
            "--build-mesh" => a.build_meshes.push(val().into()),
            _ => {} // `cargo bench` adds --bench
        }
    }
    a
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn build_report(path: &std::path::Path, opts: &BvhBuildOptions, runs: usize) -> (Scene, BvhData) {
    let t = Instant::now();
    let geom = load_mesh(path).unwrap_or_else(|e| panic!("{e}"));
    let load_ms = t.elapsed().as_secs_f64() * 1e3;
    let scene = scene_of(vec![geom], vec![]);
    let mut times = Vec::new();
    let mut data = None;
    for _ in 0..runs {
        let d = BvhData::build(&scene, opts).expect("build");
        times.push(d.stats.build_ms);
        data = Some(d);
    }
    let data = data.unwrap();
    let s = &data.stats;
    println!(
        "build {}: {} tris (load {load_ms:.0} ms) | host build median {:.1} ms of {runs} (min {:.1}) | {:.2} MiB ({} nodes x 64 B, {} tris x 40 B) | depth {} (tlas {}) | leaf <= {}",
        path.file_name().unwrap().to_string_lossy(),
        scene.unique_triangle_count(),
        median(times.clone()),
        times.iter().cloned().fold(f64::INFINITY, f64::min),
        s.bytes as f64 / (1024.0 * 1024.0),
        s.node_count,
        s.triangle_count,
        s.max_depth,
        s.tlas_depth,
        s.max_leaf_size,
    );
    (scene, data)
}

fn main() {
    let args = parse();
    for m in &args.build_meshes {
        build_report(m, &args.opts, 5);
    }
    let (scene, data) = build_report(&args.mesh, &args.opts, 5);
    if args.build_only {
        return;
    }
    let ctx = Context::new(&ContextOptions {
        fence_timeout: std::time::Duration::from_secs(args.timeout_s),
        ..Default::default()
    })
    .expect("Vulkan device");
    println!(
        "device: {} ({}), LP_NUM_THREADS={}",
        ctx.info().name,
        ctx.info().driver_info,
        std::env::var("LP_NUM_THREADS").unwrap_or_else(|_| "unset".into())
    );
    let gpu_scene = GpuScene::upload(&ctx, &scene, 0).expect("scene upload");
    let n = (args.size * args.size) as usize;
    let hit_bytes = (n * std::mem::size_of::<BenchHit>()) as u64;
    let none = vk::BufferUsageFlags::empty();
    let primary = Buffer::new(&ctx, "primary", hit_bytes, none, MemoryLocation::GpuOnly).unwrap();
    let bounce = Buffer::new(&ctx, "bounce", hit_bytes, none, MemoryLocation::GpuOnly).unwrap();
    for &backend in &args.backends {
        let external = args
            .spv
            .as_ref()
            .map(|p| std::fs::read(p).expect("--spv file"));
        let (spirv, binding) = match backend {
            "hw" => (
                rqr::shaders::BVH_BENCH_COMP_HW,
                Binding::AccelerationStructure,
            ),
            _ => (
                external
                    .as_deref()
                    .unwrap_or(rqr::shaders::BVH_BENCH_COMP_BVH),
                Binding::UniformBuffer,
            ),
        };
        let pipeline = ComputePipeline::new(
            &ctx,
            "bvh bench",
            spirv,
            &[
                Binding::UniformBuffer,
                Binding::SampledImages(1),
                binding,
                Binding::StorageBuffer,
                Binding::StorageBuffer,
            ],
            std::mem::size_of::<Push>() as u32,
        )
        .unwrap();
        let set = pipeline.allocate_set().unwrap();
        gpu_scene.bind(&set);
        set.buffer(BINDING_BENCH_PRIMARY, &primary, Binding::StorageBuffer)
            .buffer(BINDING_BENCH_BOUNCE, &bounce, Binding::StorageBuffer);
        let _keep_bvh;
        let _keep_hw;
        if backend == "hw" {
            let hw = HwAccel::build(&ctx, &scene, &gpu_scene).expect("hw build");
            set.acceleration_structure(2, hw.tlas());
            _keep_hw = Some(hw);
        } else {
            let t = Instant::now();
            let b = GpuBvh::upload(&ctx, &data).expect("bvh upload");
            println!(
                "bvh upload: {:.1} ms, {:.2} MiB on the device",
                t.elapsed().as_secs_f64() * 1e3,
                b.device_bytes() as f64 / (1024.0 * 1024.0)
            );
            b.bind(&set);
            _keep_bvh = Some(b);
        }
        let [wx, wy] = if backend == "hw" || args.spv.is_none() {
            [8, 8]
        } else {
            args.workgroup
        };
        let groups = [args.size.div_ceil(wx), args.size.div_ceil(wy), 1];
        let mut profiler = GpuProfiler::new(&ctx, 4).expect("timestamps");
        let (mut prim_ms, mut bounce_ms) = (Vec::new(), Vec::new());
        let (mut prim_cpu, mut bounce_cpu) = (Vec::new(), Vec::new());
        for iter in 0..args.iters + 1 {
            for mode in 0..2u32 {
                let push = Push {
                    eye: [0.0, 0.0, 2.5],
                    tan_half_fov: (45f32.to_radians() * 0.5).tan(),
                    width: args.size,
                    height: args.size,
                    mode,
                    seed: 17,
                };
                let cpu0 = process_cpu_ns();
                ctx.run("bvh bench", |cmd| {
                    profiler.reset(cmd);
                    profiler.begin(cmd, "trace");
                    pipeline.dispatch(cmd, Some(&set), bytemuck::bytes_of(&push), groups);
                    profiler.end(cmd);
                    Ok(())
                })
                .expect("dispatch");
                let cpu_ms = (process_cpu_ns() - cpu0) as f64 / 1e6;
                let ms = profiler.results().unwrap()[0].1;
                // The first iteration warms caches and the shader JIT.
                if iter > 0 {
                    if mode == 0 {
                        prim_ms.push(ms);
                        prim_cpu.push(cpu_ms);
                    } else {
                        bounce_ms.push(ms);
                        bounce_cpu.push(cpu_ms);
                    }
                }
            }
        }
        let hits: Vec<BenchHit> = primary.read(&ctx).unwrap();
        let prim_hits = hits.iter().filter(|h| h.instance >= 0).count();
        let bhits: Vec<BenchHit> = bounce.read(&ctx).unwrap();
        let bounce_hits = bhits
            .iter()
            .zip(&hits)
            .filter(|(b, p)| p.instance >= 0 && b.instance >= 0)
            .count();
        let min = |v: &[f64]| v.iter().cloned().fold(f64::INFINITY, f64::min);
        let (pm, bm) = (median(prim_ms.clone()), median(bounce_ms.clone()));
        // Shaders compiled with -DBVH_EXP_STATS report per-ray traversal counts.
        let mean = |v: &[BenchHit], f: fn(&BenchHit) -> f32| {
            v.iter().map(|h| f64::from(f(h))).sum::<f64>() / v.len() as f64
        };
        if args.stats {
            let bounced: Vec<BenchHit> = bhits
                .iter()
                .zip(&hits)
                .filter(|(_, p)| p.instance >= 0)
                .map(|(b, _)| *b)
                .collect();
            println!(
                "[{backend}] per ray: primary {:.1} nodes {:.1} triangles {:.1} iterations | bounce {:.1} nodes {:.1} triangles {:.1} iterations",
                mean(&hits, |h| h.pad),
                mean(&hits, |h| h.pad2),
                mean(&hits, |h| h.pad3),
                mean(&bounced, |h| h.pad),
                mean(&bounced, |h| h.pad2),
                mean(&bounced, |h| h.pad3),
            );
        }
        let (pc, bc) = (median(prim_cpu.clone()), median(bounce_cpu.clone()));
        println!(
            "[{backend}] CPU time: primary {pc:.1} ms -> {:.2} Mrays per CPU-s (best {:.2}) | bounce {bc:.1} ms -> {:.2} Mrays per CPU-s (best {:.2})",
            n as f64 / pc / 1e3,
            n as f64 / min(&prim_cpu) / 1e3,
            prim_hits as f64 / bc / 1e3,
            prim_hits as f64 / min(&bounce_cpu) / 1e3,
        );
        let (pmin, bmin) = (min(&prim_ms), min(&bounce_ms));
        println!(
            "[{backend}] primary {}x{}: {:.1} ms median of {} -> {:.2} Mrays/s (best {:.2}) ({} hits) | bounce: {prim_hits} rays {:.1} ms -> {:.2} Mrays/s (best {:.2}) ({bounce_hits} hit the mesh again) | all primary ms {:?}",
            args.size,
            args.size,
            pm,
            args.iters,
            n as f64 / pm / 1e3,
            n as f64 / pmin / 1e3,
            prim_hits,
            bm,
            prim_hits as f64 / bm / 1e3,
            prim_hits as f64 / bmin / 1e3,
            prim_ms.iter().map(|x| (x * 10.0).round() / 10.0).collect::<Vec<_>>(),
        );
    }
}

/// CPU time of every thread of this process (lavapipe's workers included), nanoseconds:
/// a throughput measure that other processes competing for the cores do not distort.
fn process_cpu_ns() -> u64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0;
    };
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<u64>().ok())
        .sum()
}

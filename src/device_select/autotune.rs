//! `--backend auto`, `--raster auto`, `--bvh-build auto` and `--texture-format auto` decided
//! by measurement: the first time rqr meets a device and driver version it times a small fixed
//! workload (the built-in scene at [`MEASURE_SIZE`]², the default recursion depth, as `render`
//! and `compare` run it): the ray-traced frame on `hw` and on `bvh`, frames of the two
//! alternating so that a device whose speed drifts (a CPU device on a shared machine, a GPU
//! changing clocks) slows both alike, and the hybrid path's visibility pass on the graphics
//! pipeline and on the compute rasterizer (each configuration keeps the median of its timed
//! frames); the compute BVH's build on the host and on the GPU over a fixed procedural mesh
//! ([`BUILD_MESH_STACKS`]² sphere, wall time of each whole build); and one short dispatch
//! sampling a small texture in the device's block format (BC7, else ASTC 4x4) and as RGBA8
//! ([`crate::render::passes::texture_sampling`], alternating, medians). The numbers
//! are cached as JSON in the user's cache directory (`$XDG_CACHE_HOME/rqr/autotune.json`),
//! keyed by device UUID and driver version, and every later run decides from them.
//!
//! `RQR_NO_AUTOTUNE=1` skips all of this and applies the feature rule (`hw` where the device
//! has ray queries, graphics visibility, the device-type rules of the BVH build and the
//! texture format). A cache that is missing, corrupt, from another format or unwritable only
//! costs a warning and a measurement (or the rule when measuring fails).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use serde::{Deserialize, Serialize};

use crate::accel::bvh::{BvhBuild, BvhBuildChoice};
use crate::accel::Backend;
use crate::render::passes::raster_compute::RasterMode;
use crate::scene::TextureFormat;
use crate::vk::{Context, DeviceInfo};

/// Format of the cache file; a file of another format is ignored and rewritten. Format 2: the
/// frames are measured at the default depth, alternating, median (format 1 measured depth 1,
/// where `hw` and `bvh` are close on lavapipe and a noisy minimum picked the slower one for
/// `compare`), and the BVH build times are added. Format 3: the texture-sampling times
/// (`texture_block_ms`, `texture_rgba8_ms`) are added.
pub const CACHE_FORMAT: u32 = 3;
/// `--texture-format auto` takes RGBA8 only when its sampling measured faster than the block
/// format's by more than this factor: a block format takes a quarter of the memory and, on a
/// GPU that samples it natively, less bandwidth on textures larger than the measured one,
/// and a dispatch of well under a millisecond on a GPU varies by more than a few percent
/// between runs. (lavapipe decodes BC7 in software: RGBA8 measures about 4x faster there.)
pub const TEXTURE_RGBA8_MARGIN: f64 = 1.25;
/// Segments (and rings) of the sphere ([`crate::scene::procedural::sphere`]) whose BVH builds
/// are timed (128 · (2 · 128 − 2) = 32 512 triangles).
pub const BUILD_MESH_STACKS: u32 = 128;
/// Image side of the measured frames.
pub const MEASURE_SIZE: u32 = 256;
/// Timed frames per measured configuration (after one untimed warm-up frame); the median is kept.
pub const MEASURE_FRAMES: u32 = 5;
/// Environment variable that turns measurement off (`1`).
pub const NO_AUTOTUNE_ENV: &str = "RQR_NO_AUTOTUNE";

/// What the micro-benchmark measured on one device (GPU milliseconds, median of
/// [`MEASURE_FRAMES`] frames).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Measurement {
    /// Ray-traced frame (default depth) on `hw`; `None` without ray queries.
    pub rt_hw_ms: Option<f64>,
    /// The same frame on `bvh`.
    pub rt_bvh_ms: f64,
    /// Hybrid visibility pass on the graphics pipeline.
    pub visibility_graphics_ms: f64,
    /// Hybrid visibility pass on the compute rasterizer.
    pub visibility_compute_ms: f64,
    /// Whole host build of the fixed mesh's BVH (wall milliseconds, upload included).
    pub bvh_host_build_ms: f64,
    /// Whole GPU build of the same BVH (wall milliseconds).
    pub bvh_gpu_build_ms: f64,
    /// Trilinear sampling of a small texture in one short dispatch, the texture in the
    /// device's block format (BC7, else ASTC 4x4); `None` where the device samples neither.
    pub texture_block_ms: Option<f64>,
    /// The same dispatch over the same texture as RGBA8.
    pub texture_rgba8_ms: f64,
}

/// The choices `auto` resolves to, with reasons.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Decision {
    /// Ray backend.
    pub backend: Backend,
    /// Why.
    pub backend_reason: String,
    /// What runs the hybrid visibility pass.
    pub raster: RasterMode,
    /// Why.
    pub raster_reason: String,
    /// Where the compute BVH is built.
    pub bvh_build: BvhBuild,
    /// Why.
    pub bvh_build_reason: String,
    /// How KTX2 textures upload: [`TextureFormat::Block`] or [`TextureFormat::Rgba8`].
    pub texture_format: TextureFormat,
    /// Why.
    pub texture_format_reason: String,
    /// The numbers behind the decision (`None`: the feature rule decided).
    pub measured: Option<Measurement>,
}

/// The feature rule: `hw` where the device has acceleration structures and ray queries and
/// is not a CPU device, else `bvh`; the graphics pipeline for visibility. `why` says why no
/// measurement decided.
pub fn rule(device: &DeviceInfo, why: &str) -> Decision {
    let hw_ok = device.ray_query && device.acceleration_structure;
    let (backend, features) = if hw_ok && device.device_type == "cpu" {
        // A CPU device emulates ray queries in software, far slower than the compute BVH:
        // on lavapipe a 128² frame of TransmissionTest took 27.7 s on hw and 215 ms on bvh.
        (
            Backend::Bvh,
            "a CPU device emulates ray queries; the compute-shader BVH is faster there".to_string(),
        )
    } else if hw_ok {
        (
            Backend::Hw,
            "device has VK_KHR_acceleration_structure + VK_KHR_ray_query".to_string(),
        )
    } else {
        (
            Backend::Bvh,
            format!(
                "device lacks {}; using the compute-shader BVH",
                if device.acceleration_structure {
                    "VK_KHR_ray_query"
                } else {
                    "VK_KHR_acceleration_structure"
                }
            ),
        )
    };
    let (bvh_build, build_reason) = BvhBuildChoice::Auto.resolve(device);
    let (texture_format, texture_why) = texture_rule(device);
    Decision {
        backend,
        backend_reason: format!("auto (feature rule, {why}): {features}"),
        raster: RasterMode::Graphics,
        raster_reason: format!("auto (feature rule, {why}): graphics pipeline"),
        bvh_build,
        bvh_build_reason: format!("{build_reason} (device-type rule, {why})"),
        texture_format,
        texture_format_reason: format!("auto (device-type rule, {why}): {texture_why}"),
        measured: None,
    }
}

/// The texture format without a measurement: RGBA8 where the device samples no block
/// format, and on CPU devices (which decode block formats in software per texel fetch),
/// else the device's block format.
fn texture_rule(device: &DeviceInfo) -> (TextureFormat, String) {
    match crate::scene::textures::block_format_name(device) {
        None => (
            TextureFormat::Rgba8,
            "the device samples no block format (BC7, ASTC 4x4): RGBA8".into(),
        ),
        Some(block) if device.device_type == "cpu" => (
            TextureFormat::Rgba8,
            format!("a CPU device decodes {block} in software: RGBA8"),
        ),
        Some(block) => (TextureFormat::Block, format!("{block} blocks")),
    }
}

/// The texture format from measured sampling times: the block format unless RGBA8 measured
/// faster by more than [`TEXTURE_RGBA8_MARGIN`].
fn texture_decision(m: &Measurement, device: &DeviceInfo) -> (TextureFormat, String) {
    let sampled = format!(
        "{}x{} texture, {}x{} invocations x {} trilinear samples",
        crate::render::passes::texture_sampling::TEXTURE_SIDE,
        crate::render::passes::texture_sampling::TEXTURE_SIDE,
        crate::render::passes::texture_sampling::DISPATCH_SIDE,
        crate::render::passes::texture_sampling::DISPATCH_SIDE,
        crate::render::passes::texture_sampling::SAMPLES_PER_INVOCATION,
    );
    let rgba8 = m.texture_rgba8_ms;
    match (
        crate::scene::textures::block_format_name(device),
        m.texture_block_ms,
    ) {
        (None, _) => (
            TextureFormat::Rgba8,
            "auto: the device samples no block format (BC7, ASTC 4x4): RGBA8".into(),
        ),
        (Some(block), Some(block_ms)) => {
            let format = if rgba8 * TEXTURE_RGBA8_MARGIN < block_ms {
                TextureFormat::Rgba8
            } else {
                TextureFormat::Block
            };
            (
                format,
                format!(
                    "auto (measured): sampling {block_ms:.3} ms {block} vs {rgba8:.3} ms RGBA8 ({sampled}; RGBA8 only when over {TEXTURE_RGBA8_MARGIN}x faster)"
                ),
            )
        }
        // A cache written where the device sampled no block format (or edited): the rule.
        (Some(_), None) => {
            let (format, why) = texture_rule(device);
            (
                format,
                format!("auto (device-type rule, block format not measured): {why}"),
            )
        }
    }
}

/// Decides from measured numbers: the faster ray backend (ties to `hw`), the faster
/// visibility pass (ties to graphics), the faster BVH build (ties to the host build) and the
/// texture format (the block format unless RGBA8 samples over [`TEXTURE_RGBA8_MARGIN`]
/// times faster).
pub fn decide(m: &Measurement, device: &DeviceInfo) -> Decision {
    let hw_ok = device.ray_query && device.acceleration_structure;
    let size = format!(
        "built-in scene, {MEASURE_SIZE}x{MEASURE_SIZE}, depth {}",
        crate::render::RenderSettings::default().max_depth
    );
    let (backend, backend_reason) = match m.rt_hw_ms {
        Some(hw) if hw_ok => {
            let backend = if hw <= m.rt_bvh_ms {
                Backend::Hw
            } else {
                Backend::Bvh
            };
            (
                backend,
                format!(
                    "auto (measured): ray-traced frame {hw:.3} ms on hw vs {:.3} ms on bvh ({size})",
                    m.rt_bvh_ms
                ),
            )
        }
        _ => (
            Backend::Bvh,
            format!(
                "auto (measured): no ray queries; bvh frame {:.3} ms ({size})",
                m.rt_bvh_ms
            ),
        ),
    };
    let raster = if m.visibility_compute_ms < m.visibility_graphics_ms {
        RasterMode::Compute
    } else {
        RasterMode::Graphics
    };
    let bvh_build = if m.bvh_gpu_build_ms < m.bvh_host_build_ms {
        BvhBuild::Gpu
    } else {
        BvhBuild::Host
    };
    let triangles = 2 * BUILD_MESH_STACKS * (BUILD_MESH_STACKS - 1);
    let (texture_format, texture_format_reason) = texture_decision(m, device);
    Decision {
        texture_format,
        texture_format_reason,
        backend,
        backend_reason,
        bvh_build,
        bvh_build_reason: format!(
            "auto (measured): BVH build {:.1} ms on the host vs {:.1} ms on the GPU ({triangles}-triangle sphere)",
            m.bvh_host_build_ms, m.bvh_gpu_build_ms
        ),
        raster,
        raster_reason: format!(
            "auto (measured): visibility pass {:.3} ms graphics vs {:.3} ms compute ({size})",
            m.visibility_graphics_ms, m.visibility_compute_ms
        ),
        measured: Some(m.clone()),
    }
}

/// The cache key of a device: name and driver version (a driver update re-measures). It is
/// the same on every identical GPU, so a fleet sharing `RQR_CACHE_DIR` measures once.
pub fn cache_key(device: &DeviceInfo) -> String {
    format!(
        "{}/{:#x}/{}",
        device.name, device.driver_version, device.driver_info
    )
}

/// The cache file: `autotune.json` in [`crate::cache::cache_dir`] (`RQR_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/rqr` or `~/.cache/rqr` on Linux); `None` where there is none.
pub fn cache_path() -> Option<PathBuf> {
    crate::cache::cache_dir().map(|d| d.join("autotune.json"))
}

#[derive(Serialize, Deserialize)]
struct CacheFile {
    format: u32,
    /// rqr version that wrote it (informational).
    rqr: String,
    devices: BTreeMap<String, Measurement>,
}

/// Why a cache file could not be used.
#[derive(Debug, thiserror::Error)]
pub enum CacheError {
    /// Reading or writing failed (the OS error is the source, printed by
    /// [`crate::error_chain`]).
    #[error("{path}: cannot read or write the autotune cache")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a cache file of this format.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
}

fn read_cache(path: &Path) -> Result<Option<CacheFile>, CacheError> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(source) => {
            return Err(CacheError::Io {
                path: path.display().to_string(),
                source,
            })
        }
    };
    let file: CacheFile = serde_json::from_str(&text).map_err(|e| CacheError::Invalid {
        path: path.display().to_string(),
        message: format!("not an autotune cache ({e})"),
    })?;
    if file.format != CACHE_FORMAT {
        return Err(CacheError::Invalid {
            path: path.display().to_string(),
            message: format!(
                "cache format {} (this rqr reads {CACHE_FORMAT})",
                file.format
            ),
        });
    }
    Ok(Some(file))
}

/// The cached measurement of `key` in `path`; `Ok(None)` when the file or entry is missing.
pub fn load(path: &Path, key: &str) -> Result<Option<Measurement>, CacheError> {
    Ok(read_cache(path)?.and_then(|mut f| f.devices.remove(key)))
}

/// Stores `m` under `key` in `path`, keeping other devices' entries of a readable file.
pub fn store(path: &Path, key: &str, m: &Measurement) -> Result<(), CacheError> {
    let mut file = read_cache(path).ok().flatten().unwrap_or(CacheFile {
        format: CACHE_FORMAT,
        rqr: String::new(),
        devices: BTreeMap::new(),
    });
    file.rqr = env!("CARGO_PKG_VERSION").to_string();
    file.devices.insert(key.to_string(), m.clone());
    let io = |source| CacheError::Io {
        path: path.display().to_string(),
        source,
    };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(io)?;
    }
    let text = serde_json::to_string_pretty(&file).unwrap_or_default();
    // Write then rename, so a concurrent reader never sees half a file.
    let tmp = path.with_extension(format!("json.{}", std::process::id()));
    std::fs::write(&tmp, text).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}

/// Whether `RQR_NO_AUTOTUNE=1`.
pub fn disabled() -> bool {
    std::env::var(NO_AUTOTUNE_ENV).is_ok_and(|v| v == "1")
}

/// What `rqr probe` reports for a device without opening it: the cached measurement's
/// decision, else the feature rule.
pub fn cached_decision(device: &DeviceInfo) -> Decision {
    if disabled() {
        return rule(device, "RQR_NO_AUTOTUNE=1");
    }
    let Some(path) = cache_path() else {
        return rule(device, "no cache directory");
    };
    match load(&path, &cache_key(device)) {
        Ok(Some(m)) => decide(&m, device),
        Ok(None) => rule(device, "not measured on this device yet"),
        Err(e) => {
            log::warn!("autotune cache unusable: {}", crate::error_chain(&e));
            rule(device, "autotune cache unusable")
        }
    }
}

// Measurements of this process, so that one run never measures twice (e.g. when the cache
// cannot be written).
static MEASURED: Mutex<BTreeMap<String, Measurement>> = Mutex::new(BTreeMap::new());

/// The decision for the opened device: cached numbers, else a measurement (then cached),
/// else the feature rule. Never fails: problems are logged as warnings.
pub fn decision(ctx: &Context) -> Decision {
    decision_with_cache(ctx, cache_path())
}

/// [`decision`] with the cache file at `path` (`None`: no cache file, measure once per
/// process), e.g. a directory of the caller's choosing instead of the user cache.
pub fn decision_with_cache(ctx: &Context, path: Option<PathBuf>) -> Decision {
    let device = ctx.info();
    if disabled() {
        return rule(device, "RQR_NO_AUTOTUNE=1");
    }
    let key = cache_key(device);
    if let Some(m) = MEASURED.lock().ok().and_then(|g| g.get(&key).cloned()) {
        return decide(&m, device);
    }
    if let Some(path) = &path {
        match load(path, &key) {
            Ok(Some(m)) => return decide(&m, device),
            Ok(None) => {}
            Err(e) => log::warn!(
                "autotune cache unusable, measuring again: {}",
                crate::error_chain(&e)
            ),
        }
    }
    log::info!(
        "autotune: first run on {} ({}), measuring backends, visibility passes, BVH builds and texture sampling",
        device.name,
        device.driver_info
    );
    let m = match measure(ctx) {
        Ok(m) => m,
        Err(e) => {
            log::warn!("autotune measurement failed ({e}); using the feature rule");
            return rule(device, "measurement failed");
        }
    };
    if let Ok(mut g) = MEASURED.lock() {
        g.insert(key.clone(), m.clone());
    }
    match &path {
        Some(path) => {
            if let Err(e) = store(path, &key, &m) {
                log::warn!(
                    "cannot write the autotune cache: {}",
                    crate::error_chain(&e)
                );
            }
        }
        None => log::warn!("no user cache directory; autotune results are not kept"),
    }
    decide(&m, device)
}

/// Times the fixed workload on `ctx` (see the module docs).
pub fn measure(ctx: &Context) -> crate::Result<Measurement> {
    use crate::render::passes::draw_list;
    use crate::render::{RenderSettings, Renderer};
    let scene = crate::scene::load_default()?;
    let camera = scene
        .cameras
        .first()
        .copied()
        .unwrap_or_else(|| crate::scene::auto_camera(&scene.bounds, 1.0));
    let draws = draw_list::draws(&scene);
    let settings = RenderSettings {
        width: MEASURE_SIZE,
        height: MEASURE_SIZE,
        ..Default::default()
    };
    type Render<'a> = &'a dyn Fn() -> crate::Result<crate::render::RenderOutput>;
    // The summed scopes `pick` selects (wall time where the device has no timestamps).
    let timed = |render: Render, pick: &dyn Fn(&str) -> bool| -> crate::Result<f64> {
        let start = std::time::Instant::now();
        let out = render()?;
        let wall = start.elapsed().as_secs_f64() * 1e3;
        Ok(if out.gpu_ms.is_empty() {
            wall
        } else {
            out.gpu_ms
                .iter()
                .filter(|(n, _)| pick(n))
                .map(|(_, v)| v)
                .sum()
        })
    };
    // Median per configuration over timed frames of all of them in turn; round 0 warms up.
    let alternate = |renders: &[Render], pick: &dyn Fn(&str) -> bool| -> crate::Result<Vec<f64>> {
        let mut times = vec![Vec::new(); renders.len()];
        for round in 0..=MEASURE_FRAMES {
            for (render, t) in renders.iter().zip(&mut times) {
                let ms = timed(*render, pick)?;
                if round > 0 {
                    t.push(ms);
                }
            }
        }
        Ok(times
            .into_iter()
            .map(|mut t| {
                t.sort_by(f64::total_cmp);
                t[t.len() / 2]
            })
            .collect())
    };
    let frame = |name: &str| name != "tonemap";
    let bvh = Renderer::new(ctx, &scene, Backend::Bvh)?;
    let rt_bvh = || bvh.render_rt(ctx, &settings, &camera, false);
    let (rt_hw_ms, rt_bvh_ms) = if ctx.features().ray_query {
        let hw = Renderer::new(ctx, &scene, Backend::Hw)?;
        let rt_hw = || hw.render_rt(ctx, &settings, &camera, false);
        let t = alternate(&[&rt_hw, &rt_bvh], &frame)?;
        (Some(t[0]), t[1])
    } else {
        (None, alternate(&[&rt_bvh], &frame)?[0])
    };
    let bvh = &bvh;
    let (draws, camera) = (&draws, &camera);
    let hybrid = |raster: RasterMode| {
        let s = RenderSettings {
            raster,
            ..settings.clone()
        };
        move || bvh.render_hybrid(ctx, draws, &s, camera, false)
    };
    let (graphics, compute) = (hybrid(RasterMode::Graphics), hybrid(RasterMode::Compute));
    let visibility = alternate(&[&graphics, &compute], &|n| n == "gbuffer")?;
    let (bvh_host_build_ms, bvh_gpu_build_ms) = measure_builds(ctx)?;
    let textures = crate::render::passes::texture_sampling::measure(ctx, MEASURE_FRAMES)?;
    let m = Measurement {
        rt_hw_ms,
        rt_bvh_ms,
        visibility_graphics_ms: visibility[0],
        visibility_compute_ms: visibility[1],
        bvh_host_build_ms,
        bvh_gpu_build_ms,
        texture_block_ms: textures.block.map(|(_, ms)| ms),
        texture_rgba8_ms: textures.rgba8_ms,
    };
    log::info!("autotune measured {m:?}");
    Ok(m)
}

/// Wall milliseconds of the whole host and GPU builds of the fixed sphere's BVH (minimum of
/// [`MEASURE_FRAMES`] builds each, after one warm-up build that also compiles the pipelines).
fn measure_builds(ctx: &Context) -> crate::Result<(f64, f64)> {
    use crate::accel::bvh::{BvhBuildOptions, GpuBvh};
    let scene = crate::scene::procedural::single_mesh(crate::scene::procedural::sphere(
        0,
        BUILD_MESH_STACKS,
        BUILD_MESH_STACKS,
    ));
    let opts = BvhBuildOptions::default();
    let mut best = [f64::INFINITY; 2];
    for (slot, build) in [BvhBuild::Host, BvhBuild::Gpu].into_iter().enumerate() {
        for i in 0..=MEASURE_FRAMES {
            let start = std::time::Instant::now();
            let bvh = GpuBvh::build_with(ctx, &scene, &opts, build)?;
            drop(bvh);
            if i > 0 {
                best[slot] = best[slot].min(start.elapsed().as_secs_f64() * 1e3);
            }
        }
    }
    Ok((best[0], best[1]))
}

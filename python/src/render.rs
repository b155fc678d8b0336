//! Rendering a batch of views of one uploaded scene into numpy arrays: one set of frame
//! targets for the batch, one submission per view, the AOVs converted on the host (ids from
//! the GPU's uint32, where a miss is `u32::MAX`, to int32 with -1 on a miss).

use std::path::PathBuf;
use std::time::Instant;

use glam::Mat4;
use numpy::ndarray::{Array1, Array3, Array4};
use numpy::IntoPyArray;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rqr::render::drivers::targets::FrameTargets;
use rqr::render::{RenderPath, RenderSettings, SamplerKind, Shading, Tonemap};
use rqr::scene::{Camera, Projection};

use crate::device::SharedDevice;
use crate::scene::{Scene, Uploaded};

/// The AOVs `render` can return.
pub const AOVS: &[&str] = &[
    "rgb",
    "depth",
    "z",
    "normal",
    "geometric_normal",
    "albedo",
    "instance",
    "primitive",
    "mask",
];

/// AOVs that need the renderer's per-pixel primary-hit buffer.
const HIT_AOVS: &[&str] = &[
    "depth",
    "z",
    "normal",
    "geometric_normal",
    "albedo",
    "instance",
    "primitive",
    "mask",
];

/// Largest image side (as the CLI).
const MAX_SIDE: u32 = 16384;

/// A validated render call, owned (it crosses into the GIL-free section).
pub(crate) struct Request {
    cameras: Vec<Camera>,
    settings: RenderSettings,
    path: RenderPath,
    environment: Option<PathBuf>,
    aovs: Vec<String>,
    /// Return 8-bit tonemapped sRGB instead of linear float colour.
    eight_bit: bool,
}

fn bad(message: String) -> PyErr {
    PyValueError::new_err(message)
}

impl Request {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        c2w: &numpy::PyReadonlyArray3<'_, f32>,
        fov_y: &numpy::PyReadonlyArray1<'_, f32>,
        width: u32,
        height: u32,
        mode: &str,
        shading: &str,
        spp: u32,
        max_depth: u32,
        seed: u32,
        environment: Option<PathBuf>,
        aovs: Vec<String>,
        tonemap: Option<String>,
    ) -> PyResult<Self> {
        let c2w = c2w.as_array();
        let fov_y = fov_y.as_array();
        let shape = c2w.shape();
        if shape[1] != 4 || shape[2] != 4 {
            return Err(bad(format!("c2w has shape {shape:?}; expected [N, 4, 4]")));
        }
        let n = shape[0];
        if n == 0 {
            return Err(bad("no cameras to render".into()));
        }
        if fov_y.len() != n {
            return Err(bad(format!(
                "{} fields of view for {n} cameras",
                fov_y.len()
            )));
        }
        let path = match mode {
            "rt" => RenderPath::RayTraced,
            "hybrid" => RenderPath::Hybrid,
            other => {
                return Err(bad(format!(
                    "mode={other:?}: expected \"rt\" or \"hybrid\""
                )))
            }
        };
        let shading = match shading {
            "whitted" => Shading::Whitted,
            "distributed" => Shading::Distributed,
            other => {
                return Err(bad(format!(
                    "shading={other:?}: expected \"whitted\" or \"distributed\""
                )))
            }
        };
        for a in &aovs {
            if !AOVS.contains(&a.as_str()) {
                return Err(bad(format!(
                    "unknown aov {a:?} (known: {})",
                    AOVS.join(", ")
                )));
            }
        }
        let (tonemap, eight_bit) = match tonemap.as_deref() {
            None => (Tonemap::None, false),
            Some("srgb8") => (Tonemap::None, true),
            Some("khronos_neutral") => (Tonemap::KhronosNeutral, true),
            Some("aces") => (Tonemap::Aces, true),
            Some(other) => {
                return Err(bad(format!(
                    "tonemap={other:?}: expected None, \"srgb8\" (clamp, sRGB), \"khronos_neutral\" or \"aces\""
                )))
            }
        };
        let mut cameras = Vec::with_capacity(n);
        for v in 0..n {
            let mut cols = [0f32; 16];
            for r in 0..4 {
                for c in 0..4 {
                    cols[c * 4 + r] = c2w[[v, r, c]];
                }
            }
            let m = Mat4::from_cols_array(&cols);
            if !cols.iter().all(|x| x.is_finite()) {
                return Err(bad(format!("camera {v}: c2w has non-finite entries")));
            }
            let yfov = fov_y[v];
            if !(yfov > 0.0 && yfov < std::f32::consts::PI) {
                return Err(bad(format!(
                    "camera {v}: vertical field of view {} deg is not in (0, 180)",
                    yfov.to_degrees()
                )));
            }
            cameras.push(Camera {
                camera_to_world: m,
                projection: Projection::Perspective {
                    yfov,
                    aspect: None,
                    znear: 0.0,
                    zfar: None,
                },
            });
        }
        let settings = RenderSettings {
            width,
            height,
            spp,
            max_depth,
            seed,
            tonemap,
            shading,
            // Distributed samples spread over the pixel (Owen-scrambled Sobol); Whitted keeps
            // the pixel centres.
            sampler: match shading {
                Shading::Whitted => SamplerKind::Center,
                Shading::Distributed => SamplerKind::Sobol,
            },
            ..Default::default()
        };
        settings
            .validate(MAX_SIDE)
            .map_err(|e| bad(e.to_string()))?;
        Ok(Self {
            cameras,
            settings,
            path,
            environment,
            aovs,
            eight_bit,
        })
    }

    fn wants(&self, aov: &str) -> bool {
        self.aovs.iter().any(|a| a == aov)
    }
}

/// Host arrays of a batch, filled view by view.
#[derive(Default)]
struct Batch {
    rgb: Vec<f32>,
    rgb8: Vec<u8>,
    depth: Vec<f32>,
    z: Vec<f32>,
    normal: Vec<f32>,
    geometric_normal: Vec<f32>,
    albedo: Vec<f32>,
    instance: Vec<i32>,
    primitive: Vec<i32>,
    gpu_ms: Vec<(String, f64)>,
    view_gpu_ms: Vec<f64>,
    rays: [u64; 4],
    samples: u64,
    wall_ms: Vec<(&'static str, f64)>,
}

/// Lights the scene with `environment`: the map is prepared (and, for a scene lit by the
/// default rig, a renderer without it is built, as the CLI drops the rig) when it changes.
fn light(
    d: &crate::device::Device,
    host: &rqr::scene::Scene,
    gpu: &mut Uploaded,
    environment: &Option<PathBuf>,
    wall: &mut Vec<(&'static str, f64)>,
) -> PyResult<()> {
    let Some(map_path) = environment else {
        return Ok(());
    };
    let t = Instant::now();
    if gpu.environment.as_ref() != Some(map_path) {
        let source = rqr::environment::EnvironmentSource::parse(&map_path.to_string_lossy())
            .map_err(|e| bad(e.to_string()))?;
        if !matches!(source, rqr::environment::EnvironmentSource::File(_)) {
            // The sky needs its sun added to the scene, which this package does not do yet:
            // refuse rather than render a sky without its sun.
            return Err(bad(format!(
                "environment {map_path:?}: the built-in environments (sky, studio) are for the \
                 CLI and rqr batch; give a .hdr or .exr path, or None"
            )));
        }
        let map = source
            .load()
            .map_err(|e| bad(e.to_string()))?
            .ok_or_else(|| bad("environment: give a .hdr or .exr path, or None".into()))?;
        let env = rqr::environment::GpuEnvironment::prepare(&d.ctx, &map)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        if host.default_lights && gpu.under_environment.is_none() {
            let mut unlit = host.clone();
            unlit.drop_default_lights();
            gpu.under_environment = Some(
                rqr::render::Renderer::with_bvh_build(&d.ctx, &unlit, d.backend, d.bvh_build)
                    .map_err(crate::to_py_err)?,
            );
        }
        let target = match gpu.under_environment.as_mut() {
            Some(r) => r,
            None => &mut gpu.plain,
        };
        target
            .set_environment(&d.ctx, Some(env))
            .map_err(crate::to_py_err)?;
        gpu.environment = Some(map_path.clone());
        wall.push(("environment", t.elapsed().as_secs_f64() * 1e3));
    }
    Ok(())
}

fn run(device: &SharedDevice, scene: &Scene, req: &Request) -> PyResult<Batch> {
    let d = device.get("rqr.Renderer")?;
    if !std::sync::Arc::ptr_eq(device, &scene.device) {
        return Err(bad(
            "this scene was loaded by another rqr.Renderer: load it with this one".into(),
        ));
    }
    let _gpu_lock = d
        .gpu
        .lock()
        .map_err(|_| PyRuntimeError::new_err("device lock poisoned"))?;
    let mut gpu_guard = scene
        .gpu
        .lock()
        .map_err(|_| PyRuntimeError::new_err("scene lock poisoned"))?;
    let gpu = gpu_guard.get_mut("rqr scene")?;
    let mut batch = Batch::default();
    // Environments that scenes with lights of their own keep must not leak into renders
    // without one: the plain renderer is lit by a map only for such scenes.
    if req.environment.is_none() && !scene.host.default_lights && gpu.environment.is_some() {
        // `set_environment(None)`, not `take_environment`: the latter leaves the scene's
        // GPU references pointing at the removed environment textures.
        gpu.plain
            .set_environment(&d.ctx, None)
            .map_err(crate::to_py_err)?;
        gpu.environment = None;
    }
    let mut wall = Vec::new();
    light(d, &scene.host, gpu, &req.environment, &mut wall)?;
    let renderer = match (&gpu.under_environment, req.environment.is_some()) {
        (Some(r), true) => r,
        _ => &gpu.plain,
    };
    let mut settings = req.settings.clone();
    settings.raster = d.raster;
    let write_aov = HIT_AOVS.iter().any(|a| req.wants(a));
    let t = Instant::now();
    let mut targets =
        FrameTargets::new(&d.ctx, renderer, req.path, &settings, &gpu.draws, write_aov)
            .map_err(crate::to_py_err)?;
    wall.push(("allocate", t.elapsed().as_secs_f64() * 1e3));
    let pixels = settings.pixels() as usize;
    let n = req.cameras.len();
    let reserve = |on: bool, per: usize| if on { n * pixels * per } else { 0 };
    batch
        .rgb
        .reserve(reserve(req.wants("rgb") && !req.eight_bit, 3));
    batch
        .rgb8
        .reserve(reserve(req.wants("rgb") && req.eight_bit, 3));
    let (mut render_ms, mut convert_ms) = (0.0, 0.0);
    for cam in &req.cameras {
        let t = Instant::now();
        let out = targets.render(&d.ctx, cam).map_err(crate::to_py_err)?;
        render_ms += t.elapsed().as_secs_f64() * 1e3;
        let t = Instant::now();
        if req.wants("rgb") {
            if req.eight_bit {
                batch
                    .rgb8
                    .extend(out.rgba8.chunks_exact(4).flat_map(|p| [p[0], p[1], p[2]]));
            } else {
                batch
                    .rgb
                    .extend(out.color.iter().flat_map(|c| [c[0], c[1], c[2]]));
            }
        }
        if write_aov {
            convert_hits(&mut batch, &out.aov, cam, req);
        }
        let rays = out.rays;
        for (sum, k) in
            batch
                .rays
                .iter_mut()
                .zip([rays.primary, rays.shadow, rays.reflection, rays.refraction])
        {
            *sum += k;
        }
        batch.samples += out.samples;
        batch.view_gpu_ms.push(out.total_ms());
        for (name, ms) in out.gpu_ms {
            match batch.gpu_ms.iter_mut().find(|(n, _)| *n == name) {
                Some(e) => e.1 += ms,
                None => batch.gpu_ms.push((name, ms)),
            }
        }
        convert_ms += t.elapsed().as_secs_f64() * 1e3;
    }
    wall.push(("render", render_ms));
    wall.push(("convert", convert_ms));
    batch.wall_ms = wall;
    Ok(batch)
}

/// Converts one view's primary-hit AOVs: ids from the GPU's uint32 to int32 (-1 on a miss;
/// exact at any scene size), ray distance and view-space depth (+inf on a miss).
fn convert_hits(batch: &mut Batch, aov: &[rqr::render::Aov], cam: &Camera, req: &Request) {
    let origin = cam.camera_to_world.w_axis.truncate();
    let forward = -cam.camera_to_world.z_axis.truncate().normalize_or_zero();
    for a in aov {
        let hit = a.hit();
        let instance = a.instance();
        if req.wants("depth") {
            batch
                .depth
                .push(if hit { a.depth() } else { f32::INFINITY });
        }
        if req.wants("z") {
            let p = a.world_position();
            batch.z.push(if hit {
                (p - origin).dot(forward)
            } else {
                f32::INFINITY
            });
        }
        // The GPU writes zero normals and albedo on a miss.
        if req.wants("normal") {
            batch.normal.extend(a.shading_normal().to_array());
        }
        if req.wants("geometric_normal") {
            batch
                .geometric_normal
                .extend(a.geometric_normal().to_array());
        }
        if req.wants("albedo") {
            batch.albedo.extend(a.albedo_rgb().to_array());
        }
        if req.wants("instance") || req.wants("mask") {
            batch.instance.push(if hit { instance } else { -1 });
        }
        if req.wants("primitive") {
            batch.primitive.push(if hit { a.primitive() } else { -1 });
        }
    }
}

/// Renders the request with the GIL released; returns a dict of numpy arrays and stats.
pub(crate) fn render<'py>(
    py: Python<'py>,
    device: &SharedDevice,
    scene: &Scene,
    req: Request,
) -> PyResult<Bound<'py, PyDict>> {
    let total = Instant::now();
    let batch = py.detach(|| run(device, scene, &req))?;
    let (n, h, w) = (
        req.cameras.len(),
        req.settings.height as usize,
        req.settings.width as usize,
    );
    let shape_err = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(e.to_string());
    let out = PyDict::new(py);
    if req.wants("rgb") {
        if req.eight_bit {
            let a = Array4::from_shape_vec((n, h, w, 3), batch.rgb8).map_err(shape_err)?;
            out.set_item("rgb", a.into_pyarray(py))?;
        } else {
            let a = Array4::from_shape_vec((n, h, w, 3), batch.rgb).map_err(shape_err)?;
            out.set_item("rgb", a.into_pyarray(py))?;
        }
    }
    let plane = |v: Vec<f32>| Array3::from_shape_vec((n, h, w), v);
    if req.wants("depth") {
        out.set_item(
            "depth",
            plane(batch.depth).map_err(shape_err)?.into_pyarray(py),
        )?;
    }
    if req.wants("z") {
        out.set_item("z", plane(batch.z).map_err(shape_err)?.into_pyarray(py))?;
    }
    for (name, data) in [
        ("normal", batch.normal),
        ("geometric_normal", batch.geometric_normal),
        ("albedo", batch.albedo),
    ] {
        if req.wants(name) {
            let a = Array4::from_shape_vec((n, h, w, 3), data).map_err(shape_err)?;
            out.set_item(name, a.into_pyarray(py))?;
        }
    }
    if req.wants("mask") {
        let mask: Vec<bool> = batch.instance.iter().map(|&i| i >= 0).collect();
        let a = Array3::from_shape_vec((n, h, w), mask).map_err(shape_err)?;
        out.set_item("mask", a.into_pyarray(py))?;
    }
    if req.wants("instance") {
        let a = Array3::from_shape_vec((n, h, w), batch.instance).map_err(shape_err)?;
        out.set_item("instance", a.into_pyarray(py))?;
    }
    if req.wants("primitive") {
        let a = Array3::from_shape_vec((n, h, w), batch.primitive).map_err(shape_err)?;
        out.set_item("primitive", a.into_pyarray(py))?;
    }
    let stats = PyDict::new(py);
    let gpu = PyDict::new(py);
    for (name, ms) in &batch.gpu_ms {
        gpu.set_item(name, ms)?;
    }
    stats.set_item("gpu_ms", gpu)?;
    stats.set_item(
        "view_gpu_ms",
        Array1::from_vec(batch.view_gpu_ms).into_pyarray(py),
    )?;
    let rays = PyDict::new(py);
    for (name, k) in ["primary", "shadow", "reflection", "refraction"]
        .iter()
        .zip(batch.rays)
    {
        rays.set_item(*name, k)?;
    }
    rays.set_item("total", batch.rays.iter().sum::<u64>())?;
    stats.set_item("rays", rays)?;
    stats.set_item("samples", batch.samples)?;
    let wall = PyDict::new(py);
    for (name, ms) in &batch.wall_ms {
        wall.set_item(*name, ms)?;
    }
    wall.set_item("total", total.elapsed().as_secs_f64() * 1e3)?;
    stats.set_item("wall_ms", wall)?;
    out.set_item("stats", stats)?;
    Ok(out)
}

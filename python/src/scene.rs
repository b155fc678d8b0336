//! Scenes: parsed on the host ([`HostScene`], any thread, no device) and uploaded with their
//! acceleration structures ([`Scene`]), once, for any number of renders.

use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rqr::render::passes::draw_list::{self, Draw};
use rqr::scene::{AnimationSelection, LoadOptions};

use crate::device::{ProcessBound, SharedDevice};

/// A glTF file parsed on the host (geometry, materials, decoded textures): no device work.
#[pyclass(frozen, module = "rqr._rqr")]
pub struct HostScene {
    pub(crate) scene: Arc<rqr::scene::Scene>,
}

/// Parses `path` (None: the built-in scene) with the GIL released. Animated, skinned or
/// morphed scenes are posed at t = 0 of their first animation, as `rqr render` does.
#[pyfunction]
#[pyo3(signature = (path = None, scene = None, variant = None))]
pub fn parse(
    py: Python<'_>,
    path: Option<PathBuf>,
    scene: Option<usize>,
    variant: Option<String>,
) -> PyResult<HostScene> {
    let loaded = py.detach(move || -> rqr::Result<rqr::scene::Scene> {
        let s = match &path {
            None => rqr::scene::load_default()?,
            Some(p) => rqr::scene::load(
                p,
                &LoadOptions {
                    scene,
                    variant,
                    ..Default::default()
                },
            )?,
        };
        if !s.is_animated() {
            return Ok(s);
        }
        let animations = s.select_animations(&AnimationSelection::default())?;
        Ok(s.posed(&animations, 0.0))
    });
    Ok(HostScene {
        scene: Arc::new(loaded.map_err(crate::to_py_err)?),
    })
}

fn bounds(scene: &rqr::scene::Scene) -> ([f32; 3], [f32; 3]) {
    (scene.bounds.min.to_array(), scene.bounds.max.to_array())
}

/// One dict per instance id: node, mesh, primitive, material (index and name), triangles.
fn instances<'py>(py: Python<'py>, scene: &rqr::scene::Scene) -> PyResult<Bound<'py, PyList>> {
    let list = PyList::empty(py);
    for (id, inst) in scene.instances.iter().enumerate() {
        let d = PyDict::new(py);
        d.set_item("id", id)?;
        d.set_item("node", inst.node)?;
        if let Some(g) = scene.geometries.get(inst.geometry as usize) {
            d.set_item("mesh", g.mesh)?;
            d.set_item("primitive", g.primitive)?;
            d.set_item("material", g.material)?;
            let name = scene
                .materials
                .get(g.material as usize)
                .map(|m| m.name.clone())
                .unwrap_or_default();
            d.set_item("material_name", name)?;
            d.set_item("triangles", g.indices.len() / 3)?;
        }
        list.append(d)?;
    }
    Ok(list)
}

/// What the camera `rqr render` would use for an image of `aspect`: the scene's first camera,
/// else the automatic one. Returns (c2w rows, vertical fov in radians).
fn default_camera(scene: &rqr::scene::Scene, aspect: f32) -> ([[f32; 4]; 4], f32) {
    let cam = scene
        .cameras
        .first()
        .copied()
        .unwrap_or_else(|| rqr::scene::auto_camera(&scene.bounds, aspect));
    let yfov = match cam.projection {
        rqr::scene::Projection::Perspective { yfov, .. } => yfov,
        rqr::scene::Projection::Orthographic { .. } => f32::NAN,
    };
    (cam.camera_to_world.transpose().to_cols_array_2d(), yfov)
}

#[pymethods]
impl HostScene {
    /// Where it came from (file path or `built-in`).
    #[getter]
    fn source(&self) -> String {
        self.scene.source.clone()
    }
    /// World bounds: (min xyz, max xyz).
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        bounds(&self.scene)
    }
    /// Instances by id.
    #[getter]
    fn instances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        instances(py, &self.scene)
    }
    /// See [`default_camera`].
    fn default_camera(&self, aspect: f32) -> ([[f32; 4]; 4], f32) {
        default_camera(&self.scene, aspect)
    }
}

/// The GPU side of an uploaded scene: one renderer lit by the file's lights (or the default
/// rig), and, built when an environment is first asked for, one without the default rig
/// (lit by the environment alone, as `rqr render --environment` does).
pub(crate) struct Uploaded {
    pub(crate) plain: rqr::render::Renderer,
    pub(crate) under_environment: Option<rqr::render::Renderer>,
    /// The map `under_environment` (or `plain`, for scenes with their own lights) is lit by.
    pub(crate) environment: Option<PathBuf>,
    pub(crate) draws: Vec<Draw>,
}

/// A scene uploaded to a device with its acceleration structures.
#[pyclass(frozen, module = "rqr._rqr")]
pub struct Scene {
    pub(crate) host: Arc<rqr::scene::Scene>,
    pub(crate) device: SharedDevice,
    pub(crate) gpu: Mutex<ProcessBound<Uploaded>>,
    /// Milliseconds of the upload and acceleration-structure build.
    upload_ms: f64,
}

impl Scene {
    pub(crate) fn upload(py: Python<'_>, device: SharedDevice, host: &HostScene) -> PyResult<Self> {
        let scene = host.scene.clone();
        let dev = device.clone();
        let (uploaded, ms) = py.detach(move || -> PyResult<(Uploaded, f64)> {
            let d = dev.get("rqr.Renderer")?;
            let _gpu = d
                .gpu
                .lock()
                .map_err(|_| PyRuntimeError::new_err("device lock poisoned"))?;
            let t = std::time::Instant::now();
            let plain =
                rqr::render::Renderer::with_bvh_build(&d.ctx, &scene, d.backend, d.bvh_build)
                    .map_err(crate::to_py_err)?;
            Ok((
                Uploaded {
                    plain,
                    under_environment: None,
                    environment: None,
                    draws: draw_list::draws(&scene),
                },
                t.elapsed().as_secs_f64() * 1e3,
            ))
        })?;
        Ok(Self {
            host: host.scene.clone(),
            device,
            gpu: Mutex::new(ProcessBound::new(uploaded)),
            upload_ms: ms,
        })
    }
}

#[pymethods]
impl Scene {
    /// Where it came from (file path or `built-in`).
    #[getter]
    fn source(&self) -> String {
        self.host.source.clone()
    }
    /// World bounds: (min xyz, max xyz).
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        bounds(&self.host)
    }
    /// Instances by id.
    #[getter]
    fn instances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        instances(py, &self.host)
    }
    /// Triangles over every instance.
    #[getter]
    fn triangles(&self) -> usize {
        self.host.triangle_count()
    }
    /// Upload and acceleration-structure build, milliseconds.
    #[getter]
    fn upload_ms(&self) -> f64 {
        self.upload_ms
    }
    /// See [`default_camera`].
    fn default_camera(&self, aspect: f32) -> ([[f32; 4]; 4], f32) {
        default_camera(&self.host, aspect)
    }
}

//! The native `Renderer`: one opened Vulkan device with the ray backend, raster mode and BVH
//! build chosen for it, owned by the process that created it.

use std::mem::ManuallyDrop;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rqr::accel::bvh::BvhBuild;
use rqr::accel::{Backend, BackendChoice};
use rqr::render::passes::raster_compute::RasterMode;
use rqr::vk::{Context, ContextOptions, DeviceSelector};

/// A value that belongs to the process that made it. Vulkan objects cannot be used or
/// destroyed in a child made by `fork()` (the driver's threads and mappings are not there), so
/// in any other process the value is never dropped: it is leaked instead.
pub(crate) struct ProcessBound<T> {
    value: ManuallyDrop<T>,
    pid: u32,
}

impl<T> ProcessBound<T> {
    pub(crate) fn new(value: T) -> Self {
        Self {
            value: ManuallyDrop::new(value),
            pid: std::process::id(),
        }
    }

    /// The value, or the error a forked child gets.
    pub(crate) fn get(&self, what: &str) -> PyResult<&T> {
        self.check(what)?;
        Ok(&self.value)
    }

    /// Mutable [`Self::get`].
    pub(crate) fn get_mut(&mut self, what: &str) -> PyResult<&mut T> {
        self.check(what)?;
        Ok(&mut self.value)
    }

    fn check(&self, what: &str) -> PyResult<()> {
        let now = std::process::id();
        if now != self.pid {
            return Err(PyRuntimeError::new_err(format!(
                "this {what} was created in process {} and cannot be used in process {now} (a fork() child): Vulkan devices do not survive fork(); create a new rqr.Renderer in the child, or use multiprocessing with the 'spawn' start method",
                self.pid
            )));
        }
        Ok(())
    }
}

impl<T> Drop for ProcessBound<T> {
    fn drop(&mut self) {
        if std::process::id() == self.pid {
            // SAFETY: dropped once, here; the field is never used again.
            unsafe { ManuallyDrop::drop(&mut self.value) };
        }
    }
}

/// The opened device and what was chosen for it.
pub(crate) struct Device {
    pub(crate) ctx: Context,
    pub(crate) backend: Backend,
    pub(crate) backend_reason: String,
    pub(crate) raster: RasterMode,
    pub(crate) raster_reason: String,
    pub(crate) bvh_build: BvhBuild,
    pub(crate) bvh_build_reason: String,
    /// Serializes GPU work from several Python threads on one device.
    pub(crate) gpu: Mutex<()>,
}

/// A device shared by the renderer and the scenes uploaded to it.
pub(crate) type SharedDevice = Arc<ProcessBound<Device>>;

/// `device=`: `"auto"`, an index, `"uuid:…"` or a name substring.
#[derive(FromPyObject)]
pub(crate) enum DeviceArg {
    Index(i64),
    Text(String),
}

fn selector(arg: &DeviceArg) -> PyResult<DeviceSelector> {
    match arg {
        DeviceArg::Index(i) if *i < 0 => Err(PyValueError::new_err(format!(
            "device={i}: a device index is 0 or more (see `rqr probe`)"
        ))),
        DeviceArg::Index(i) => Ok(DeviceSelector::Index(*i as usize)),
        DeviceArg::Text(s) if s.is_empty() => Err(PyValueError::new_err(
            "device='': use \"auto\", an index, \"uuid:…\" or a name substring",
        )),
        DeviceArg::Text(s) => match s.strip_prefix("uuid:") {
            Some(uuid) => by_uuid(uuid),
            None => Ok(s.parse().unwrap_or(DeviceSelector::Auto)),
        },
    }
}

/// Normalizes a UUID for comparison: lower case, hex digits only (`GPU-` prefixes as
/// `nvidia-smi` prints them are dropped).
fn uuid_digits(s: &str) -> String {
    let s = s.trim();
    let s = s
        .strip_prefix("GPU-")
        .or_else(|| s.strip_prefix("gpu-"))
        .unwrap_or(s);
    s.chars()
        .filter(char::is_ascii_hexdigit)
        .map(|c| c.to_ascii_lowercase())
        .collect()
}

fn by_uuid(uuid: &str) -> PyResult<DeviceSelector> {
    let want = uuid_digits(uuid);
    if want.len() != 32 {
        return Err(PyValueError::new_err(format!(
            "device='uuid:{uuid}': a device UUID has 32 hex digits (see `rqr probe`)"
        )));
    }
    let report = rqr::vk::describe_devices(&DeviceSelector::Auto)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    report
        .devices
        .iter()
        .position(|d| uuid_digits(&d.device_uuid) == want)
        .map(DeviceSelector::Index)
        .ok_or_else(|| {
            let known: Vec<String> = report
                .devices
                .iter()
                .map(|d| format!("{} ({})", d.device_uuid, d.name))
                .collect();
            PyValueError::new_err(format!(
                "device='uuid:{uuid}': no Vulkan device has this UUID (devices: {})",
                known.join(", ")
            ))
        })
}

fn backend_choice(s: &str) -> PyResult<BackendChoice> {
    match s {
        "auto" => Ok(BackendChoice::Auto),
        "hw" => Ok(BackendChoice::Hw),
        "bvh" => Ok(BackendChoice::Bvh),
        other => Err(PyValueError::new_err(format!(
            "backend={other:?}: expected \"auto\", \"hw\" or \"bvh\""
        ))),
    }
}

fn open(
    selector: DeviceSelector,
    choice: BackendChoice,
    cache: Option<PathBuf>,
) -> Result<Device, String> {
    let ctx = Context::new(&ContextOptions {
        device: selector,
        validation: None,
        sync_validation: None,
        fence_timeout: Duration::from_secs(120),
    })
    .map_err(|e| e.to_string())?;
    // The measured choice (cached per device) decides what `auto` means, as in the CLI.
    let decision = rqr::device_select::autotune::decision_with_cache(&ctx, cache);
    let (backend, backend_reason) = match choice {
        BackendChoice::Auto => (decision.backend, decision.backend_reason.clone()),
        forced => forced.resolve(ctx.info()).map_err(|e| e.to_string())?,
    };
    Ok(Device {
        backend,
        backend_reason,
        raster: decision.raster,
        raster_reason: decision.raster_reason,
        bvh_build: decision.bvh_build,
        bvh_build_reason: decision.bvh_build_reason,
        ctx,
        gpu: Mutex::new(()),
    })
}

/// The native renderer: an opened device. Use it through `rqr.Renderer`.
#[pyclass(frozen, module = "rqr._rqr")]
pub struct Renderer {
    device: Mutex<Option<SharedDevice>>,
    created_pid: u32,
}

impl Renderer {
    /// The open device, or the error of a closed renderer or a forked child.
    pub(crate) fn device(&self) -> PyResult<SharedDevice> {
        let guard = self
            .device
            .lock()
            .map_err(|_| PyRuntimeError::new_err("renderer state poisoned"))?;
        let device = guard
            .as_ref()
            .ok_or_else(|| PyRuntimeError::new_err("this rqr.Renderer is closed"))?;
        device.get("rqr.Renderer")?;
        Ok(device.clone())
    }
}

#[pymethods]
impl Renderer {
    /// Opens the device. `device`: "auto", an index, "uuid:…" or a name substring;
    /// `backend`: "auto", "hw" or "bvh"; `cache_dir`: where the autotune measurements are
    /// kept (default: the user cache directory).
    #[new]
    #[pyo3(signature = (device = DeviceArg::Text("auto".into()), backend = "auto", cache_dir = None))]
    fn new(
        py: Python<'_>,
        device: DeviceArg,
        backend: &str,
        cache_dir: Option<PathBuf>,
    ) -> PyResult<Self> {
        let choice = backend_choice(backend)?;
        let cache = match cache_dir {
            Some(dir) => {
                if dir.exists() && !dir.is_dir() {
                    return Err(PyValueError::new_err(format!(
                        "cache_dir={}: not a directory",
                        dir.display()
                    )));
                }
                Some(dir.join("autotune.json"))
            }
            None => rqr::device_select::autotune::cache_path(),
        };
        let selector = selector(&device)?;
        let opened = py
            .detach(|| open(selector, choice, cache))
            .map_err(PyRuntimeError::new_err)?;
        Ok(Self {
            device: Mutex::new(Some(Arc::new(ProcessBound::new(opened)))),
            created_pid: std::process::id(),
        })
    }

    /// The process id that created the renderer.
    #[getter]
    fn pid(&self) -> u32 {
        self.created_pid
    }

    /// Whether `close()` was called.
    #[getter]
    fn closed(&self) -> bool {
        self.device.lock().map(|d| d.is_none()).unwrap_or(true)
    }

    /// Releases the device (scenes still alive keep their own GPU memory until they are
    /// dropped). Closing twice is fine; in a forked child it only forgets the device.
    fn close(&self, py: Python<'_>) {
        let taken = self.device.lock().ok().and_then(|mut d| d.take());
        // Dropping waits for the device to be idle: without the GIL.
        py.detach(move || drop(taken));
    }

    /// The device: name, uuid, driver, type, and the backend, raster mode and BVH build
    /// chosen, each with why (as `rqr probe` reports them).
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let device = self.device()?;
        let d = device.get("rqr.Renderer")?;
        let i = d.ctx.info();
        let dict = PyDict::new(py);
        dict.set_item("index", i.index)?;
        dict.set_item("name", &i.name)?;
        dict.set_item("type", &i.device_type)?;
        dict.set_item("uuid", &i.device_uuid)?;
        dict.set_item("driver", &i.driver_name)?;
        dict.set_item("driver_info", &i.driver_info)?;
        dict.set_item("api_version", &i.api_version)?;
        dict.set_item("backend", d.backend.as_str())?;
        dict.set_item("backend_reason", &d.backend_reason)?;
        dict.set_item("raster", d.raster.as_str())?;
        dict.set_item("raster_reason", &d.raster_reason)?;
        dict.set_item("bvh_build", d.bvh_build.as_str())?;
        dict.set_item("bvh_build_reason", &d.bvh_build_reason)?;
        Ok(dict)
    }

    /// Uploads a parsed scene and builds its acceleration structures (once).
    fn upload(
        &self,
        py: Python<'_>,
        host: &crate::scene::HostScene,
    ) -> PyResult<crate::scene::Scene> {
        let device = self.device()?;
        crate::scene::Scene::upload(py, device, host)
    }

    /// Renders `c2w` (float32 [N,4,4], OpenGL convention) with vertical fields of view
    /// `fov_y` (float32 [N], radians); see `rqr.Renderer.render`.
    #[pyo3(signature = (scene, c2w, fov_y, width, height, mode, shading, spp, max_depth, seed, environment, aovs, tonemap))]
    #[allow(clippy::too_many_arguments)]
    fn render<'py>(
        &self,
        py: Python<'py>,
        scene: &crate::scene::Scene,
        c2w: numpy::PyReadonlyArray3<'py, f32>,
        fov_y: numpy::PyReadonlyArray1<'py, f32>,
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
    ) -> PyResult<Bound<'py, PyDict>> {
        let device = self.device()?;
        let request = crate::render::Request::new(
            &c2w,
            &fov_y,
            width,
            height,
            mode,
            shading,
            spp,
            max_depth,
            seed,
            environment,
            aovs,
            tonemap,
        )?;
        crate::render::render(py, &device, scene, request)
    }
}

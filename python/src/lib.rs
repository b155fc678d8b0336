//! `rqr._rqr`: the native half of the `rqr` Python package. The pure-Python wrapper
//! (`python/rqr/__init__.py`) holds the user-facing classes (cameras, conventions, results);
//! this module opens the device, parses and uploads scenes and renders batches of views,
//! with the GIL released for all GPU and CPU work.
//!
//! Nothing here touches Vulkan at import: the system loader (`libvulkan.so.1`) is opened
//! when the first `Renderer` is created.

mod device;
mod render;
mod scene;

use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

create_exception!(
    _rqr,
    SceneError,
    PyException,
    "A scene file could not be loaded; the message names the file and the element."
);

/// Maps a library error to the documented Python exception: scene loading errors to
/// [`SceneError`], bad arguments (environment maps given by the caller, settings) to
/// `ValueError`, everything from the device to `RuntimeError`.
pub(crate) fn to_py_err(e: rqr::Error) -> PyErr {
    match e {
        rqr::Error::Scene(e) => SceneError::new_err(e.to_string()),
        rqr::Error::Environment(e) => PyValueError::new_err(e.to_string()),
        other => PyRuntimeError::new_err(other.to_string()),
    }
}

/// Reads an OpenEXR or Radiance HDR image (e.g. the CLI's linear `.exr` output or AOVs) as
/// float32 RGBA, shape `[H, W, 4]`.
#[pyfunction]
fn read_exr<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
) -> PyResult<Bound<'py, numpy::PyArray3<f32>>> {
    use numpy::IntoPyArray;
    let (w, h, data) = py
        .detach(|| {
            let img = image::open(&path).map_err(|e| format!("{}: {e}", path.display()))?;
            let rgba = img.into_rgba32f();
            Ok::<_, String>((
                rgba.width() as usize,
                rgba.height() as usize,
                rgba.into_raw(),
            ))
        })
        .map_err(PyValueError::new_err)?;
    let arr = numpy::ndarray::Array3::from_shape_vec((h, w, 4), data)
        .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
    Ok(arr.into_pyarray(py))
}

/// The native module.
#[pymodule]
fn _rqr(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("SceneError", m.py().get_type::<SceneError>())?;
    m.add_class::<device::Renderer>()?;
    m.add_class::<scene::HostScene>()?;
    m.add_class::<scene::Scene>()?;
    m.add_function(wrap_pyfunction!(scene::parse, m)?)?;
    m.add_function(wrap_pyfunction!(read_exr, m)?)?;
    // Ids are uint32 on the GPU and int32 in numpy: exact below int32's overflow.
    m.add("AOV_ID_EXACT_LIMIT", 1u64 << 31)?;
    Ok(())
}

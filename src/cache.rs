//! Where rqr keeps what it learns about a device between runs: the autotune measurements
//! ([`crate::device_select::autotune`]) and the pipeline cache ([`crate::vk::pipeline_cache`]).
//!
//! `RQR_CACHE_DIR` names the directory (a fleet can point every node at one shared
//! directory: the files are keyed by device and driver, and written atomically); otherwise
//! `<user cache dir>/rqr` (`$XDG_CACHE_HOME/rqr` or `~/.cache/rqr` on Linux).
//! `RQR_NO_PIPELINE_CACHE=1` keeps pipelines out of it (to time a cold start).

use std::path::PathBuf;

/// The cache directory, if the platform has one.
pub fn cache_dir() -> Option<PathBuf> {
    match std::env::var_os("RQR_CACHE_DIR") {
        Some(dir) if !dir.is_empty() => Some(PathBuf::from(dir)),
        _ => dirs::cache_dir().map(|d| d.join("rqr")),
    }
}

/// Where pipeline caches go: [`cache_dir`], unless `RQR_NO_PIPELINE_CACHE=1`.
pub fn pipeline_cache_dir() -> Option<PathBuf> {
    match std::env::var("RQR_NO_PIPELINE_CACHE").is_ok_and(|v| v == "1") {
        true => None,
        false => cache_dir(),
    }
}

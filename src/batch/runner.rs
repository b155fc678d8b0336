//! Running a shard of a manifest: outputs `DIR/<id>/<view>.<ext>` (AOVs as
//! `<view>.<aov>.exr`), each written to a temporary name and renamed when complete; jobs whose
//! outputs all exist are skipped unless forced; one result line per job of the shard in
//! `DIR/results-I-of-N.jsonl`. A bad job fails alone; a lost device is reopened.
//!
//! CPU work overlaps GPU work: a loader thread reads and decodes the next job's scene while
//! the current one renders, and an encoder thread writes view k while view k + 1 renders.
//! The environment of the last job is kept for the next one naming the same (see
//! `EnvironmentCache`).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use image::{ImageBuffer, Rgb, Rgba};
use serde::Serialize;

use super::manifest::{Entry, Environment, Format, Job, Manifest};
use super::shard::Shard;
use super::{BatchDevice, RenderedView, ViewOptions};
use crate::environment::{EnvironmentSource, GpuEnvironment};
use crate::render::image::output::aov_value;
use crate::scene::{LoadOptions, Scene, SceneError};
use crate::vk::VkError;

/// How to run a shard.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Output directory.
    pub out_dir: PathBuf,
    /// The shard to run.
    pub shard: Shard,
    /// Redo jobs whose outputs exist.
    pub force: bool,
    /// Longest a job may take (load, build, every view); `None`: no limit.
    pub job_timeout: Option<Duration>,
}

/// What happened to a job.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Rendered and written.
    Ok,
    /// Every output existed already.
    Skipped,
    /// Failed (see the error).
    Failed,
}

/// Milliseconds per stage of one job (wall clock on the host, except `render_gpu_ms`: GPU
/// timestamps of the frames' passes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct StageTimes {
    /// Reading and parsing the file (texture decoding included).
    pub load_ms: f64,
    /// Decoding the images (part of `load_ms`).
    pub texture_decode_ms: f64,
    /// Uploading textures and buffers.
    pub upload_ms: f64,
    /// Acceleration-structure or BVH build.
    pub accel_build_ms: f64,
    /// GPU time of all views' passes.
    pub render_gpu_ms: f64,
    /// Host time from the first submission to the last readback.
    pub render_wall_ms: f64,
    /// Reading the images back (part of `render_wall_ms`).
    pub readback_ms: f64,
    /// Encoding and writing files (on the encoder thread, overlapping rendering).
    pub encode_ms: f64,
    /// The whole job, from its start to its last file.
    pub total_ms: f64,
}

/// One line of the results file.
#[derive(Clone, Debug, Serialize)]
pub struct JobResult {
    /// 1-based manifest line.
    pub line: usize,
    /// Job id (absent for lines without a readable one).
    pub id: Option<String>,
    /// What happened.
    pub status: Status,
    /// Why it failed.
    pub error: Option<String>,
    /// Views written (or found, when skipped).
    pub views: usize,
    /// Stage times.
    pub times: StageTimes,
    /// The camera of every view rendered, in view order (what a dataset needs with its
    /// images).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub cameras: Vec<ViewCamera>,
}

/// The camera of one view, as written to the results.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ViewCamera {
    /// Camera-to-world matrix, row-major (looks down -Z, +Y up: glTF and NeRF's convention).
    pub c2w: [[f32; 4]; 4],
    /// Vertical field of view, degrees.
    pub fov_y_deg: f32,
}

impl ViewCamera {
    fn new(camera: &crate::scene::Camera) -> Self {
        let fov_y_deg = match camera.projection {
            crate::scene::Projection::Perspective { yfov, .. } => yfov.to_degrees(),
            crate::scene::Projection::Orthographic { .. } => 0.0,
        };
        Self {
            c2w: camera.camera_to_world.transpose().to_cols_array_2d(),
            fov_y_deg,
        }
    }
}

/// A shard's totals.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Jobs of the shard (invalid lines included).
    pub jobs: usize,
    /// Rendered.
    pub ok: usize,
    /// Skipped (outputs existed).
    pub skipped: usize,
    /// Failed.
    pub failed: usize,
    /// Views rendered.
    pub views: usize,
    /// Wall-clock seconds.
    pub seconds: f64,
}

impl Summary {
    /// Views rendered per second.
    pub fn views_per_second(&self) -> f64 {
        self.views as f64 / self.seconds.max(1e-9)
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} jobs ({} rendered, {} skipped, {} failed), {} views in {:.1} s ({:.2} views/s)",
            self.jobs,
            self.ok,
            self.skipped,
            self.failed,
            self.views,
            self.seconds,
            self.views_per_second()
        )
    }
}

/// Errors that stop the whole shard (job errors go into the results instead).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// The output directory cannot be created or written.
    #[error("output directory '{dir}' is not writable")]
    OutputDir {
        /// The directory.
        dir: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The results file could not be written.
    #[error("cannot write the results file '{path}'")]
    Results {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

/// Suffix of files being written; a leftover one (from a killed run) is removed when its job
/// runs again and never counts as an output.
pub const TEMP_MARKER: &str = ".rqr-tmp";

/// The output files of view `k` of `job`: the image, then one EXR per AOV.
pub fn view_files(out_dir: &Path, job: &Job, k: usize) -> Vec<PathBuf> {
    let dir = out_dir.join(&job.id);
    let mut files = vec![dir.join(format!("{k:03}.{}", job.format.extension()))];
    files.extend(job.aovs.iter().map(|a| dir.join(format!("{k:03}.{a}.exr"))));
    files
}

/// Every output file of `job`.
pub fn job_files(out_dir: &Path, job: &Job) -> Vec<PathBuf> {
    (0..job.cameras.len())
        .flat_map(|k| view_files(out_dir, job, k))
        .collect()
}

/// Checks that `dir` exists (creating it) and takes a file.
pub fn check_output_dir(dir: &Path) -> Result<(), RunError> {
    let fail = |source| RunError::OutputDir {
        dir: dir.to_path_buf(),
        source,
    };
    std::fs::create_dir_all(dir).map_err(fail)?;
    let probe = dir.join(format!("{TEMP_MARKER}-probe-{}", std::process::id()));
    std::fs::write(&probe, b"").map_err(fail)?;
    std::fs::remove_file(&probe).map_err(fail)
}

fn temp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}{TEMP_MARKER}-{}", std::process::id()))
}

/// Removes the temporary files a killed run left in a job's directory.
fn remove_stale_temps(dir: &Path) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        if e.file_name().to_string_lossy().contains(TEMP_MARKER) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Writes `bytes` through `write` to a temporary name next to `path`, then renames it.
fn write_atomically(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), String> {
    let temp = temp_name(path);
    match write(&temp).and_then(|()| std::fs::rename(&temp, path).map_err(|e| e.to_string())) {
        Ok(()) => Ok(()),
        Err(e) => {
            let _ = std::fs::remove_file(&temp);
            Err(format!("cannot write '{}': {e}", path.display()))
        }
    }
}

/// Encodes one view's files (image, then AOVs).
fn encode_view(
    files: &[PathBuf],
    format: Format,
    aovs: &[String],
    view: &RenderedView,
) -> Result<(), String> {
    let out = &view.output;
    let (w, h) = (out.width, out.height);
    write_atomically(&files[0], |p| match format {
        Format::Png => ImageBuffer::<Rgba<u8>, _>::from_raw(w, h, out.rgba8.as_slice())
            .ok_or("pixel buffer size mismatch".to_string())?
            .save_with_format(p, image::ImageFormat::Png)
            .map_err(|e| e.to_string()),
        Format::Exr => {
            let data: Vec<f32> = out.color.iter().flatten().copied().collect();
            ImageBuffer::<Rgba<f32>, _>::from_raw(w, h, data)
                .ok_or("pixel buffer size mismatch".to_string())?
                .save_with_format(p, image::ImageFormat::OpenExr)
                .map_err(|e| e.to_string())
        }
    })?;
    for (name, file) in aovs.iter().zip(&files[1..]) {
        write_atomically(file, |p| {
            let data: Vec<f32> = out.aov.iter().flat_map(|a| aov_value(a, name)).collect();
            ImageBuffer::<Rgb<f32>, _>::from_raw(w, h, data)
                .ok_or("AOVs were not rendered".to_string())?
                .save_with_format(p, image::ImageFormat::OpenExr)
                .map_err(|e| e.to_string())
        })?;
    }
    Ok(())
}

/// A loaded scene from the loader thread: (job position, scene and decode ms, load ms).
type Loaded = (usize, Result<(Scene, f64), SceneError>, f64);

/// The environment the last job that rendered was lit with, kept for the next job that names
/// the same one (usually the default sky of every scene without lights): preparing one costs a
/// sky bake or a file decode, its mip chain, its sampling tables and an upload, 0.1 to 0.4 s a
/// job on lavapipe. One only, so that a manifest of many different maps keeps flat memory;
/// emptied before the device is reopened.
type EnvironmentCache = Option<(EnvironmentSource, GpuEnvironment)>;

/// Whether an error means the device must be reopened before the next job.
fn needs_new_device(e: &crate::Error) -> bool {
    matches!(
        e,
        crate::Error::Vk(VkError::DeviceLost { .. } | VkError::Timeout { .. })
    )
}

/// Runs the jobs of `options.shard` in `manifest` on `device`, writing files and the
/// results file; calls `progress` after every job. Job failures are in the results and the
/// summary; only an unusable output directory or results file stops the shard.
pub fn run_shard(
    device: &mut BatchDevice,
    manifest: &Manifest,
    options: &RunOptions,
    progress: &mut dyn FnMut(&JobResult),
) -> Result<Summary, RunError> {
    let start = Instant::now();
    check_output_dir(&options.out_dir)?;
    let results_path = options.out_dir.join(options.shard.results_name());
    let results_err = |source| RunError::Results {
        path: results_path.clone(),
        source,
    };
    let mut results = std::fs::File::create(&results_path).map_err(results_err)?;
    let mine: Vec<(usize, &Entry)> = manifest
        .entries
        .iter()
        .enumerate()
        .filter(|(k, e)| options.shard.owns(*k) && !matches!(e, Entry::Blank | Entry::Defaults))
        .collect();
    // Jobs to render, decided before any work so the loader thread loads only those.
    let to_render: Vec<&Job> = mine
        .iter()
        .filter_map(|(_, e)| match e {
            Entry::Job(job)
                if options.force
                    || !job_files(&options.out_dir, job).iter().all(|f| f.is_file()) =>
            {
                Some(&**job)
            }
            _ => None,
        })
        .collect();
    let scenes: Vec<PathBuf> = to_render.iter().map(|j| j.scene.clone()).collect();
    let (tx, rx) = mpsc::sync_channel::<Loaded>(1);
    // The loader runs one scene ahead of the renderer; it ends when `rx` is dropped.
    let loader = std::thread::spawn(move || {
        for (k, path) in scenes.into_iter().enumerate() {
            let t = Instant::now();
            let r = crate::scene::load_timed(&path, &LoadOptions::default());
            if tx.send((k, r, t.elapsed().as_secs_f64() * 1e3)).is_err() {
                return;
            }
        }
    });
    let mut summary = Summary::default();
    let mut next_render = 0usize;
    let mut environments: EnvironmentCache = None;
    for (index, entry) in mine {
        let line = index + 1;
        let result = match entry {
            Entry::Invalid { id, error } => JobResult {
                line,
                id: id.clone(),
                status: Status::Failed,
                error: Some(error.to_string()),
                views: 0,
                times: StageTimes::default(),
                cameras: Vec::new(),
            },
            Entry::Job(job)
                if to_render
                    .get(next_render)
                    .is_some_and(|j| std::ptr::eq(*j, &**job)) =>
            {
                let position = next_render;
                next_render += 1;
                let mut cameras = Vec::new();
                let (outcome, times) = run_job(
                    device,
                    &rx,
                    position,
                    job,
                    options,
                    &mut environments,
                    &mut cameras,
                );
                let views = match &outcome {
                    Ok(n) => *n,
                    Err(_) => 0,
                };
                summary.views += views;
                JobResult {
                    line,
                    id: Some(job.id.clone()),
                    status: if outcome.is_ok() {
                        Status::Ok
                    } else {
                        Status::Failed
                    },
                    error: outcome.err(),
                    views,
                    times,
                    cameras,
                }
            }
            Entry::Job(job) => JobResult {
                line,
                id: Some(job.id.clone()),
                status: Status::Skipped,
                error: None,
                views: job.cameras.len(),
                times: StageTimes::default(),
                cameras: Vec::new(),
            },
            Entry::Blank | Entry::Defaults => continue,
        };
        summary.jobs += 1;
        match result.status {
            Status::Ok => summary.ok += 1,
            Status::Skipped => summary.skipped += 1,
            Status::Failed => summary.failed += 1,
        }
        let line = serde_json::to_string(&result).unwrap_or_default();
        writeln!(results, "{line}")
            .and_then(|()| results.flush())
            .map_err(results_err)?;
        progress(&result);
    }
    drop(environments);
    drop(rx);
    let _ = loader.join();
    summary.seconds = start.elapsed().as_secs_f64();
    Ok(summary)
}

/// Runs one job: waits for its scene from the loader, uploads, renders every view and
/// encodes them on a thread of their own. Returns the views written, or the error.
fn run_job(
    device: &mut BatchDevice,
    loaded: &mpsc::Receiver<Loaded>,
    position: usize,
    job: &Job,
    options: &RunOptions,
    environments: &mut EnvironmentCache,
    cameras: &mut Vec<ViewCamera>,
) -> (Result<usize, String>, StageTimes) {
    let start = Instant::now();
    let deadline = options.job_timeout.map(|t| start + t);
    let mut times = StageTimes::default();
    let timeout_error = |what: &str| {
        format!(
            "job time limit of {:.1} s (--job-timeout) reached during {what}",
            options.job_timeout.unwrap_or_default().as_secs_f64()
        )
    };
    // Results of earlier jobs that timed out while loading arrive late: skip them.
    let scene = loop {
        let received = match deadline {
            Some(d) => loaded
                .recv_timeout(d.saturating_duration_since(Instant::now()))
                .map_err(|_| ()),
            None => loaded.recv().map_err(|_| ()),
        };
        match received {
            Ok((k, r, ms)) if k == position => {
                times.load_ms = ms;
                break r;
            }
            Ok(_) => continue,
            Err(()) => return (Err(timeout_error("loading")), times),
        }
    };
    let (scene, decode_ms) = match scene {
        Ok(s) => s,
        Err(e) => return (Err(e.to_string()), times),
    };
    times.texture_decode_ms = decode_ms;
    let default_timeout = device.default_fence_timeout();
    let fence = match deadline {
        Some(d) => d
            .saturating_duration_since(Instant::now())
            .max(Duration::from_millis(1)),
        None => default_timeout,
    };
    device
        .context_mut()
        .set_fence_timeout(fence.min(default_timeout));
    let result = render_job(
        device,
        scene,
        job,
        options,
        deadline,
        environments,
        &mut times,
        cameras,
    );
    device.context_mut().set_fence_timeout(default_timeout);
    times.total_ms = start.elapsed().as_secs_f64() * 1e3;
    match result {
        Ok(n) => (Ok(n), times),
        Err(e) => {
            let mut message = match &e {
                crate::Error::Vk(VkError::Timeout { .. })
                    if deadline.is_some_and(|d| Instant::now() >= d) =>
                {
                    timeout_error("rendering")
                }
                other => other.to_string(),
            };
            if needs_new_device(&e) {
                // The cached environment lives in the old device's memory.
                *environments = None;
                match device.reopen() {
                    Ok(()) => log::warn!("job '{}': {message}; the device was reopened", job.id),
                    Err(re) => message = format!("{message}; reopening the device failed: {re}"),
                }
            }
            (Err(message), times)
        }
    }
}

#[allow(clippy::too_many_arguments)] // one call site, each argument a different concern
fn render_job(
    device: &BatchDevice,
    scene: Scene,
    job: &Job,
    options: &RunOptions,
    deadline: Option<Instant>,
    environments: &mut EnvironmentCache,
    times: &mut StageTimes,
    records: &mut Vec<ViewCamera>,
) -> crate::Result<usize> {
    let source = match &job.environment {
        Environment::Default if scene.default_lights => crate::environment::default_environment(),
        Environment::Default | Environment::None => EnvironmentSource::None,
        Environment::File(path) => EnvironmentSource::File(path.clone()),
        Environment::Builtin(spec) => EnvironmentSource::parse(spec)?,
    };
    // The last job's environment when it is this one, taken out so that a job that fails
    // drops it with its scene; freed when this job needs another one; left for later jobs by
    // a job without any.
    let prepared = match environments {
        Some((cached, _)) if *cached == source => environments.take().map(|(_, env)| env),
        _ if source == EnvironmentSource::None => None,
        _ => {
            *environments = None;
            None
        }
    };
    let map = match prepared {
        Some(_) => None,
        None => source.load()?,
    };
    let mut scene = scene;
    source.light_scene(&mut scene, 0.0, 1.0)?;
    let mut loaded = device.upload(scene, times.load_ms, times.texture_decode_ms)?;
    match prepared {
        Some(env) => loaded.set_prepared_environment(device, env)?,
        None => {
            loaded.set_environment(device, map.as_ref())?;
        }
    }
    times.upload_ms = loaded.times.build.upload_ms;
    times.accel_build_ms = loaded.times.build.accel_build_ms;
    let aspect = job.width as f32 / job.height as f32;
    let cameras = job.cameras.cameras(&loaded.scene.bounds, aspect);
    records.extend(cameras.iter().map(ViewCamera::new));
    let dir = options.out_dir.join(&job.id);
    std::fs::create_dir_all(&dir).map_err(|e| crate::render::image::output::OutputError {
        path: dir.clone(),
        reason: e.to_string(),
    })?;
    remove_stale_temps(&dir);
    let view_options = ViewOptions {
        width: job.width,
        height: job.height,
        spp: job.spp,
        mode: job.mode.into(),
        aovs: !job.aovs.is_empty(),
    };
    let render_start = Instant::now();
    let (gpu_ms, readback_ms, encoded) = std::thread::scope(|scope| {
        let (tx, rx) = mpsc::sync_channel::<(usize, RenderedView)>(2);
        let encoder = scope.spawn(move || -> Result<f64, String> {
            let mut ms = 0.0;
            for (k, view) in rx {
                let t = Instant::now();
                encode_view(
                    &view_files(&options.out_dir, job, k),
                    job.format,
                    &job.aovs,
                    &view,
                )?;
                ms += t.elapsed().as_secs_f64() * 1e3;
            }
            Ok(ms)
        });
        let (mut gpu, mut readback) = (0.0, 0.0);
        let rendered = loaded.render_each(device, &cameras, &view_options, deadline, |k, view| {
            gpu += view.gpu_ms;
            readback += view.readback_ms;
            // A send fails only when the encoder stopped on an error, which join reports.
            let _ = tx.send((k, view));
            Ok(())
        });
        drop(tx);
        let encoded = encoder
            .join()
            .unwrap_or_else(|_| Err("the encoder thread panicked".into()));
        rendered.map(|()| (gpu, readback, encoded))
    })?;
    times.render_gpu_ms = gpu_ms;
    times.readback_ms = readback_ms;
    times.render_wall_ms = render_start.elapsed().as_secs_f64() * 1e3;
    times.encode_ms = encoded.map_err(|reason| crate::render::image::output::OutputError {
        path: dir.clone(),
        reason,
    })?;
    // Kept for the next job only after a job that went through (a failed take keeps none).
    if let Ok(Some(env)) = loaded.take_environment(device) {
        *environments = Some((source, env));
    }
    Ok(cameras.len())
}

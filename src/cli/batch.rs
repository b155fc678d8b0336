//! `rqr batch`: render every job of a JSON Lines manifest (or one shard of it) on one warm
//! device. See `docs/batch.md`.

use std::io::IsTerminal as _;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Context as _, Result};
use clap::Args;
use rqr::accel::BackendChoice;
use rqr::batch::manifest::{self, Format, JobFields, Mode};
use rqr::batch::runner::{self, RunOptions, Status};
use rqr::batch::shard::{self, ShardSpec};
use rqr::batch::{BatchDevice, DeviceOptions};
use rqr::vk::DeviceSelector;

use super::{outln, usage};

/// `rqr batch` arguments.
#[derive(Args, Debug)]
pub struct BatchArgs {
    /// The manifest: one JSON job per line (see docs/batch.md).
    manifest: PathBuf,
    /// Output directory: DIR/<id>/<view>.png|exr and DIR/results-I-of-N.jsonl.
    #[arg(long)]
    out: PathBuf,
    /// Which shard to render: I/N (line k of the manifest belongs to shard k mod N) or auto
    /// (Slurm job array, Kubernetes Indexed Job, else 0/1).
    #[arg(long, default_value = "0/1")]
    shard: ShardSpec,
    /// Number of shards for --shard auto: a Kubernetes Indexed Job's completions (else
    /// RQR_SHARD_COUNT); under Slurm it makes the array task id the shard index.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    shard_count: Option<u32>,
    /// Render jobs whose outputs all exist again.
    #[arg(long)]
    force: bool,
    /// Longest one job may take, in seconds (load, build, every view).
    #[arg(long, value_name = "S")]
    job_timeout: Option<f64>,
    /// Vulkan device: auto, index, name substring, or uuid:GPU-… (CUDA_VISIBLE_DEVICES and
    /// NVIDIA_VISIBLE_DEVICES are honoured under auto; see docs/batch.md).
    #[arg(long, default_value = "auto")]
    device: DeviceSelector,
    /// Ray backend.
    #[arg(long, value_enum, default_value_t = BackendChoice::Auto)]
    backend: BackendChoice,
    /// GPU fence timeout per submission, in milliseconds.
    #[arg(long, default_value_t = 120_000, value_parser = clap::value_parser!(u64).range(1..))]
    timeout_ms: u64,
    /// Override every job's width.
    #[arg(long)]
    width: Option<u32>,
    /// Override every job's height.
    #[arg(long)]
    height: Option<u32>,
    /// Override every job's samples per pixel.
    #[arg(long)]
    spp: Option<u32>,
    /// Override every job's mode: rt or hybrid.
    #[arg(long, value_parser = ["rt", "hybrid"])]
    mode: Option<String>,
    /// Override every job's format: png or exr.
    #[arg(long, value_parser = ["png", "exr"])]
    format: Option<String>,
}

impl BatchArgs {
    fn overrides(&self) -> JobFields {
        JobFields {
            width: self.width,
            height: self.height,
            spp: self.spp,
            mode: self.mode.as_deref().map(|m| match m {
                "hybrid" => Mode::Hybrid,
                _ => Mode::RayTraced,
            }),
            format: self.format.as_deref().map(|f| match f {
                "exr" => Format::Exr,
                _ => Format::Png,
            }),
            ..Default::default()
        }
    }
}

/// Runs `rqr batch`; fails (exit code 1) when any job failed.
pub fn run(args: &BatchArgs) -> Result<()> {
    let env = |name: &str| std::env::var(name).ok();
    let (shard, source) = shard::resolve(args.shard, &env, args.shard_count)?;
    log::info!("shard {shard} ({source})");
    let job_timeout = match args.job_timeout {
        Some(s) if !(s.is_finite() && s > 0.0) => {
            usage!(
                "--job-timeout",
                "--job-timeout {s} must be a positive number of seconds"
            )
        }
        Some(s) => Some(Duration::from_secs_f64(s)),
        None => None,
    };
    let manifest = manifest::read(&args.manifest, &args.overrides())
        .with_context(|| format!("cannot read the manifest '{}'", args.manifest.display()))?;
    // Before the device opens: an unusable output directory is the shard's error, not the jobs'.
    runner::check_output_dir(&args.out)?;
    let opened = std::time::Instant::now();
    let mut device = BatchDevice::open(&DeviceOptions {
        device: rqr::device_select::resolve(&args.device).map_err(anyhow::Error::from_boxed)?,
        backend: args.backend,
        fence_timeout: Duration::from_millis(args.timeout_ms),
        pipeline_cache_dir: rqr::cache::pipeline_cache_dir(),
        autotune: true,
        validation: None,
    })?;
    let open_s = opened.elapsed().as_secs_f64();
    log::info!(
        "device {} ({}), backend {}, ready in {open_s:.1} s",
        device.context().info().name,
        device.context().info().device_uuid,
        device.backend().as_str()
    );
    let owned = manifest
        .entries
        .iter()
        .enumerate()
        .filter(|(k, e)| {
            shard.owns(*k) && !matches!(e, manifest::Entry::Blank | manifest::Entry::Defaults)
        })
        .count();
    let bar = match std::io::stderr().is_terminal() {
        true => indicatif::ProgressBar::new(owned as u64),
        false => indicatif::ProgressBar::hidden(),
    };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:30} {pos}/{len} jobs {elapsed} {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let options = RunOptions {
        out_dir: args.out.clone(),
        shard,
        force: args.force,
        job_timeout,
    };
    let mut failed = 0usize;
    let summary = runner::run_shard(&mut device, &manifest, &options, &mut |r| {
        if r.status == Status::Failed {
            failed += 1;
            let what = r.id.as_deref().unwrap_or("(no id)");
            bar.suspend(|| {
                eprintln!(
                    "rqr: job {what} failed: {}",
                    r.error.as_deref().unwrap_or("")
                )
            });
        }
        bar.set_message(format!("{failed} failed"));
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    drop(device);
    outln!("shard {shard}: {summary}; device ready in {open_s:.1} s")?;
    if summary.failed > 0 {
        bail!(
            "{} of {} jobs failed (see {})",
            summary.failed,
            summary.jobs,
            args.out.join(shard.results_name()).display()
        );
    }
    Ok(())
}

//! The `rqr` command line: `probe`, `info`, `render`, `compare`, `bench`, `batch`.
//!
//! Subcommands print to stdout through [`outln!`] and [`out!`], never `println!`: a reader
//! that goes away (`rqr info | head -1`) must end the command quietly, not panic.
#![deny(clippy::print_stdout)]

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};
use rqr::accel::BackendChoice;
use rqr::device_select::report::{probe_devices, ProbeReport};
use rqr::vk::{DeviceSelector, VkError};

mod batch;
mod bench;
mod common;
mod compare;
mod info;
mod probe;
mod progress;
mod quality;
mod render;
mod report_charts;
mod report_html;

/// Exit code for "no Vulkan loader or no device".
const EXIT_NO_VULKAN: u8 = 2;

/// Exit code for a usage mistake: a flag value or combination that cannot work
/// ([`rqr::SettingsError`]), the code clap exits with on the errors it finds itself.
const EXIT_USAGE: u8 = 2;

/// Exit code when stdout's reader went away: 128 + SIGPIPE, what a shell reports for a
/// command killed by a closed pipe (`yes | head -1`), since the command did not finish.
const EXIT_STDOUT_CLOSED: u8 = 141;

/// Writing to stdout failed.
#[derive(Debug, thiserror::Error)]
pub(crate) enum StdoutError {
    /// The reading end of the pipe was closed (`EPIPE`, e.g. `rqr info | head -1`): [`main`]
    /// exits quietly with [`EXIT_STDOUT_CLOSED`].
    #[error("stdout was closed")]
    Closed,
    /// Any other failure (a full disk behind a redirection, say).
    #[error("cannot write to stdout: {0}")]
    Io(std::io::Error),
}

/// Writes `args` (and a newline when `newline`) to stdout and flushes, returning the error
/// instead of panicking like `println!`.
pub(crate) fn write_stdout(
    args: std::fmt::Arguments<'_>,
    newline: bool,
) -> Result<(), StdoutError> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    out.write_fmt(args)
        .and_then(|()| {
            if newline {
                out.write_all(b"\n")
            } else {
                Ok(())
            }
        })
        .and_then(|()| out.flush())
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::BrokenPipe => StdoutError::Closed,
            _ => StdoutError::Io(e),
        })
}

/// `println!` that returns a [`StdoutError`] instead of panicking (use with `?`).
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!($($arg)*), true)
    };
}

/// `print!` that returns a [`StdoutError`] instead of panicking (use with `?`).
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::cli::write_stdout(format_args!($($arg)*), false)
    };
}
/// Returns a usage mistake from the enclosing function: a [`rqr::SettingsError`] naming the
/// flag `field` (the command exits with code 2, like on clap's own errors), the message
/// formatted like `format!`.
macro_rules! usage {
    ($field:expr, $($arg:tt)*) => {
        return Err(rqr::SettingsError::new($field, format!($($arg)*)).into())
    };
}
pub(crate) use {out, outln, usage};

#[derive(Parser, Debug)]
#[command(
    name = "rqr",
    version,
    about = "glTF renderer on raw Vulkan: pure ray tracing vs hybrid, hardware ray queries or a compute BVH"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Report what every Vulkan device can do, and which ray backend rqr would use.
    Probe(probe::ProbeArgs),
    /// Load a glTF scene (default: the built-in one) and print its counts and bounds.
    Info(info::InfoArgs),
    /// Render an image (pure ray-traced or hybrid) to PNG/EXR, with optional AOVs.
    Render(render::RenderArgs),
    /// Render both paths (and optionally both backends), write images, FLIP map and a report.
    Compare(compare::CompareArgs),
    /// Render every job of a JSON Lines manifest (or one shard of it) on one warm device.
    Batch(batch::BatchArgs),
    /// Measure acceleration-structure builds and ray throughput (primary and incoherent rays).
    Bench(bench::BenchArgs),
}

/// Runs the CLI; returns the process exit code.
pub fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Probe(args) => probe::run(&args),
        Command::Info(args) => info::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Compare(args) => compare::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Batch(args) => batch::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e)
            if e.chain()
                .any(|c| matches!(c.downcast_ref(), Some(StdoutError::Closed))) =>
        {
            // Nobody reads stdout any more: stop like a command killed by SIGPIPE, silently.
            ExitCode::from(EXIT_STDOUT_CLOSED)
        }
        Err(e) => {
            eprintln!("rqr: error: {e:#}");
            let no_vulkan = e.chain().any(|cause| {
                let vk = cause.downcast_ref::<VkError>().or_else(|| {
                    match cause.downcast_ref::<rqr::Error>() {
                        Some(rqr::Error::Vk(v)) => Some(v),
                        _ => None,
                    }
                });
                vk.is_some_and(|v| matches!(v, VkError::Loader(_) | VkError::NoDevice))
            });
            let usage = e.chain().any(|cause| {
                cause.downcast_ref::<rqr::SettingsError>().is_some()
                    || matches!(
                        cause.downcast_ref::<rqr::Error>(),
                        Some(rqr::Error::Settings(_))
                    )
            });
            ExitCode::from(if no_vulkan {
                EXIT_NO_VULKAN
            } else if usage {
                EXIT_USAGE
            } else {
                1
            })
        }
    }
}

/// Shared by subcommands that open a device.
pub(crate) fn probe_report(
    device: &DeviceSelector,
    backend: BackendChoice,
) -> Result<ProbeReport, VkError> {
    let device = match rqr::device_select::resolve(device) {
        Ok(d) => d,
        Err(e) => {
            log::warn!("{e}");
            device.clone()
        }
    };
    let mut report = probe_devices(&device, backend)?;
    // `auto` as the autotune cache decided it (probe opens no device, so it never measures).
    for d in &mut report.devices {
        let decision = rqr::device_select::autotune::cached_decision(d);
        if backend == BackendChoice::Auto {
            d.backend = Some(decision.backend.as_str().to_string());
            d.backend_reason = decision.backend_reason;
        }
        d.raster = decision.raster.as_str().to_string();
        d.raster_reason = decision.raster_reason;
        d.texture_format = decision.texture_format.as_str().to_string();
        d.texture_format_reason = decision.texture_format_reason;
        d.autotune = decision.measured;
    }
    Ok(report)
}

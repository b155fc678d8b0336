//! The `rqr` command line: `probe`, `info`, `render`, `compare`, `bench`.

use std::process::ExitCode;

use anyhow::Result;
use clap::{Parser, Subcommand};
use rqr::accel::BackendChoice;
use rqr::vk::{probe_devices, DeviceSelector, ProbeReport, VkError};

mod bench;
mod common;
mod compare;
mod info;
mod probe;
mod render;

/// Exit code for "no Vulkan loader or no device".
const EXIT_NO_VULKAN: u8 = 2;

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
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
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
            ExitCode::from(if no_vulkan { EXIT_NO_VULKAN } else { 1 })
        }
    }
}

/// Shared by subcommands that open a device.
pub(crate) fn probe_report(
    device: &DeviceSelector,
    backend: BackendChoice,
) -> Result<ProbeReport, VkError> {
    probe_devices(device, backend)
}

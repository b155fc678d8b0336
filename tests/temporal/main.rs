//! Frame after frame: the denoiser (its history, cuts, disocclusion and converged references), the frame loop (bursts, statistics, no allocation after the first
//! frame), temporal reprojection, frameless rendering and adaptive sub-sampling, and animated
//! scenes updated on the device (skinning, refits, rebuilds) and reprojected, and camera paths
//! with `rqr render --frames` end to end.
//!
//! One module per subject: `cargo test --test temporal reproject::` runs one.

#[path = "../support/mod.rs"]
mod support;

mod animation_update;
mod denoise;
mod frame_loop;
mod reproject;
mod reproject_animated;
mod sequence;

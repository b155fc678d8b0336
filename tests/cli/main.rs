//! The `rqr` binary end to end: rendering commands and their outputs, `rqr info`, `rqr batch`
//! (and the library API under it, with a soak test of flat memory), `auto` choices by
//! measurement, and the build script on its own.
//!
//! One module per subject: `cargo test --test cli batch::` runs one.

#[path = "../support/mod.rs"]
mod support;

mod autotune;
mod batch;
mod batch_soak;
mod build_script;
mod cli_render;
mod scene_info;

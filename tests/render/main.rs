//! What the renderer draws: the hybrid path against the pure ray-traced one and the Whitted
//! controls, closed-form lighting, the distributed shading model, image-based lighting and
//! the physical sky, the AOVs, and the golden images.
//!
//! One module per subject: `cargo test --test render distributed::` runs one.

#[path = "../support/mod.rs"]
mod support;

mod aovs;
mod distributed;
mod distributed_spent_diffuse;
mod environment;
mod environment_sampling;
mod environment_sheen;
mod environment_sky;
mod golden;
mod paths;
mod rt_physics;

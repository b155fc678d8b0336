//! The GPU passes, one module each: what a pass binds, records and reads back. Their bindings
//! and push constants come from [`crate::interface`]; [`super::Renderer`] and the frame drivers
//! ([`super::drivers`]) run them. `reproject` is the set of passes of temporal reprojection,
//! with the sample cache they share.

pub mod gbuffer;
pub mod hybrid;
pub mod raster_compute;
pub mod raybench;
pub mod raytraced;
pub mod reproject;
pub mod skinning;
pub mod texture_sampling;
pub mod tonemap;

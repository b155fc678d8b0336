//! The GPU passes, one module each: what a pass binds, records and reads back. Their bindings
//! and push constants come from [`crate::interface`]; [`super::Renderer`] and the frame drivers
//! (`super::targets`, `super::reproject`, `super::sequence`) run them.

pub mod gbuffer;
pub mod hybrid;
pub mod raster_compute;
pub mod raybench;
pub mod raytraced;
pub mod skinning;
pub mod tonemap;

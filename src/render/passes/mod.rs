//! The GPU passes, one module each: what a pass binds, records and reads back. Their bindings
//! and push constants come from [`crate::interface`]; [`super::Renderer`] and the frame drivers
//! ([`super::drivers`]) run them. Temporal reuse, a technique of several passes with a sample
//! cache they share, lives beside them in [`super::temporal`].

pub mod draw_list;
pub mod gbuffer;
pub mod hybrid;
pub mod raster_compute;
pub mod raybench;
pub mod raytrace;
pub mod skin;
pub mod texture_sampling;
pub mod tonemap;

//! What runs frames: the per-frame resources of a single frame and the host-visible ring frames
//! copy into ([`targets`]), burst timing ([`burst`]) and camera sequences with or without reuse
//! between frames ([`sequence`]), and animated frames updated in place ([`animated`]).

pub mod animated;
pub mod burst;
pub mod sequence;
pub mod targets;

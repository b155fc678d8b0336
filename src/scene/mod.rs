//! glTF 2.0 → a plain [`Scene`](types::Scene), then GPU buffers.

pub mod gpu;
pub mod layout;
pub mod procedural;
pub mod types;

pub use types::*;

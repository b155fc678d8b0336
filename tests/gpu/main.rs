//! The device and the GPU plumbing under the renderer: device probing and backend choice,
//! compute round trips, timestamps and fence timeouts, Rust vs GLSL record layouts, the
//! shaders' math, device limits and memory checks, both ray backends (rqr's compute BVH,
//! built on the host and on the GPU, and hardware ray queries), the compute rasterizer and the
//! on-disk pipeline cache.
//!
//! One module per subject: `cargo test --test gpu limits::` runs one.

#[path = "../support/mod.rs"]
mod support;

mod backends;
mod bvh_gpu;
mod bvh_gpu_build;
mod foundation;
mod layout;
mod limits;
mod pipeline_cache;
mod raster_compute;
mod shader_math;

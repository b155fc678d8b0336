//! CPU references of shader code, kept only to test the shaders against (`tests/gpu/shader_math.rs`)
//! and in unit tests: nothing in the renderer calls them.

pub mod optics;

//! The distributed shading model (`shaders/common/distributed.glsl`): its bits of the `Frame`
//! uniform's flags (`interface_distributed.glsl`, included by the distributed shaders only, so
//! that the Whitted model's shaders stay as they are). The other flags are in `shared.rs`.

/// Frame flag: no triangle emits, so every emitter a diffuse ray could meet (sphere and cone
/// lights, the environment, the background) is also light-sampled, and a vertex whose diffuse
/// bounces are spent estimates its diffuse lobe by light sampling alone instead of tracing a
/// diffuse ray that would only collect light.
pub const FLAG_DIFFUSE_LIGHT_SAMPLED: u32 = 64;

/// Pixels each invocation of a distributed shading pass takes in turn (`raytrace_distributed`
/// and the hybrid `*_distributed` passes): invocation (x, y) shades pixels (x, y + k ⌈h / n⌉)
/// for k < n. An invocation whose path ends starts its next pixel's at once (path
/// regeneration), so a SIMD group's lanes stay busy while the paths of its neighbours, which
/// choose lobes and end at random, still run.
pub const PIXELS_PER_INVOCATION: u32 = 8;

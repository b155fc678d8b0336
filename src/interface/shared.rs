//! Set-0 bindings every pass shares, the `Frame` uniform and its codes, ray kinds and the
//! counter slots of the tracing passes (`interface_shared.glsl`).

use bytemuck::{Pod, Zeroable};

/// Binding of the scene's buffer addresses (`scene.glsl`'s `SceneRefs` uniform).
pub const BINDING_SCENE: u32 = 0;
/// Binding of the bindless texture array (`sampler2D textures[]`).
pub const BINDING_TEXTURES: u32 = 1;
/// Binding of the ray backend: the TLAS (hw) or the BVH's buffer addresses (bvh).
pub const BINDING_RAY_BACKEND: u32 = 2;
/// Binding of the `Frame` uniform ([`GpuFrame`]).
pub const BINDING_FRAME: u32 = 3;

/// Frame flag: no GGX lobe in direct light.
pub const FLAG_NO_SPECULAR: u32 = 1;
/// Frame flag: sky gradient background.
pub const FLAG_SKY: u32 = 2;
/// Frame flag (raytrace.comp push constant): write AOVs.
pub const FLAG_WRITE_AOV: u32 = 4;
/// Frame flag (raytrace.comp push constant): the adaptive corner pass.
pub const FLAG_ADAPTIVE_CORNERS: u32 = 8;
/// Frame flag: camera rays that miss show the environment (cleared by `--background`, which
/// then shows that colour while the environment still lights the scene).
pub const FLAG_ENV_BACKGROUND: u32 = 16;
/// Frame flag: camera samples are numbered through the sequence (`sample_base` + k) for their
/// position in the pixel too, not only for their random numbers: each frame of a denoised
/// sequence jitters anew, so that accumulated frames anti-alias (sequence-indexed samplers
/// only: Halton, Sobol, blue noise).
pub const FLAG_SEQUENCE_JITTER: u32 = 32;

/// `GpuFrame::sampler_kind`: pixel centres.
pub const SAMPLER_CENTER: u32 = 0;
/// `GpuFrame::sampler_kind`: regular grid.
pub const SAMPLER_GRID: u32 = 1;
/// `GpuFrame::sampler_kind`: stratified jitter.
pub const SAMPLER_JITTER: u32 = 2;
/// `GpuFrame::sampler_kind`: Halton (2,3).
pub const SAMPLER_HALTON: u32 = 3;
/// `GpuFrame::sampler_kind`: Owen-scrambled Sobol.
pub const SAMPLER_SOBOL: u32 = 4;
/// `GpuFrame::sampler_kind`: R2 with blue-noise offsets.
pub const SAMPLER_BLUENOISE: u32 = 5;
/// `GpuFrame::sampler_kind`: adaptive quincunx supersampling.
pub const SAMPLER_ADAPTIVE: u32 = 6;

/// `GpuFrame::filter_kind`: box filter.
pub const FILTER_BOX: u32 = 0;
/// `GpuFrame::filter_kind`: tent filter.
pub const FILTER_TENT: u32 = 1;

/// Ray kind and counter slot: camera rays.
pub const RAY_PRIMARY: u32 = 0;
/// Ray kind and counter slot: shadow rays.
pub const RAY_SHADOW: u32 = 1;
/// Ray kind and counter slot: reflection rays.
pub const RAY_REFLECTION: u32 = 2;
/// Ray kind and counter slot: refraction (and alpha-blend continuation) rays.
pub const RAY_REFRACTION: u32 = 3;
/// Counter slot after the four ray kinds: camera samples traced.
pub const COUNTER_SAMPLES: u32 = 4;
/// Ray kind and counter slot after the samples: diffuse rays (distributed model).
pub const RAY_DIFFUSE: u32 = 5;
/// Counter slots of the ray-traced and hybrid passes (four ray kinds, samples, diffuse rays),
/// per stripe.
pub const COUNTER_SLOTS: u32 = 6;
/// Copies of those counters: a run of consecutive workgroups counts into one copy, so that a
/// CPU device's threads (each runs a contiguous range of workgroups) do not share their cache
/// lines; a count is the sum over copies (as reprojection's `COUNTER_STRIPES`).
pub const RAY_COUNTER_STRIPES: u32 = 8;
/// Words from one copy of the ray counters to the next (128 bytes).
pub const RAY_COUNTER_STRIDE: u32 = 32;
/// Workgroups per row of a one-dimensional dispatch that may need more than
/// `maxComputeWorkGroupCount[0]` (at least 65 535; lavapipe's): longer ones take several rows
/// (`crate::vk::rows_of_groups`, and `counters.glsl`'s `linear_invocation()` on the shader
/// side). A power of two.
pub const GROUPS_PER_ROW: u32 = 32768;

/// The `Frame` uniform (binding [`BINDING_FRAME`], scalar layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuFrame {
    /// Camera to world.
    pub camera_to_world: [f32; 16],
    /// World to camera.
    pub view: [f32; 16],
    /// Projection (Vulkan clip space: y down, depth 0..1).
    pub proj: [f32; 16],
    /// proj × view.
    pub view_proj: [f32; 16],
    /// proj × view of the previous frame (motion vectors, reprojection).
    pub prev_view_proj: [f32; 16],
    /// Sub-pixel offset of the raster pass, in pixels (sample position − pixel centre).
    pub jitter: [f32; 2],
    /// cos and sin of the environment's rotation about +Y (`--environment-rotation`).
    pub env_rotation: [f32; 2],
    /// Camera position.
    pub camera_pos: [f32; 3],
    /// tan(yfov / 2).
    pub tan_half_fov_y: f32,
    /// Width / height.
    pub aspect: f32,
    /// 1 for orthographic.
    pub ortho: u32,
    /// Orthographic half extents.
    pub ortho_half: [f32; 2],
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// SAMPLER_* code.
    pub sampler_kind: u32,
    /// FILTER_* code.
    pub filter_kind: u32,
    /// Max path segments.
    pub max_depth: u32,
    /// FLAG_* bits.
    pub flags: u32,
    /// Sampler seed.
    pub seed: u32,
    /// Path weight cut-off.
    pub min_weight: f32,
    /// Ray offset.
    pub epsilon: f32,
    /// Adaptive threshold.
    pub adaptive_threshold: f32,
    /// Adaptive depth.
    pub adaptive_depth: u32,
    /// Ambient radiance.
    pub ambient: [f32; 3],
    /// Ray-cone spread angle per pixel (radians).
    pub pixel_spread: f32,
    /// Background radiance.
    pub background: [f32; 3],
    /// Scale of the environment's radiance (`--environment-intensity`).
    pub env_intensity: f32,
    /// Number of this dispatch's first camera sample (distributed model's random numbers:
    /// sample k of the ray-traced pass is `sample_base + k`; each hybrid sample's uniform has
    /// its own; sequences advance it by spp per frame).
    pub sample_base: u32,
    /// Diffuse bounces a distributed path may take.
    pub diffuse_bounces: u32,
}

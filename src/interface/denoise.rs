//! Denoising (`shaders/denoise/`, `interface_denoise.glsl`): the split of a distributed
//! frame's colour that the shading passes write for it, the denoiser's uniform, its per-pixel
//! records and the push constant of its filter iterations.

use bytemuck::{Pod, Zeroable};

/// What the ray-traced and hybrid distributed passes write per pixel for the denoiser
/// (through [`crate::interface::RaytracePush::guide`] / [`crate::interface::HybridPush::guide`]):
/// the pixel's colour split into the part the filter may blur and the part it must keep.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DenoiseGuide {
    /// rgb: radiance carried by the first shaded vertex's diffuse lobe (light sampled through
    /// it, the ambient term, and the whole path when the diffuse lobe continued it); a: the
    /// sum of filter weights (1 on the ray-traced path; Σ weight on the hybrid path, whose
    /// rgb is then Σ weight × value like its colour).
    pub diffuse: [f32; 4],
    /// rgb: radiance that needs no filtering: what the camera ray met before its first shaded
    /// vertex (misses, lights seen directly) and that vertex's emission; a: as `diffuse`.
    pub unfiltered: [f32; 4],
    /// rgb: the first shaded vertex's diffuse albedo (base colour × (1 − metallic) ×
    /// (1 − transmission)), 0 on a miss.
    pub diffuse_albedo: [f32; 4],
    /// rgb: its specular albedo (the GGX lobe's directional albedo, Karis' fit, plus the
    /// transmission tint and the coat), 0 on a miss; a: its roughness (the specular filter's
    /// radius follows it: a mirror's reflection is not blurred).
    pub specular_albedo: [f32; 4],
}

/// The colour buffer holds Σ weight × colour and Σ weight (the hybrid path's accumulation),
/// not colour: divide by alpha.
pub const DN_WEIGHTED_COLOR: u32 = 1;
/// The previous frame's history may be reprojected (else every pixel starts again).
pub const DN_HISTORY: u32 = 2;

/// Per-pixel surface the denoiser keeps from frame to frame to test its history against.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DenoiseSurface {
    /// World position of the primary hit.
    pub position: [f32; 3],
    /// Instance of the hit ([`crate::interface::AOV_NO_ID`] on a miss).
    pub instance: u32,
    /// Geometric normal of the glTF front face.
    pub normal: [f32; 3],
    /// Hit distance along the unit primary ray (0 on a miss).
    pub depth: f32,
}

/// What the next frame blends with, per pixel: the accumulated diffuse and specular light, the
/// accumulated albedos the filter divides them by and multiplies them back with, and the
/// accumulated unfiltered light (so that a jittered sampler's albedo and emission edges are
/// averaged over frames too, not flicker).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DenoiseHistory {
    /// rgb: diffuse light (reflected through the diffuse lobe, not yet divided by its albedo).
    pub diffuse: [f32; 4],
    /// rgb: specular light.
    pub specular: [f32; 4],
    /// rgb: diffuse albedo.
    pub diffuse_albedo: [f32; 4],
    /// rgb: specular albedo; a: roughness.
    pub specular_albedo: [f32; 4],
    /// rgb: unfiltered light.
    pub unfiltered: [f32; 4],
}

/// Per-pixel temporal state of the denoiser.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DenoiseMoments {
    /// First and second moments of the demodulated diffuse and specular luminance (m1 d,
    /// m2 d, m1 s, m2 s).
    pub moments: [f32; 4],
    /// Frames of history behind the pixel (1: this frame alone), at most the history cap.
    pub frames: f32,
    /// Padding.
    pub pad: [f32; 3],
}

/// The denoiser's uniform (one per frame target, written by each frame's commands). Buffers
/// go by device address; `prev_*` are last frame's, the others this frame's.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DenoiseParams {
    /// proj × view of this frame (unjittered).
    pub view_proj: [f32; 16],
    /// proj × view of the previous frame.
    pub prev_view_proj: [f32; 16],
    /// The inverse of `view_proj` (where a miss's pixel looks: its far-plane point).
    pub inv_view_proj: [f32; 16],
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// `DN_*` flags.
    pub flags: u32,
    /// Longest history a pixel keeps (`--history-cap`): the blend weight never drops below
    /// its inverse.
    pub history_cap: u32,
    /// Smallest blend weight of the moments.
    pub moments_alpha: f32,
    /// Luminance edge-stopping scale (× the local standard deviation).
    pub phi_color: f32,
    /// Depth edge-stopping scale: a neighbour's distance from the pixel's tangent plane over
    /// its distance from the pixel.
    pub phi_plane: f32,
    /// History test: largest distance from the history's plane, over the view depth.
    pub plane_threshold: f32,
    /// History test: smallest dot product of the normals.
    pub normal_threshold: f32,
    /// Spatial filtering fades with history: a pixel with f frames behind it takes the
    /// à-trous iterations whose taps lie at most `spatial_reach / f` pixels apart.
    pub spatial_reach: f32,
    /// Longest history of a pixel whose history is resampled between texels (the view or
    /// the surface moved).
    pub moving_history_cap: f32,
    /// The same for its specular light, which moves otherwise than the surface.
    pub moving_specular_history_cap: f32,
    /// Linear colour of the frame, `vec4` per pixel.
    pub color: u64,
    /// [`DenoiseGuide`] per pixel.
    pub guide: u64,
    /// [`crate::interface::Aov`] per pixel.
    pub aov: u64,
    /// Denoised linear colour out, `vec4` per pixel (alpha 1).
    pub denoised: u64,
    /// [`DenoiseSurface`] per pixel: this frame's (written) and the previous one's.
    pub surface: u64,
    /// The previous frame's [`DenoiseSurface`]s.
    pub prev_surface: u64,
    /// [`DenoiseMoments`] per pixel, this frame's.
    pub moments: u64,
    /// The previous frame's [`DenoiseMoments`].
    pub prev_moments: u64,
    /// [`DenoiseHistory`] per pixel, this frame's.
    pub history: u64,
    /// The previous frame's [`DenoiseHistory`].
    pub prev_history: u64,
    /// What the spatial passes test edges on, one `vec4` per pixel: world position, and the
    /// shading normal octahedron-encoded into two 16-bit snorms (the bits of w; all ones on a
    /// miss).
    pub edges: u64,
    /// This frame's accumulated illumination, 2 `vec4` per pixel (rgb, variance).
    pub accumulated: u64,
    /// Ping-pong buffers of the à-trous iterations, 2 `vec4` per pixel each.
    pub ping: u64,
    /// The other one.
    pub pong: u64,
}

/// Push constant of `denoise_atrous.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DenoiseAtrousPush {
    /// Device address of the iteration's input (2 `vec4` per pixel).
    pub source: u64,
    /// Device address of its output.
    pub target: u64,
    /// Tap spacing in pixels (1, 2, 4, …).
    pub step: u32,
    /// Padding.
    pub pad0: u32,
}

/// Binding of the denoiser's uniform ([`DenoiseParams`]), after the scene's set-0 bindings
/// (the temporal pass reads the scene's previous pose).
pub const BINDING_DENOISE_PARAMS: u32 = 4;

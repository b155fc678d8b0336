//! Bindings, flags and push constants of the passes: ray-traced (`raytrace.comp`), hybrid
//! shading (`hybrid_main.glsl`), G-buffer raster (`gbuffer.*`, `gbuffer_visibility.frag`), compute
//! raster (`raster.glsl`), tonemap and `rqr bench`'s ray throughput (`interface_passes.glsl`).
//! Bindings 0-3 are the shared ones of `shared.rs`.

use bytemuck::{Pod, Zeroable};

/// Instance or primitive id of a pixel whose primary ray hit nothing (the `instance` and
/// `primitive` fields of [`Aov`]; -1 as an `int32`).
pub const AOV_NO_ID: u32 = u32::MAX;

/// Per-pixel arbitrary output variables of the primary hit (ray-traced and hybrid passes).
/// Ids are integers end to end (exact at any scene size); the rest is float.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Aov {
    /// xyz: world-space shading normal (after normal mapping, unit length, turned towards the
    /// camera; 0 on a miss); w: hit distance along the unit primary ray (0 on a miss).
    pub normal_depth: [f32; 4],
    /// xyz: world-space geometric normal of the glTF front face (0 on a miss); w: samples
    /// traced for the pixel.
    pub geometric_samples: [f32; 4],
    /// xyz: world position (0 on a miss); w: 0.
    pub position: [f32; 4],
    /// rgb: linear base colour after texture, vertex colour and factor, in [0, 1] (0 on a
    /// miss); a: its alpha.
    pub albedo: [f32; 4],
    /// Barycentrics of the hit in its triangle.
    pub bary: [f32; 2],
    /// Instance index ([`AOV_NO_ID`] on a miss).
    pub instance: u32,
    /// Primitive (triangle) index in the instance's mesh ([`AOV_NO_ID`] on a miss).
    pub primitive: u32,
}

/// raytrace.comp: [`Aov`] per pixel (written under `FLAG_WRITE_AOV`).
pub const BINDING_RT_AOV: u32 = 5;
/// raytrace.comp: ray counters (`COUNTER_SLOTS`).
pub const BINDING_RT_COUNTERS: u32 = 6;
/// raytrace.comp: adaptive corner samples, (w+1) x (h+1) `vec4`.
pub const BINDING_RT_CORNERS: u32 = 7;

/// raytrace.comp's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RaytracePush {
    /// `FLAG_ADAPTIVE_CORNERS` (the corner pass) and `FLAG_WRITE_AOV`.
    pub flags: u32,
    /// Aligns `color` (8 bytes).
    pub pad0: u32,
    /// Device address of the linear HDR colour out, `vec4` per pixel (a buffer reference: a
    /// CPU device (lavapipe) stores through one with a vector scatter, where it stores into a
    /// descriptor-bound buffer lane by lane).
    pub color: u64,
    /// Device address of the denoiser's [`crate::interface::denoise::DenoiseGuide`] per pixel
    /// out (distributed shading only), 0 for none.
    pub guide: u64,
}

/// Hybrid shading: accumulation (rgb sum, weight sum) per pixel.
pub const BINDING_HYBRID_ACCUM: u32 = 4;
/// Hybrid shading: [`Aov`] per pixel.
pub const BINDING_HYBRID_AOV: u32 = 5;
/// Hybrid shading: ray counters (`COUNTER_SLOTS`).
pub const BINDING_HYBRID_COUNTERS: u32 = 6;
/// Hybrid shading: the raster pass's first image (the visibility image, or the G-buffer's
/// images in `GBUFFER_*` order at consecutive bindings).
pub const BINDING_HYBRID_GBUFFER: u32 = 7;

/// G-buffer image: world position, t.
pub const GBUFFER_POSITION: u32 = 0;
/// G-buffer image: shading normal, roughness.
pub const GBUFFER_NORMAL: u32 = 1;
/// G-buffer image: geometric normal of the glTF front face, metallic.
pub const GBUFFER_GEOMETRIC: u32 = 2;
/// G-buffer image: base colour, alpha.
pub const GBUFFER_BASE: u32 = 3;
/// G-buffer image: emissive, occlusion.
pub const GBUFFER_EMISSIVE: u32 = 4;
/// G-buffer image: instance, primitive, material | front face << 31, transmission bits.
pub const GBUFFER_IDS: u32 = 5;
/// G-buffer image: barycentrics, motion.
pub const GBUFFER_BARY: u32 = 6;
/// Images of the full G-buffer.
pub const GBUFFER_IMAGES: u32 = 7;

/// Hybrid push flag: overwrite the accumulation (first sample).
pub const HYBRID_FIRST_SAMPLE: u32 = 1;
/// Hybrid push flag: write AOVs.
pub const HYBRID_WRITE_AOV: u32 = 4;

/// The hybrid shading pass's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct HybridPush {
    /// `HYBRID_*` flags.
    pub flags: u32,
    /// Filter weight of this sample.
    pub weight: f32,
    /// Device address of the denoiser's [`crate::interface::denoise::DenoiseGuide`] per pixel
    /// (accumulated like the colour; distributed shading only), 0 for none.
    pub guide: u64,
}

/// The raster G-buffer and visibility pipelines' push constant (one draw).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct DrawPush {
    /// Scene instance index.
    pub instance: u32,
}

/// Compute raster: depth | triangle id per pixel.
pub const BINDING_RASTER_DEPTH_IDS: u32 = 4;
/// Compute raster: the draw table ([`RasterDraw`] per drawn instance).
pub const BINDING_RASTER_DRAWS: u32 = 5;
/// Compute raster: the big-triangle queue.
pub const BINDING_RASTER_BIG: u32 = 6;
/// Compute raster: the visibility image (resolve only).
pub const BINDING_RASTER_VISIBILITY: u32 = 7;
/// Compute raster: the tile bins (per-tile counts, offsets, cursors, then the lists).
pub const BINDING_RASTER_BINS: u32 = 8;
/// Compute raster: side of the binned stages' screen tiles, in pixels.
pub const RASTER_TILE_SIZE: u32 = 16;
/// `raster_bin.comp` stage (specialization constant 0): count each queued triangle's tiles.
pub const RASTER_BIN_COUNT: u32 = 0;
/// `raster_bin.comp` stage: scan the counts into per-tile offsets.
pub const RASTER_BIN_SCAN: u32 = 1;
/// `raster_bin.comp` stage: fill the per-tile lists.
pub const RASTER_BIN_FILL: u32 = 2;

/// [`RasterDraw`] flag: cull back faces.
pub const DRAW_CULL_BACK: u32 = 1;
/// [`RasterDraw`] flag: mirrored instance (clockwise front faces).
pub const DRAW_MIRRORED: u32 = 2;
/// [`RasterDraw`] flag: alpha-MASK test.
pub const DRAW_ALPHA_TEST: u32 = 4;

/// The compute rasterizer's draw table entry: one per drawn instance, in instance order.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RasterDraw {
    /// Global index of the draw's first triangle.
    pub first_triangle: u32,
    /// Scene instance index.
    pub instance: u32,
    /// `DRAW_*` flags.
    pub flags: u32,
}

/// The compute rasterizer's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RasterPush {
    /// Triangles of all draws.
    pub triangle_count: u32,
    /// Entries of the draw table.
    pub draw_count: u32,
    /// atomic32 only: 0 = depth pass, 1 = id pass.
    pub pass_kind: u32,
}

/// Tonemap operator: clamp only.
pub const TONEMAP_NONE: u32 = 0;
/// Tonemap operator: ACES filmic (Narkowicz fit).
pub const TONEMAP_ACES: u32 = 1;
/// Tonemap operator: Khronos PBR Neutral.
pub const TONEMAP_KHRONOS_NEUTRAL: u32 = 2;

/// tonemap.comp's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TonemapPush {
    /// Pixels.
    pub count: u32,
    /// `TONEMAP_*` operator.
    pub op: u32,
    /// Exposure scale (2^EV).
    pub scale: f32,
    /// Aligns the addresses (8 bytes).
    pub pad0: u32,
    /// Device address of the linear colour in, `vec4` per pixel (buffer references, as in
    /// [`RaytracePush`]).
    pub color_in: u64,
    /// Device address of the RGBA8 out, one `uint` per pixel.
    pub pixels_out: u64,
}

/// raybench.comp: per pixel (hit position, instance bits), (primary direction, primitive bits).
pub const BINDING_RAYBENCH_HITS: u32 = 4;
/// raybench.comp: counters (rays traced, rays that hit).
pub const BINDING_RAYBENCH_COUNTERS: u32 = 5;
/// raybench.comp mode: one primary ray per pixel centre.
pub const RAYBENCH_PRIMARY: u32 = 0;
/// raybench.comp mode: one cosine-weighted bounce ray from every stored primary hit.
pub const RAYBENCH_BOUNCE: u32 = 1;

/// raybench.comp's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct RaybenchPush {
    /// `RAYBENCH_*` mode.
    pub mode: u32,
}

/// texture_sampling.comp (the texture-format measurement of `rqr::device_select::autotune`): the texture
/// it samples.
pub const BINDING_TEXTURE_SAMPLING_IMAGE: u32 = 0;
/// texture_sampling.comp: one `vec4` sum of samples per invocation (keeps the samples live).
pub const BINDING_TEXTURE_SAMPLING_SUMS: u32 = 1;

/// texture_sampling.comp's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TextureSamplingPush {
    /// Invocations per side of the square dispatch.
    pub side: u32,
    /// Trilinear samples per invocation.
    pub samples: u32,
}

/// skin.comp: rest positions, `vec3` per vertex.
pub const BINDING_SKIN_REST_POSITIONS: u32 = 0;
/// skin.comp: rest normals, `vec3` per vertex.
pub const BINDING_SKIN_REST_NORMALS: u32 = 1;
/// skin.comp: rest tangents, `vec4` per vertex.
pub const BINDING_SKIN_REST_TANGENTS: u32 = 2;
/// skin.comp: 8 joint indices per vertex.
pub const BINDING_SKIN_JOINTS: u32 = 3;
/// skin.comp: 8 joint weights per vertex.
pub const BINDING_SKIN_WEIGHTS: u32 = 4;
/// skin.comp: morph displacements, indexed `[attribute (position, normal, tangent)][target][vertex]`.
pub const BINDING_SKIN_DELTAS: u32 = 5;
/// skin.comp: this frame's joint matrices (`mat4` per joint).
pub const BINDING_SKIN_JOINT_MATRICES: u32 = 6;
/// skin.comp: this frame's morph weights (`float` per target).
pub const BINDING_SKIN_MORPH_WEIGHTS: u32 = 7;
/// skin.comp: deformed positions out.
pub const BINDING_SKIN_OUT_POSITIONS: u32 = 8;
/// skin.comp: deformed normals out.
pub const BINDING_SKIN_OUT_NORMALS: u32 = 9;
/// skin.comp: deformed tangents out.
pub const BINDING_SKIN_OUT_TANGENTS: u32 = 10;
/// [`SkinPush`] flag: linear blend skinning (else morphing only).
pub const SKIN_SKINNED: u32 = 1;
/// [`SkinPush`] flag: the geometry has tangents.
pub const SKIN_TANGENTS: u32 = 2;

/// skin.comp's push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct SkinPush {
    /// Vertices.
    pub count: u32,
    /// Morph targets.
    pub targets: u32,
    /// `SKIN_*` flags.
    pub flags: u32,
    /// Joints of the skin (0: not skinned).
    pub joint_count: u32,
}

/// bvh_bench.comp (`benches/bvh.rs`, no `Frame` uniform): primary hits, one [`BenchHit`] per
/// pixel.
pub const BINDING_BENCH_PRIMARY: u32 = 3;
/// bvh_bench.comp: bounce hits, one [`BenchHit`] per pixel.
pub const BINDING_BENCH_BOUNCE: u32 = 4;

/// bvh_bench.comp's record of one closest hit (scalar layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BenchHit {
    /// Hit distance.
    pub t: f32,
    /// Instance index (-1 on a miss).
    pub instance: i32,
    /// Primitive index (-1 on a miss).
    pub primitive: i32,
    /// Padding.
    pub pad: f32,
    /// Ray origin.
    pub origin: [f32; 3],
    /// Padding.
    pub pad2: f32,
    /// Ray direction.
    pub dir: [f32; 3],
    /// Padding.
    pub pad3: f32,
}

/// bvh_bench.comp's push constant (scalar layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BenchPush {
    /// Camera position (looking at the origin).
    pub eye: [f32; 3],
    /// tan(yfov / 2).
    pub tan_half_fov: f32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// 0: primary rays, 1: one bounce from each primary hit.
    pub mode: u32,
    /// Bounce sampler seed.
    pub seed: u32,
}

//! Temporal reprojection (`render/temporal/`, `shaders/temporal/`):
//! bindings, params flags, stages, job lists, pixel states, cache flags and counter slots
//! (`interface_reproject.glsl`). Bindings 0-3 are the shared ones of `shared.rs`; every family of
//! ids here (bindings, flags, pixel kinds and reasons, cache flags, job lists, counter slots) is
//! contiguous, which `interface::tests` checks.

use bytemuck::{Pod, Zeroable};

/// The `Params` uniform ([`GpuParams`]), which also holds the addresses of the per-pixel
/// buffers (cache, states, colours, job lists, shown samples, anchors: the shaders reach
/// them through buffer references).
pub const BINDING_RP_PARAMS: u32 = 4;
/// Scatter winners and depth keys, interleaved per pixel.
pub const BINDING_RP_KEY_WINNER: u32 = 5;
/// Counters (`C_*` slots).
pub const BINDING_RP_COUNTERS: u32 = 6;
/// Per job list: the indirect dispatch of the pass working through it and its job count.
pub const BINDING_RP_DISPATCH_ARGS: u32 = 7;
/// First G-buffer image; the others follow in `GBUFFER_*` order (the last bindings).
pub const BINDING_RP_GBUFFER: u32 = 8;

/// Params flag: reproject the previous frame's cache.
pub const RP_REUSE: u32 = 1;
/// Params flag: every pixel's primary hit is in the G-buffer (hybrid path).
pub const RP_GBUFFER: u32 = 2;
/// Params flag: rt path, verify every candidate with a primary ray.
pub const RP_VERIFY_ALL: u32 = 4;
/// Params flag: frameless refresh (a sweep over the pixels at the budget's rate).
pub const RP_FRAMELESS: u32 = 8;
/// Params flag: adaptive sub-sampling of the pixels that need new colour.
pub const RP_ADAPTIVE: u32 = 16;
/// Params flag: the scene has moving geometry (animated transforms, skins, morph targets):
/// every cache entry has an [`Anchor`], and the scatter moves cached samples with their
/// objects.
pub const RP_MOVING: u32 = 32;
/// Params flag: the passes write each pixel's linear colour, not only its display value.
pub const RP_LINEAR_COLOR: u32 = 64;
/// [`Anchor::instance`] of an entry without an anchor (a miss).
pub const NO_ANCHOR: u32 = 0xFFFF_FFFF;

/// [`ReprojectPush::gather`] of a stage that lists no pixels to trace.
pub const GATHER_NONE: u32 = u32::MAX;
/// Job list 0: the verify pass's jobs (rt path), then each later adaptive level's.
pub const LIST_VERIFY: u32 = 0;
/// Job list 1: the first pixels to trace (the settling stage's and the verify pass's).
pub const LIST_TRACE: u32 = 1;
/// Job list 2, adaptive sub-sampling only: the pixels that need new colour (the settling
/// stage's and the verify pass's), which the interpolation passes work through instead of
/// the whole image.
pub const LIST_PENDING: u32 = 2;
/// Job lists in the jobs buffer (and indirect dispatches in the arguments buffer).
pub const JOB_LISTS: u32 = 3;

/// Pixel state: mask of the kind.
pub const PX_KIND_MASK: u32 = 15;
/// Pixel kind: shows a reprojected sample.
pub const PX_REUSE: u32 = 1;
/// Pixel kind: needs new rays (or interpolation), not done yet.
pub const PX_TRACE: u32 = 2;
/// Pixel kind: has a candidate sample; a primary ray decides (rt path).
pub const PX_VERIFY: u32 = 3;
/// Pixel kind: traced this frame.
pub const PX_TRACED: u32 = 4;
/// Pixel kind: interpolated this frame (adaptive sub-sampling).
pub const PX_INTERP: u32 = 5;
/// Pixel reason: no sample landed here.
pub const PX_HOLE: u32 = 1 << 4;
/// Pixel reason: the sample disagrees with this frame's primary visibility.
pub const PX_REJECTED: u32 = 1 << 5;
/// Pixel reason: specular/transmissive sample or surface.
pub const PX_VIEW_DEPENDENT: u32 = 1 << 6;
/// Pixel reason: older than --max-age.
pub const PX_EXPIRED: u32 = 1 << 7;
/// Pixel reason: picked by the frameless refresh.
pub const PX_FRAMELESS: u32 = 1 << 8;
/// Pixel reason: the sample is a neighbour's, filling an empty pixel.
pub const PX_FILLED: u32 = 1 << 9;

/// Cache entry flag: valid.
pub const CACHE_VALID: u32 = 1;
/// Cache entry flag: a miss (position holds the unit ray direction).
pub const CACHE_MISS: u32 = 2;
/// Cache entry flag: specular/transmissive, never reused.
pub const CACHE_VIEW_DEPENDENT: u32 = 4;
/// [`CacheEntry::meta`] flag: the sample has moved with its object (moving geometry) since it
/// was traced, so its shading is that of where the object was.
pub const CACHE_MOVED: u32 = 8;
/// A sample that moved with its object is re-traced once it is this many frames old (its
/// shadows and highlights belong to where the object was; `--max-age` still bounds every
/// sample).
pub const MOVED_MAX_AGE: u32 = 4;
/// [`CacheEntry::meta`]: bits 4-5 count fills away from where the colour was computed
/// (saturating at 3; fills copy samples below `MAX_FILL_HOPS`).
pub const CACHE_HOPS_SHIFT: u32 = 4;
/// [`CacheEntry::meta`]: bits 6-15 count the frames the sample has been reused (saturating at
/// [`MAX_CACHE_AGE`]).
pub const CACHE_AGE_SHIFT: u32 = 6;
/// The oldest age a cache entry counts to (`--max-age` is at most this).
pub const MAX_CACHE_AGE: u32 = 1023;
/// [`CacheEntry::meta`]: bits 16-31 hold the sample's material index (reprojection takes scenes
/// of at most [`MAX_CACHE_MATERIALS`] materials).
pub const CACHE_MATERIAL_SHIFT: u32 = 16;
/// Materials a scene may have for reprojection (16 bits of [`CacheEntry::meta`]).
pub const MAX_CACHE_MATERIALS: u32 = 65536;
/// [`Shown::normal`] bit: a sample landed on (or was filled into) the pixel.
pub const SHOWN_SAMPLE: u32 = 1;
/// [`Shown::normal`] bit: the sample is a miss.
pub const SHOWN_MISS: u32 = 2;
/// No sample.
pub const NO_SAMPLE: u32 = 0xFFFF_FFFF;
/// A depth key with this bit marks an empty pixel filled from a neighbour.
pub const FILLED_KEY: u32 = 0x8000_0000;

/// Counter slot: samples (after the four ray kinds, as `COUNTER_SAMPLES`).
pub const C_SAMPLES: u32 = 4;
/// Counter slot: length of job list 0 while a stage appends to it (a shared slot; in the
/// statistics' stripes this index counts diffuse rays, `RAY_DIFFUSE`, as the full frame's).
pub const C_JOBS: u32 = 5;
/// Counter slot: pixels that reused a sample.
pub const C_REUSED: u32 = 6;
/// Counter slot: pixels traced.
pub const C_TRACED: u32 = 7;
/// Counter slot: pixels interpolated.
pub const C_INTERP: u32 = 8;
/// Counter slot: holes.
pub const C_HOLES: u32 = 9;
/// Counter slot: rejected samples.
pub const C_REJECTED: u32 = 10;
/// Counter slot: view-dependent pixels.
pub const C_VIEW_DEPENDENT: u32 = 11;
/// Counter slot: expired samples.
pub const C_EXPIRED: u32 = 12;
/// Counter slot: frameless refreshes.
pub const C_FRAMELESS: u32 = 13;
/// Counter slot: verification rays.
pub const C_VERIFY_RAYS: u32 = 14;
/// Counter slot (per stripe): pixels the shown stage filled, for the frameless budget.
pub const C_SHOWN_FILLED: u32 = 15;
/// Counter slot: the first refresh bin of this frame's frameless window.
pub const C_WINDOW_START: u32 = 16;
/// Counter slot: how many refresh bins this frame's frameless window spans (from
/// `C_WINDOW_START`, wrapping around at `REFRESH_BINS`).
pub const C_WINDOW_BINS: u32 = 17;
/// Counter slot: filled pixels.
pub const C_FILLED: u32 = 18;
/// Counter slot: subgroups that finished appending to the current job lists.
pub const C_TILES_DONE: u32 = 19;
/// Counter slot: length of job list 1 (two passes append to it).
pub const C_TRACE_JOBS: u32 = 20;
/// Counter slot: length of job list 2 (two passes append to it).
pub const C_PENDING_JOBS: u32 = 21;
/// Counter slot: subgroups of one stripe that finished appending to the current job lists
/// (per stripe, like the statistics; `lists_done` of `temporal/job_lists.glsl`).
pub const C_STRIPE_DONE: u32 = 22;
/// The statistics counters (ray kinds, `C_SAMPLES`, `C_REUSED` .. `C_FILLED` but the frameless
/// and job-list slots) come in this many stripes: a workgroup counts into the stripe of its
/// share of the dispatch (consecutive workgroups share one). A CPU device (lavapipe) hands each
/// thread a contiguous range of workgroups, so the threads' per-subgroup atomics land on
/// different cache lines instead of bouncing one line between cores.
pub const COUNTER_STRIPES: u32 = 8;
/// Counter slots per stripe (128 bytes: two cache lines). Slots `[0, COUNTER_STRIPE_WORDS)`
/// hold the counters every workgroup shares (job lists, frameless threshold); stripe `s` of
/// the statistics starts at `(s + 1) * COUNTER_STRIPE_WORDS`, and a statistic is the sum over
/// stripes.
pub const COUNTER_STRIPE_WORDS: u32 = 32;
/// Counter slot: first of the frameless candidates' histogram over their refresh bins (after
/// the shared slots and the stripes).
pub const C_HISTOGRAM: u32 = 288;
/// Frameless refresh bins: the refresh order's ranks, quantized. A power of two.
pub const REFRESH_BINS: u32 = 1024;
/// Pixels of one row that share a refresh rank (a row of an 8x8 workgroup: one cluster of
/// subgroup invocations counts them with one atomic).
pub const REFRESH_SEGMENT: u32 = 8;
/// Counter slot: the refresh bin where the frameless sweep stands. Not cleared between frames
/// (the frame clears the slots before it); cleared when a sequence starts.
pub const C_SWEEP: u32 = 1312;
/// Counter slots in all (`C_SWEEP` + 1).
pub const RP_COUNTER_SLOTS: u32 = 1313;
/// Depth keys (the scatter's) keep where in its pixel a sample falls in their low bits: this
/// many bits per axis (eighths of a pixel), so that a fill reads a neighbour's sample place
/// from the key instead of gathering and projecting the sample.
pub const KEY_PLACE_BITS: u32 = 3;
/// Depth key bit: a fill may not copy the sample (`max_hops` fills or more from where its
/// colour was computed).
pub const KEY_NOT_COPYABLE: u32 = 64;
/// The depth key bits that are not depth (`KEY_NOT_COPYABLE` and the place).
pub const KEY_LOW_MASK: u32 = 127;

/// A cached sample: the colour of one primary hit and where it was. Nine words, not sixteen:
/// every reprojected frame moves each pixel's entry about three times (scatter, fill,
/// commit), and on a CPU device (lavapipe) every word gathered from a per-pixel address
/// costs alike, so the entry carries only what a stage reads.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct CacheEntry {
    /// Linear radiance.
    pub color: [f32; 3],
    /// `color` as displayed: RGBA8 after the sequence's tonemap operator and exposure
    /// (`tonemap_rgba8` of tonemap.glsl), computed once where the colour is. A reused sample
    /// is shown as it is: tonemapping every reused pixel again took 15 % of the stage that
    /// commits them on lavapipe. (Misses are shown per pixel: their colour is the
    /// background seen through the pixel.)
    pub display: u32,
    /// World position of the primary hit (a miss: unit direction).
    pub position: [f32; 3],
    /// Geometric normal of the glTF front face, octahedral (`pack_normal` of `temporal/cache_entry.glsl`:
    /// two 14-bit coordinates in bits 4-31).
    pub normal: u32,
    /// Bits 0-3: `CACHE_*` flags; bits 4-5: fills away from where the colour was computed
    /// (`CACHE_HOPS_SHIFT`); bits 6-15: age in frames (`CACHE_AGE_SHIFT`, saturating at
    /// `MAX_CACHE_AGE`); bits 16-31: material index (`CACHE_MATERIAL_SHIFT`). 0 (no
    /// `CACHE_VALID`) marks an empty entry.
    pub meta: u32,
}

/// Where on the scene's geometry a cached sample lies, for scenes with moving geometry
/// ([`RP_MOVING`]): one per cache slot, in a side buffer double-buffered like the cache (so
/// static scenes do not pay for it). The scatter recomputes the sample's world position and
/// normal from this frame's instance transform and (skinned, morphed) vertices.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Anchor {
    /// Scene instance, or [`NO_ANCHOR`].
    pub instance: u32,
    /// Triangle of the instance's geometry.
    pub primitive: u32,
    /// Barycentrics (b1, b2) of the point in that triangle (may lie outside it for a fill's
    /// point on the triangle's plane).
    pub bary: [f32; 2],
}

/// What the edge test of a pixel's neighbours needs of the sample a pixel shows after the
/// scatter, in pixel order: two words (the fewer, the cheaper the stage that reads four of
/// them per pixel).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Shown {
    /// The sample's tangent plane, as its offset from this frame's camera along its normal:
    /// `dot(position - camera, normal)` (unused for misses).
    pub plane: f32,
    /// [`CacheEntry::normal`] with the `SHOWN_*` bits in bits 0-2; 0 where no sample landed.
    pub normal: u32,
}

/// The push constant of the stages that trace no rays (`temporal_classify.comp` and
/// `temporal_interpolate.comp` read it).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct ReprojectPush {
    /// The adaptive level it works at (interpolate).
    pub level: u32,
    /// The adaptive level (1, 2, 4) whose pixels to trace it lists, or [`GATHER_NONE`].
    pub gather: u32,
}

/// `temporal_verify.comp`'s push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct VerifyPush {
    /// The adaptive level (1, 2, 4) whose pixels to trace it lists.
    pub level: u32,
}

/// `temporal_trace.comp`'s push constant.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TracePush {
    /// The job list it works through ([`LIST_TRACE`] first, then [`LIST_VERIFY`]).
    pub list: u32,
}

/// The reprojection `Params` uniform (binding [`BINDING_RP_PARAMS`], scalar layout).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuParams {
    /// `RP_*` flags.
    pub flags: u32,
    /// A sample older than this is re-traced.
    pub max_age: u32,
    /// Share of pixels re-traced per frame (0..1).
    pub frameless_fraction: f32,
    /// Adaptive sub-sampling: largest channel difference to interpolate.
    pub subsample_threshold: f32,
    /// Tonemap operator of the display pixels (`TONEMAP_*`).
    pub tonemap_op: u32,
    /// Plane distance / view depth.
    pub plane_threshold: f32,
    /// Smallest dot of the two geometric normals.
    pub normal_threshold: f32,
    /// rt path: plane distance / view depth between neighbours = an edge.
    pub edge_threshold: f32,
    /// Metallic at or above: view-dependent.
    pub specular_metallic: f32,
    /// Roughness below: view-dependent (Whitted mirror term).
    pub specular_roughness: f32,
    /// An empty pixel takes a neighbour's sample this close (pixels).
    pub fill_radius: f32,
    /// Fills copy samples fewer hops than this from their origin.
    pub max_hops: u32,
    /// Exposure scale of the display pixels (2^exposure).
    pub tonemap_scale: f32,
    /// Aligns the addresses below (8 bytes).
    pub pad0: u32,
    /// Device addresses of the per-pixel buffers, which the shaders reach through
    /// `buffer_reference`s rather than descriptor bindings: a CPU device (lavapipe) loads and
    /// stores a descriptor-bound buffer at per-lane addresses one lane at a time (a branch,
    /// a bounds check and a scalar access per lane and word), but a buffer reference with a
    /// vector gather or scatter. The cache this frame reads ([`CacheEntry`] array).
    pub cache_prev: u64,
    /// The cache this frame writes.
    pub cache_next: u64,
    /// Per pixel, interleaved: the winning sample's index and its depth key.
    pub key_winner: u64,
    /// Per pixel: the `PX_*` state.
    pub states: u64,
    /// Per pixel: linear colour (`vec4`), for EXR output.
    pub colors: u64,
    /// Per pixel: the display value (RGBA8).
    pub display: u64,
    /// Per pixel: [`Shown`].
    pub shown: u64,
    /// The job lists (`JOB_LISTS` x pixels).
    pub jobs: u64,
    /// Per cache slot: the [`Anchor`]s this frame reads.
    pub anchors_prev: u64,
    /// The [`Anchor`]s this frame writes.
    pub anchors_next: u64,
}

//! The host/shader interface, one source for both sides.
//!
//! Every binding number, flag, stage id, counter slot, AOV and push-constant struct that Rust
//! and GLSL share is declared once, in the Rust files of this folder. `build.rs`
//! (`build/interface.rs`) translates each file into a GLSL header, `interface_<file>.glsl`,
//! generated into `$OUT_DIR/glsl` and found by every shader's `#include`:
//!
//! | Rust file | header | for |
//! |---|---|---|
//! | `shared.rs` | `interface_shared.glsl` | set-0 bindings 0-3, `Frame` ([`GpuFrame`]), sampler/filter codes, ray kinds and counter slots |
//! | `passes.rs` | `interface_passes.glsl` | ray-traced, hybrid, G-buffer, compute-raster, tonemap, ray-bench, texture-sampling and skinning passes, [`Aov`] |
//! | `bvh.rs` | `interface_bvh.glsl` | the compute BVH's uniform, the GPU build and refit passes' records, push constants and state words |
//! | `reproject.rs` | `interface_reproject.glsl` | temporal reprojection |
//! | `environment.rs` | `interface_environment.glsl` | image-based lighting: the environment's textures and preparation passes |
//! | `denoise.rs` | `interface_denoise.glsl` | the denoiser: the shading passes' colour split, its uniform, records and push constant |
//! | `distributed.rs` | `interface_distributed.glsl` | the distributed shading model's frame flags and pixels per invocation |
//!
//! **Adding a binding** (or a flag, a counter): add a `pub const` to the right file, use the
//! name in the shader (`layout(set = 0, binding = BINDING_X)`) and in the pass
//! ([`bindings`] and `DescriptorSet::buffer(BINDING_X, ..)`). A name missing on either side
//! fails to compile; two names on one number fail [`bindings`]' check. Structs (push constants,
//! uniforms) are `repr(C)` here and become GLSL structs field by field; `tests/gpu/layout.rs` reads
//! them back on the GPU. Only constants and structs belong in these files: the generator
//! rejects anything else with the file and line.

pub mod bvh;
pub mod denoise;
pub mod distributed;
pub mod environment;
pub mod passes;
pub mod reproject;
pub mod shared;

pub use distributed::*;
pub use passes::*;
pub use shared::*;

use crate::vk::Binding;

/// A pass's descriptor-set layout from `(binding number, kind)` pairs: entry `n` of the result
/// is binding `n`; numbers no pair names are [`Binding::Unused`].
///
/// # Panics
/// When two pairs name the same binding: a numbering mistake in the interface, caught the first
/// time the pass is built (every pass is built by the test suite).
pub fn bindings(entries: &[(u32, Binding)]) -> Vec<Binding> {
    let len = entries.iter().map(|e| e.0 as usize + 1).max().unwrap_or(0);
    let mut out = vec![None; len];
    for &(number, kind) in entries {
        let slot = &mut out[number as usize];
        assert!(
            slot.is_none(),
            "binding {number} is declared twice in one pass (see src/interface)"
        );
        *slot = Some(kind);
    }
    out.into_iter()
        .map(|b| b.unwrap_or(Binding::Unused))
        .collect()
}

/// The scene's set-0 bindings 0-2 (scene, textures, ray backend) and the frame uniform at 3,
/// which every tracing pass starts with.
pub fn scene_bindings(texture_capacity: u32, ray_backend: Binding) -> [(u32, Binding); 4] {
    [
        (BINDING_SCENE, Binding::UniformBuffer),
        (BINDING_TEXTURES, Binding::SampledImages(texture_capacity)),
        (BINDING_RAY_BACKEND, ray_backend),
        (BINDING_FRAME, Binding::UniformBuffer),
    ]
}

/// Push-constant bytes of a `repr(C)` interface struct.
pub fn push_bytes<T: bytemuck::Pod>(push: &T) -> &[u8] {
    bytemuck::bytes_of(push)
}

// Relations between constants the GLSL side relies on.
const _: () = assert!(reproject::C_SAMPLES == COUNTER_SAMPLES);
// Reprojection's statistics stripes (after its shared slots) have the full frame's ray-counter
// layout, so the host sums both alike (`render::passes::raytrace::striped_sum`).
const _: () = assert!(
    reproject::COUNTER_STRIPES == RAY_COUNTER_STRIPES
        && reproject::COUNTER_STRIPE_WORDS == RAY_COUNTER_STRIDE
);
const _: () = assert!(
    COUNTER_SAMPLES == RAY_REFRACTION + 1
        && RAY_DIFFUSE == COUNTER_SAMPLES + 1
        && COUNTER_SLOTS == RAY_DIFFUSE + 1
);
const _: () = assert!(reproject::C_STRIPE_DONE < reproject::COUNTER_STRIPE_WORDS);
// The temporal statistics' stripes count diffuse rays where the full frame does: at the index
// of the (shared, never striped) job-list length.
const _: () = assert!(RAY_DIFFUSE == reproject::C_JOBS && reproject::C_SAMPLES == COUNTER_SAMPLES);
const _: () = assert!(
    reproject::C_HISTOGRAM == (reproject::COUNTER_STRIPES + 1) * reproject::COUNTER_STRIPE_WORDS
);
const _: () = assert!(reproject::C_SWEEP == reproject::C_HISTOGRAM + reproject::REFRESH_BINS);
const _: () = assert!(reproject::REFRESH_BINS.is_power_of_two());
const _: () = assert!(reproject::RP_COUNTER_SLOTS == reproject::C_SWEEP + 1);
const _: () = assert!(
    reproject::KEY_LOW_MASK
        == reproject::KEY_NOT_COPYABLE | ((1 << (2 * reproject::KEY_PLACE_BITS)) - 1)
        && reproject::KEY_NOT_COPYABLE == 1 << (2 * reproject::KEY_PLACE_BITS)
);
const _: () = assert!(GBUFFER_BARY + 1 == GBUFFER_IMAGES);
// `vk::rows_of_groups` rows: within `maxComputeWorkGroupCount[0]`'s minimum, and a power of two
// (the shaders split an invocation index into row and column with it).
const _: () = assert!(GROUPS_PER_ROW.is_power_of_two() && GROUPS_PER_ROW <= 65_535);
// Temporal pixel states: the kinds fit their mask, and the reason bits start above it; cache
// flags stay below the hop count.
const _: () = assert!(
    reproject::PX_INTERP <= reproject::PX_KIND_MASK
        && reproject::PX_KIND_MASK + 1 == reproject::PX_HOLE
);
const _: () = assert!(reproject::CACHE_MOVED < 1 << reproject::CACHE_HOPS_SHIFT);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bindings_place_entries_at_their_numbers() {
        let table = bindings(&[
            (BINDING_RT_AOV, Binding::StorageBuffer),
            (BINDING_FRAME, Binding::UniformBuffer),
        ]);
        assert_eq!(table.len(), BINDING_RT_AOV as usize + 1);
        assert!(matches!(
            table[BINDING_FRAME as usize],
            Binding::UniformBuffer
        ));
        assert!(matches!(
            table[BINDING_RT_AOV as usize],
            Binding::StorageBuffer
        ));
        assert!(matches!(table[0], Binding::Unused));
    }

    #[test]
    #[should_panic(expected = "declared twice")]
    fn bindings_reject_a_number_used_twice() {
        bindings(&[
            (BINDING_HYBRID_AOV, Binding::StorageBuffer),
            (BINDING_RT_AOV, Binding::StorageBuffer),
        ]);
    }

    /// Asserts that `ids`, sorted, are `first, first + 1, ..` (or, with `bits`, the powers of
    /// two from `first`): a family of ids without gaps or duplicates.
    fn assert_contiguous(what: &str, ids: &[u32], first: u32, bits: bool) {
        let mut sorted = ids.to_vec();
        sorted.sort_unstable();
        let expected: Vec<u32> = (0..ids.len() as u32)
            .map(|i| if bits { first << i } else { first + i })
            .collect();
        assert_eq!(sorted, expected, "{what} have a gap or a duplicate");
    }

    #[test]
    fn frame_flags_are_distinct_bits() {
        assert_contiguous(
            "frame flags",
            &[
                FLAG_NO_SPECULAR,
                FLAG_SKY,
                FLAG_WRITE_AOV,
                FLAG_ADAPTIVE_CORNERS,
                FLAG_ENV_BACKGROUND,
                FLAG_SEQUENCE_JITTER,
                distributed::FLAG_DIFFUSE_LIGHT_SAMPLED,
            ],
            1,
            true,
        );
    }

    #[test]
    fn temporal_ids_have_no_gaps() {
        use reproject::*;
        assert_contiguous(
            "temporal bindings",
            &[
                BINDING_SCENE,
                BINDING_TEXTURES,
                BINDING_RAY_BACKEND,
                BINDING_FRAME,
                BINDING_RP_PARAMS,
                BINDING_RP_KEY_WINNER,
                BINDING_RP_COUNTERS,
                BINDING_RP_DISPATCH_ARGS,
            ],
            0,
            false,
        );
        let gbuffer: Vec<u32> = (0..GBUFFER_IMAGES)
            .map(|i| BINDING_RP_GBUFFER + i)
            .collect();
        assert_contiguous(
            "temporal G-buffer bindings",
            &gbuffer,
            BINDING_RP_DISPATCH_ARGS + 1,
            false,
        );
        assert_contiguous(
            "temporal params flags",
            &[
                RP_REUSE,
                RP_GBUFFER,
                RP_VERIFY_ALL,
                RP_FRAMELESS,
                RP_ADAPTIVE,
                RP_MOVING,
                RP_LINEAR_COLOR,
            ],
            1,
            true,
        );
        assert_contiguous(
            "pixel kinds",
            &[PX_REUSE, PX_TRACE, PX_VERIFY, PX_TRACED, PX_INTERP],
            1,
            false,
        );
        assert_contiguous(
            "pixel state reasons",
            &[
                PX_HOLE,
                PX_REJECTED,
                PX_VIEW_DEPENDENT,
                PX_EXPIRED,
                PX_FRAMELESS,
                PX_FILLED,
            ],
            PX_KIND_MASK + 1,
            true,
        );
        assert_contiguous(
            "cache entry flags",
            &[CACHE_VALID, CACHE_MISS, CACHE_VIEW_DEPENDENT, CACHE_MOVED],
            1,
            true,
        );
        assert_contiguous(
            "job lists",
            &[LIST_VERIFY, LIST_TRACE, LIST_PENDING, JOB_LISTS],
            0,
            false,
        );
        // The counter slots of a stripe (and of the shared slots before the stripes): the ray
        // kinds, then every named slot, each once.
        assert_contiguous(
            "temporal counter slots",
            &[
                RAY_PRIMARY,
                RAY_SHADOW,
                RAY_REFLECTION,
                RAY_REFRACTION,
                C_SAMPLES,
                C_JOBS,
                C_REUSED,
                C_TRACED,
                C_INTERP,
                C_HOLES,
                C_REJECTED,
                C_VIEW_DEPENDENT,
                C_EXPIRED,
                C_FRAMELESS,
                C_VERIFY_RAYS,
                C_SHOWN_FILLED,
                C_WINDOW_START,
                C_WINDOW_BINS,
                C_FILLED,
                C_TILES_DONE,
                C_TRACE_JOBS,
                C_PENDING_JOBS,
                C_STRIPE_DONE,
            ],
            0,
            false,
        );
    }

    #[test]
    fn every_interface_file_has_a_generated_header() {
        let names: Vec<&str> = crate::shaders::INTERFACE_GLSL.iter().map(|h| h.0).collect();
        assert_eq!(
            names,
            [
                "interface_bvh.glsl",
                "interface_denoise.glsl",
                "interface_distributed.glsl",
                "interface_environment.glsl",
                "interface_passes.glsl",
                "interface_reproject.glsl",
                "interface_shared.glsl"
            ]
        );
        let shared = crate::shaders::INTERFACE_GLSL
            .iter()
            .find(|h| h.0 == "interface_shared.glsl")
            .unwrap()
            .1;
        assert!(shared.contains(&format!("#define BINDING_FRAME {BINDING_FRAME}u")));
        assert!(shared.contains("struct GpuFrame {"));
    }
}

//! The technique's pipelines and descriptor sets: one pipeline per stage that traces no rays
//! ([`Stage`], `shaders/temporal/temporal_<stage>.comp`), the verify and tracing passes,
//! and the one-pass scatter where the device has 64-bit atomics. Every pass binds the same set,
//! declared once ([`SLOTS`]): that one list makes both the set layout and the descriptor writes.

use std::sync::Arc;

use crate::accel::Backend;
use crate::interface::reproject::{
    ReprojectPush, TracePush, VerifyPush, BINDING_RP_COUNTERS, BINDING_RP_DISPATCH_ARGS,
    BINDING_RP_GBUFFER, BINDING_RP_KEY_WINNER, BINDING_RP_PARAMS,
};
use crate::interface::{
    bindings, BINDING_FRAME, BINDING_RAY_BACKEND, BINDING_SCENE, BINDING_TEXTURES, GBUFFER_IMAGES,
};
use crate::render::{PassContext, Shading};
use crate::vk::{Binding, ComputePipeline, Context, DescriptorSet, VkResult};

use super::resources::Resources;

/// The stages that trace no rays, each its own shader (`shaders/temporal/temporal_<stage>.comp`)
/// and pipeline, all with one set layout; in the order a frame records them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub(super) enum Stage {
    /// The first of the two 32-bit scatter passes: the nearest depth key per pixel.
    Scatter,
    /// The second: the lowest source index among the samples at that depth.
    Resolve,
    /// The sample each pixel shows, fills, and the frameless candidates' histogram.
    Shown,
    /// The frameless refresh window.
    Threshold,
    /// Decide, commit, count and list every pixel.
    Classify,
    /// Adaptive sub-sampling's interpolation at one level.
    Interpolate,
}

impl Stage {
    /// Every stage, in the order of their discriminants (the index of a stage's pipeline).
    pub(super) const ALL: [Self; 6] = [
        Self::Scatter,
        Self::Resolve,
        Self::Shown,
        Self::Threshold,
        Self::Classify,
        Self::Interpolate,
    ];

    /// The stage's shader and pipeline name.
    fn shader(self) -> (&'static [u8], &'static str) {
        use crate::shaders as s;
        match self {
            Self::Scatter => (s::TEMPORAL_SCATTER_COMP, "temporal scatter"),
            Self::Resolve => (s::TEMPORAL_RESOLVE_COMP, "temporal resolve"),
            Self::Shown => (s::TEMPORAL_SHOWN_COMP, "temporal shown"),
            Self::Threshold => (s::TEMPORAL_THRESHOLD_COMP, "temporal threshold"),
            Self::Classify => (s::TEMPORAL_CLASSIFY_COMP, "temporal classify"),
            Self::Interpolate => (s::TEMPORAL_INTERPOLATE_COMP, "temporal interpolate"),
        }
    }
}

fn verify_spirv(backend: Backend) -> &'static [u8] {
    match backend {
        Backend::Hw => crate::shaders::TEMPORAL_VERIFY_COMP_HW,
        Backend::Bvh => crate::shaders::TEMPORAL_VERIFY_COMP_BVH,
    }
}

fn trace_spirv(backend: Backend, shading: Shading) -> &'static [u8] {
    use crate::shaders as s;
    match (shading, backend) {
        (Shading::Whitted, Backend::Hw) => s::TEMPORAL_TRACE_COMP_HW,
        (Shading::Whitted, Backend::Bvh) => s::TEMPORAL_TRACE_COMP_BVH,
        (Shading::Distributed, Backend::Hw) => s::TEMPORAL_TRACE_DISTRIBUTED_COMP_HW,
        (Shading::Distributed, Backend::Bvh) => s::TEMPORAL_TRACE_DISTRIBUTED_COMP_BVH,
    }
}

/// What a binding of the temporal set holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Slot {
    /// The scene uniform (the renderer's).
    Scene,
    /// The bindless textures (the renderer's).
    Textures,
    /// The ray backend (the renderer's; unused by the stages that trace no rays).
    RayBackend,
    /// [`Resources::frame`].
    Frame,
    /// [`Resources::params`].
    Params,
    /// [`Resources::key_winner`].
    KeyWinner,
    /// [`Resources::counters`].
    Counters,
    /// [`Resources::args`].
    DispatchArgs,
    /// G-buffer image `GBUFFER_*` of [`Resources::gbuffer`].
    Gbuffer(u32),
}

/// The set every temporal pass binds, declared once: binding number and what it holds.
const SLOTS: [(u32, Slot); 8 + GBUFFER_IMAGES as usize] = {
    let named = [
        (BINDING_SCENE, Slot::Scene),
        (BINDING_TEXTURES, Slot::Textures),
        (BINDING_RAY_BACKEND, Slot::RayBackend),
        (BINDING_FRAME, Slot::Frame),
        (BINDING_RP_PARAMS, Slot::Params),
        (BINDING_RP_KEY_WINNER, Slot::KeyWinner),
        (BINDING_RP_COUNTERS, Slot::Counters),
        (BINDING_RP_DISPATCH_ARGS, Slot::DispatchArgs),
    ];
    let mut slots = [named[0]; 8 + GBUFFER_IMAGES as usize];
    let mut i = 0;
    while i < named.len() {
        slots[i] = named[i];
        i += 1;
    }
    let mut g = 0;
    while g < GBUFFER_IMAGES {
        slots[named.len() + g as usize] = (BINDING_RP_GBUFFER + g, Slot::Gbuffer(g));
        g += 1;
    }
    slots
};

/// The set layout of [`SLOTS`], with `ray_backend` for the ray backend's binding
/// ([`Binding::Unused`] for the passes that trace no rays).
fn layout(texture_capacity: u32, ray_backend: Binding) -> Vec<Binding> {
    let kinds: Vec<(u32, Binding)> = SLOTS
        .iter()
        .map(|&(number, slot)| {
            let kind = match slot {
                Slot::Textures => Binding::SampledImages(texture_capacity),
                Slot::RayBackend => ray_backend,
                Slot::Scene | Slot::Frame | Slot::Params => Binding::UniformBuffer,
                Slot::KeyWinner | Slot::Counters | Slot::DispatchArgs => Binding::StorageBuffer,
                Slot::Gbuffer(_) => Binding::StorageImage,
            };
            (number, kind)
        })
        .collect();
    bindings(&kinds)
}

/// Writes [`SLOTS`] into `set`: the scene's bindings (with the ray backend where `rays`) and
/// `res`'s buffers and images.
fn write(set: &DescriptorSet, pass: &PassContext<'_>, res: &Resources, rays: bool) {
    for &(number, slot) in &SLOTS {
        match slot {
            // The renderer's, written together below.
            Slot::Scene | Slot::Textures | Slot::RayBackend => {}
            Slot::Frame => {
                set.buffer(number, &res.frame, Binding::UniformBuffer);
            }
            Slot::Params => {
                set.buffer(number, &res.params, Binding::UniformBuffer);
            }
            Slot::KeyWinner => {
                set.buffer(number, &res.key_winner, Binding::StorageBuffer);
            }
            Slot::Counters => {
                set.buffer(number, &res.counters, Binding::StorageBuffer);
            }
            Slot::DispatchArgs => {
                set.buffer(number, &res.args, Binding::StorageBuffer);
            }
            Slot::Gbuffer(i) => {
                set.storage_image(number, res.gbuffer.images()[i as usize].view());
            }
        }
    }
    if rays {
        pass.bind_scene(set);
    } else {
        pass.scene.bind(set);
        set.sampled_images(BINDING_TEXTURES, pass.textures);
    }
}

/// The pipelines of one [`super::Reprojector`] and their descriptor sets (one set per
/// pipeline: the buffers that alternate between frames, the caches and anchors, are reached
/// through the addresses in the params, written every frame).
pub(super) struct Pipelines {
    /// The stages' pipelines, indexed by [`Stage`] (sharing one set layout).
    pub(super) stages: Vec<Arc<ComputePipeline>>,
    /// The stages' descriptor set.
    pub(super) stages_set: DescriptorSet,
    /// The rt path's verify pass (`temporal_verify.comp`) and its set (its pipeline and
    /// timestamp scope keep the names `reproject visibility` and `visibility`, which outputs
    /// show).
    pub(super) verify: (Arc<ComputePipeline>, DescriptorSet),
    /// The tracing pass (`temporal_trace.comp`) and its set.
    pub(super) trace: (Arc<ComputePipeline>, DescriptorSet),
    /// The one-pass scatter and its descriptor set, where the device has 64-bit buffer
    /// atomics.
    pub(super) scatter64: Option<(Arc<ComputePipeline>, DescriptorSet)>,
}

impl Pipelines {
    /// Builds every pipeline and writes its set.
    pub(super) fn build(
        ctx: &Context,
        pass: &PassContext<'_>,
        res: &Resources,
        shading: Shading,
    ) -> VkResult<Self> {
        let capacity = pass.texture_capacity();
        let no_rays = layout(capacity, Binding::Unused);
        let rays = layout(capacity, pass.backend.binding());
        let push_size = |bytes: usize| bytes as u32;
        let backend = pass.backend.kind();
        let stages = Stage::ALL
            .iter()
            .map(|&stage| {
                let (spirv, name) = stage.shader();
                ComputePipeline::cached(
                    ctx,
                    name,
                    spirv,
                    &no_rays,
                    push_size(std::mem::size_of::<ReprojectPush>()),
                )
            })
            .collect::<VkResult<Vec<_>>>()?;
        let verify = ComputePipeline::cached(
            ctx,
            "reproject visibility",
            verify_spirv(backend),
            &rays,
            push_size(std::mem::size_of::<VerifyPush>()),
        )?;
        let trace = ComputePipeline::cached(
            ctx,
            "reproject trace",
            trace_spirv(backend, shading),
            &rays,
            push_size(std::mem::size_of::<TracePush>()),
        )?;
        // One pass instead of two for the scatter where the device has 64-bit atomics.
        let scatter64 = if ctx.features().buffer_int64_atomics {
            Some(ComputePipeline::cached(
                ctx,
                "reproject scatter (64-bit atomics)",
                crate::shaders::TEMPORAL_SCATTER64_COMP,
                &no_rays,
                0,
            )?)
        } else {
            None
        };
        let make = |pipeline: Arc<ComputePipeline>,
                    rays: bool|
         -> VkResult<(Arc<ComputePipeline>, DescriptorSet)> {
            let set = pipeline.allocate_set()?;
            write(&set, pass, res, rays);
            Ok((pipeline, set))
        };
        let stages_set = stages[0].allocate_set()?;
        write(&stages_set, pass, res, false);
        Ok(Self {
            stages,
            stages_set,
            verify: make(verify, true)?,
            trace: make(trace, true)?,
            scatter64: scatter64.map(|p| make(p, false)).transpose()?,
        })
    }

    /// Rebinds the scene (its ray backend, which an update may have built again) in the sets of
    /// the passes that trace rays.
    pub(super) fn rebind_scene(&self, pass: &PassContext<'_>) {
        pass.bind_scene(&self.verify.1);
        pass.bind_scene(&self.trace.1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stages_are_numbered_in_pipeline_order() {
        for (index, stage) in Stage::ALL.iter().enumerate() {
            assert_eq!(*stage as usize, index, "{stage:?}");
        }
    }

    #[test]
    fn the_set_has_no_unused_bindings() {
        let table = layout(4, Binding::StorageBuffer);
        assert_eq!(table.len(), SLOTS.len());
        assert!(
            !table.iter().any(|b| matches!(b, Binding::Unused)),
            "{table:?}"
        );
        let mut numbers: Vec<u32> = SLOTS.iter().map(|s| s.0).collect();
        numbers.sort_unstable();
        assert_eq!(numbers, (0..SLOTS.len() as u32).collect::<Vec<_>>());
    }
}

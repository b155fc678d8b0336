//! Animated frames: one persistent renderer whose scene is updated per frame instead of
//! uploaded and built again.
//!
//! [`AnimatedFrames::new`] uploads the scene posed at the first frame and builds its ray
//! backend once. [`AnimatedFrames::update`] then moves it to a later time:
//! 0. **previous frame**: the instances and the deformed geometry's vertex ranges are copied
//!    into the scene's previous-frame buffers ([`GpuScene::keep_previous_frame`]), from which
//!    the G-buffer's motion vectors take each point's previous position;
//! 1. **skin**: the GPU skinning/morphing pass ([`crate::render::passes::skin`]) of every deformed
//!    (skinned or morphed) instance writes its vertices into the scene's vertex buffers
//!    (`skin_scatter.comp`); node-only animation does no vertex work;
//! 2. instance transforms, lights and the scene bounds are uploaded;
//! 3. **acceleration structures**: on `hw` the BLASes of deformed geometry are refitted
//!    (mode `UPDATE`, built again every [`hw_update::DEFAULT_HW_REBUILD_EVERY`] refits) and
//!    the TLAS is built again ([`hw_update::HwAnimatedAccel`]); on `bvh` the bottom levels of
//!    deformed geometry are refitted from the skinned vertices on the GPU
//!    ([`GpuBvh::refit_device`]: the host never reads them) and the top level rebuilt
//!    ([`GpuBvh::rebuild_tlas_deformed`]); once the refitted bottom levels' SAH cost grew past
//!    [`UpdatePolicy::bvh_max_sah_growth`] over the built trees', those bottom levels alone
//!    are built again ([`GpuBvh::rebuild_bottom_levels`]).
//!
//! Static geometry is never rebuilt nor refitted on either backend ([`AnimationCounters`]
//! counts the builds). The scene is still posed on the CPU per frame ([`Scene::posed`],
//! vertices included): the returned scene gives the frame's bounds, cameras and lights, and
//! the rare `bvh` bottom-level rebuild builds from its positions; neither the refits nor the
//! top-level builds read its deformed vertices. [`AnimatedFrames::update_by_rebuild`] keeps the former path (upload
//! and build everything per frame) for comparisons.

use std::sync::Arc;

use ash::vk;

use crate::accel::bvh::refit::DeviceVertices;
use crate::accel::bvh::{BvhBuild, BvhBuildOptions, GpuBvh};
use crate::accel::hw_update::{self, HwAnimatedAccel, HwUpdateCounters};
use crate::accel::{Backend, RayBackend};
use crate::render::passes::skin::{self, SkinningPass};
use crate::scene::gpu::GpuScene;
use crate::scene::Scene;
use crate::vk::{memory_barrier, Binding, ComputePipeline, Context, DescriptorSet, GpuProfiler};

use crate::render::Renderer;

/// Push constants of `skin_scatter.comp` (first vertex, count, tangents flag, padding); the
/// copy is timed with the skinning pass under [`skin::PASS_NAME`].
const SCATTER_PUSH_BYTES: u32 = 16;

/// How the frames of an animated sequence get their scene (`--animation-update`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AnimationUpdate {
    /// GPU skinning into the scene's vertex buffers, refit of the deformed geometry's
    /// acceleration structures, top level built again ([`AnimatedFrames::update`]).
    #[default]
    Refit,
    /// Upload the posed scene and build every acceleration structure again per frame
    /// ([`AnimatedFrames::update_by_rebuild`]; for comparisons).
    Rebuild,
}

/// When an update rebuilds instead of refitting.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct UpdatePolicy {
    /// `bvh`: rebuild the BVH once the refitted bottom levels' SAH cost exceeds the built
    /// tree's by this fraction (0.3: 30 % costlier to trace, by the SAH model). A refit keeps
    /// the tree, so its boxes overlap more as a mesh deforms; 30 % is about where a rebuild
    /// (which costs several refits on lavapipe) pays back within a few frames.
    pub bvh_max_sah_growth: f64,
    /// `hw`: refits of a deformed BLAS before it is built again (the driver reports no
    /// quality measure, so a count stands in for one).
    pub hw_rebuild_every: u32,
}

impl Default for UpdatePolicy {
    fn default() -> Self {
        Self {
            bvh_max_sah_growth: 0.3,
            hw_rebuild_every: hw_update::DEFAULT_HW_REBUILD_EVERY,
        }
    }
}

/// Builds and refits so far (tests check static geometry is built once).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct AnimationCounters {
    /// Frames updated.
    pub updates: u64,
    /// Skinning dispatches (one per deformed instance per frame).
    pub skin_dispatches: u64,
    /// `hw` builds and refits.
    pub hw: HwUpdateCounters,
    /// `bvh` refits of the deformed bottom levels (one per frame with deformed geometry).
    pub bvh_refits: u64,
    /// `bvh` top-level rebuilds.
    pub bvh_tlas_rebuilds: u64,
    /// `bvh` builds of bottom levels of static geometry (one per static geometry at creation;
    /// more only after a full build).
    pub bvh_static_blas_builds: u64,
    /// `bvh` builds of bottom levels of deformed geometry (at creation, and when the SAH
    /// growth passed the policy's threshold).
    pub bvh_deformed_blas_builds: u64,
    /// `bvh` full builds after creation (only when a new top level no longer fit the room the
    /// built BVH reserved for it).
    pub bvh_full_rebuilds: u64,
    /// Full uploads and builds (creation, and every [`AnimatedFrames::update_by_rebuild`]).
    pub full_builds: u64,
    /// Largest SAH growth of the refitted `bvh` bottom levels over the built tree seen.
    pub bvh_max_sah_growth_seen: f64,
}

/// One deformed instance: its skinning pass and where its vertices go.
struct Deformer {
    instance: usize,
    pass: SkinningPass,
    scatter_set: DescriptorSet,
    first_vertex: u32,
    count: u32,
    has_tangents: u32,
}

/// A renderer kept across the frames of an animation (see the module docs).
pub struct AnimatedFrames {
    renderer: Renderer,
    rest: Scene,
    animations: Vec<usize>,
    backend: Backend,
    bvh_build: BvhBuild,
    deformers: Vec<Deformer>,
    /// Geometries (of the uploaded, posed scene) the deformers write.
    deformed_geometries: Vec<usize>,
    scatter: Arc<ComputePipeline>,
    /// SAH cost of the `bvh` bottom levels as built (set by the first refit after a build).
    bvh_built_sah: Option<f64>,
    /// When updates rebuild instead of refitting.
    pub policy: UpdatePolicy,
    counters: AnimationCounters,
}

/// The renderer of one animated frame, from the scene posed at that frame
/// ([`Scene::posed`]): uploads and builds everything (the path [`AnimatedFrames`]
/// replaces; kept for comparisons).
pub fn frame_renderer(
    ctx: &Context,
    posed: &Scene,
    backend: Backend,
    bvh_build: BvhBuild,
) -> crate::Result<Renderer> {
    Renderer::with_bvh_build(ctx, posed, backend, bvh_build)
}

/// GPU milliseconds of the acceleration-structure builds of a freshly built backend, as
/// `("blas build", ms)` and `("tlas build", ms)` (the `bvh` host builder's times are host
/// milliseconds).
pub fn build_scopes(backend: &RayBackend) -> Vec<(String, f64)> {
    let (blas, tlas) = match backend {
        RayBackend::Hw(a) => (
            a.stats.blas_build_ms + a.stats.compact_ms,
            a.stats.tlas_build_ms,
        ),
        RayBackend::HwAnimated(_) => (0.0, 0.0),
        RayBackend::Bvh(b) => {
            let s = b.stats();
            match &s.gpu_phases {
                Some(p) => (
                    p.morton_ms + p.sort_ms + p.clustering_ms + p.collapse_ms + p.relocate_ms,
                    p.tlas_ms,
                ),
                None => (s.blas_ms, s.tlas_ms),
            }
        }
    };
    vec![("blas build".into(), blas), ("tlas build".into(), tlas)]
}

impl AnimatedFrames {
    /// Uploads `rest` posed at `time` seconds of `animations` and builds its ray backend
    /// (`bvh_build`: where the compute BVH is built), ready for [`Self::update`].
    pub fn new(
        ctx: &Context,
        rest: &Scene,
        animations: &[usize],
        time: f32,
        backend: Backend,
        bvh_build: BvhBuild,
    ) -> crate::Result<Self> {
        let posed = rest.posed(animations, time);
        let gpu_textures = crate::scene::textures::GpuTextures::upload(ctx, &posed)?;
        let textures = gpu_textures.descriptors();
        let mut gpu = GpuScene::upload(ctx, &posed, textures.len() as u32)?;
        gpu.keep_previous_frame(ctx)?;
        let scatter = ComputePipeline::cached(
            ctx,
            "skin scatter",
            crate::shaders::SKIN_SCATTER_COMP,
            &[Binding::StorageBuffer; 5],
            SCATTER_PUSH_BYTES,
        )?;
        // `Scene::posed` deforms only scenes whose rig covers every instance.
        let poses =
            !rest.rig.nodes.is_empty() && rest.rig.instance_local.len() == rest.instances.len();
        let mut deformers = Vec::new();
        let mut deformed = vec![false; posed.geometries.len()];
        for (k, inst) in rest.instances.iter().enumerate().filter(|_| poses) {
            let g = &rest.geometries[inst.geometry as usize];
            if !g.is_deformable() {
                continue;
            }
            let skin = rest.rig.nodes[inst.node]
                .skin
                .filter(|_| !g.joints.is_empty());
            let joint_count = skin.map_or(0, |s| rest.rig.skins[s].joints.len());
            let pass = SkinningPass::new(ctx, g, joint_count)?;
            let target = posed.instances[k].geometry as usize;
            deformed[target] = true;
            let record = gpu.geometry_records[target];
            let scatter_set = scatter.allocate_set()?;
            scatter_set
                .buffer(0, &pass.positions, Binding::StorageBuffer)
                .buffer(1, &pass.normals, Binding::StorageBuffer)
                .buffer(2, &pass.tangents, Binding::StorageBuffer)
                .buffer(3, &gpu.positions, Binding::StorageBuffer)
                .buffer(4, &gpu.attributes, Binding::StorageBuffer);
            deformers.push(Deformer {
                instance: k,
                pass,
                scatter_set,
                first_vertex: record.first_vertex,
                count: record.vertex_count,
                has_tangents: u32::from(
                    g.tangents.len() == g.positions.len() && !g.tangents.is_empty(),
                ),
            });
        }
        let ray_backend = match backend {
            Backend::Hw => RayBackend::HwAnimated(Box::new(HwAnimatedAccel::build(
                ctx, &posed, &gpu, &deformed,
            )?)),
            Backend::Bvh => RayBackend::build(ctx, &posed, &gpu, backend, bvh_build)?,
        };
        let deformed_geometries: Vec<usize> =
            (0..deformed.len()).filter(|&g| deformed[g]).collect();
        let (static_blas, deformed_blas) = match &ray_backend {
            RayBackend::Bvh(b) => {
                let deformed = deformed_geometries.len() as u64;
                (
                    (b.stats().blas_count as u64).saturating_sub(deformed),
                    deformed,
                )
            }
            _ => (0, 0),
        };
        let renderer = Renderer::from_parts(ctx, gpu, ray_backend, gpu_textures, textures);
        log::info!(
            "animated frames: {} deformed instance(s) skinned on the GPU, {} backend updated per frame",
            deformers.len(),
            backend.as_str()
        );
        Ok(Self {
            renderer,
            rest: rest.clone(),
            animations: animations.to_vec(),
            backend,
            bvh_build,
            deformers,
            deformed_geometries,
            scatter,
            bvh_built_sah: None,
            policy: UpdatePolicy::default(),
            counters: AnimationCounters {
                full_builds: 1,
                bvh_static_blas_builds: static_blas,
                bvh_deformed_blas_builds: deformed_blas,
                ..Default::default()
            },
        })
    }

    /// Lights every frame with `environment` (kept across renderer rebuilds).
    pub fn set_environment(
        &mut self,
        ctx: &Context,
        environment: Option<crate::environment::GpuEnvironment>,
    ) -> crate::Result<()> {
        self.renderer.set_environment(ctx, environment)
    }

    /// The renderer of the frame of the last update.
    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// Builds and refits so far.
    pub fn counters(&self) -> AnimationCounters {
        let mut c = self.counters;
        if let RayBackend::HwAnimated(a) = &self.renderer.backend {
            c.hw = a.counters;
        }
        c
    }

    /// Deformed (skinned or morphed) instances, skinned on the GPU per update.
    pub fn deformed_instances(&self) -> usize {
        self.deformers.len()
    }

    /// Moves the scene to `time` seconds: GPU skinning of the deformed instances into the
    /// scene's vertex buffers, new instance transforms, lights and bounds, and the
    /// acceleration-structure update of the module docs. Returns the posed scene (cameras,
    /// lights: what the frame loop needs from it) and the GPU milliseconds of the update by
    /// pass: [`skin::PASS_NAME`], [`hw_update::BLAS_PASS_NAME`] and
    /// [`hw_update::TLAS_PASS_NAME`] (`bvh`: the refit's and the top-level build's GPU
    /// times; a full rebuild reports `blas build`/`tlas build` instead).
    pub fn update(
        &mut self,
        ctx: &Context,
        time: f32,
    ) -> crate::Result<(Scene, Vec<(String, f64)>)> {
        let posed = self.rest.posed(&self.animations, time);
        let pose = self.rest.rig.pose(&self.animations, time);
        // This frame becomes the previous one (motion vectors) before anything moves.
        let moving: Vec<(u32, u32)> = self
            .deformers
            .iter()
            .map(|d| (d.first_vertex, d.count))
            .collect();
        let gpu = &self.renderer.gpu;
        ctx.run("previous frame", |cmd| {
            gpu.record_previous_frame(ctx, cmd, &moving);
            Ok(())
        })?;
        for d in &mut self.deformers {
            let (joints, weights) = self.rest.instance_deformation(d.instance, &pose);
            d.pass.update(joints.as_deref(), weights)?;
        }
        self.renderer.gpu.update_frame(ctx, &posed)?;
        self.renderer.scene_scale = self.renderer.gpu.refs_data.scene_scale;
        if let RayBackend::HwAnimated(a) = &mut self.renderer.backend {
            a.rebuild_every = self.policy.hw_rebuild_every;
            a.write_instances(&posed)?;
        }
        let scopes = 2 * self.deformers.len() as u32 + 4;
        let mut profiler = match ctx.features().timestamps {
            true => Some(GpuProfiler::new(ctx, scopes)?),
            false => None,
        };
        let (deformers, scatter) = (&self.deformers, &self.scatter);
        let backend = &mut self.renderer.backend;
        ctx.run("animation update", |cmd| {
            if let Some(p) = profiler.as_mut() {
                p.reset(cmd);
            }
            record_skinning(ctx, cmd, deformers, scatter, profiler.as_mut());
            if let RayBackend::HwAnimated(a) = backend {
                a.record_update(ctx, cmd, profiler.as_mut())?;
            }
            Ok(())
        })?;
        let mut timings = match &profiler {
            Some(p) => crate::render::merge_scopes(p.results()?),
            None => Vec::new(),
        };
        self.counters.updates += 1;
        self.counters.skin_dispatches += self.deformers.len() as u64;
        if self.backend == Backend::Bvh {
            timings.extend(self.update_bvh(ctx, &posed)?);
        }
        Ok((posed, timings))
    }

    /// Refits the compute BVH's deformed bottom levels to the skinned vertices on the GPU
    /// and rebuilds its top level; builds those bottom levels again when the refit degraded
    /// them past the policy (static ones are kept), and the whole BVH only when the new top
    /// level does not fit.
    fn update_bvh(&mut self, ctx: &Context, posed: &Scene) -> crate::Result<Vec<(String, f64)>> {
        let Renderer { gpu, backend, .. } = &mut self.renderer;
        let RayBackend::Bvh(bvh) = backend else {
            return Ok(Vec::new());
        };
        let opts = BvhBuildOptions::default();
        let mut scopes = Vec::new();
        if !self.deformed_geometries.is_empty() {
            let vertices = DeviceVertices::of_scene(gpu, self.deformed_geometries.clone());
            let report = bvh.refit_device(ctx, posed, &vertices)?;
            self.counters.bvh_refits += 1;
            let built = *self.bvh_built_sah.get_or_insert(report.blas_sah_before);
            let growth = if built > 0.0 {
                report.blas_sah_after / built - 1.0
            } else {
                0.0
            };
            self.counters.bvh_max_sah_growth_seen =
                self.counters.bvh_max_sah_growth_seen.max(growth);
            scopes.push((
                hw_update::BLAS_PASS_NAME.to_string(),
                report.gpu_ms.unwrap_or(0.0),
            ));
            if growth > self.policy.bvh_max_sah_growth {
                log::info!(
                    "bvh refit: deformed bottom levels {:.0} % costlier than built (threshold {:.0} %): building them again",
                    growth * 100.0,
                    self.policy.bvh_max_sah_growth * 100.0
                );
                let built = bvh.rebuild_bottom_levels(
                    ctx,
                    posed,
                    &self.deformed_geometries,
                    &opts,
                    self.bvh_build,
                )?;
                self.bvh_built_sah = None;
                self.counters.bvh_deformed_blas_builds += self.deformed_geometries.len() as u64;
                self.counters.bvh_tlas_rebuilds += 1;
                let blas_ms = match &built.gpu_phases {
                    Some(p) => p.morton_ms + p.sort_ms + p.clustering_ms + p.collapse_ms,
                    None => built.blas_ms,
                };
                scopes.push(("blas build".into(), blas_ms));
                scopes.push((hw_update::TLAS_PASS_NAME.to_string(), tlas_ms(bvh)));
                return Ok(scopes);
            }
        }
        match bvh.rebuild_tlas_deformed(ctx, posed, &opts) {
            Ok(()) => {
                self.counters.bvh_tlas_rebuilds += 1;
                scopes.push((hw_update::TLAS_PASS_NAME.to_string(), tlas_ms(bvh)));
                return Ok(scopes);
            }
            Err(e) => {
                log::warn!("bvh top level not rebuilt in place ({e}); building the BVH again")
            }
        }
        let new = GpuBvh::build_with(ctx, posed, &opts, self.bvh_build)?;
        let deformed = self.deformed_geometries.len() as u64;
        self.counters.bvh_static_blas_builds +=
            (new.stats().blas_count as u64).saturating_sub(deformed);
        self.counters.bvh_deformed_blas_builds += deformed;
        **bvh = new;
        self.bvh_built_sah = None;
        self.counters.bvh_full_rebuilds += 1;
        scopes.extend(build_scopes(&self.renderer.backend));
        Ok(scopes)
    }

    /// [`Self::update`] or [`Self::update_by_rebuild`], as `how` says.
    pub fn update_with(
        &mut self,
        ctx: &Context,
        time: f32,
        how: AnimationUpdate,
    ) -> crate::Result<(Scene, Vec<(String, f64)>)> {
        match how {
            AnimationUpdate::Refit => self.update(ctx, time),
            AnimationUpdate::Rebuild => self.update_by_rebuild(ctx, time),
        }
    }

    /// The former per-frame path, for comparisons: poses the scene at `time` on the CPU,
    /// uploads it and builds every acceleration structure again. Returns the posed scene and
    /// the GPU milliseconds of the builds (see [`build_scopes`]).
    pub fn update_by_rebuild(
        &mut self,
        ctx: &Context,
        time: f32,
    ) -> crate::Result<(Scene, Vec<(String, f64)>)> {
        let posed = self.rest.posed(&self.animations, time);
        let environment = self.renderer.take_environment(ctx)?;
        self.renderer = frame_renderer(ctx, &posed, self.backend, self.bvh_build)?;
        self.renderer.set_environment(ctx, environment)?;
        self.counters.full_builds += 1;
        self.counters.updates += 1;
        let scopes = build_scopes(&self.renderer.backend);
        Ok((posed, scopes))
    }
}

/// GPU milliseconds of the last top-level build (host milliseconds for a host-built BVH).
fn tlas_ms(bvh: &GpuBvh) -> f64 {
    let s = bvh.stats();
    s.gpu_phases.as_ref().map_or(s.tlas_ms, |p| p.tlas_ms)
}

/// Records the skinning pass of every deformed instance, then the copies into the scene's
/// vertex buffers, with barriers so the BLAS updates that follow read the new vertices.
fn record_skinning(
    ctx: &Context,
    cmd: vk::CommandBuffer,
    deformers: &[Deformer],
    scatter: &ComputePipeline,
    mut profiler: Option<&mut GpuProfiler>,
) {
    if deformers.is_empty() {
        return;
    }
    for d in deformers {
        d.pass.record(cmd, profiler.as_deref_mut());
    }
    memory_barrier(ctx.device(), cmd);
    if let Some(p) = profiler.as_deref_mut() {
        p.begin(cmd, skin::PASS_NAME);
    }
    for d in deformers {
        let push: Vec<u8> = [d.first_vertex, d.count, d.has_tangents, 0]
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect();
        scatter.dispatch(
            cmd,
            Some(&d.scatter_set),
            &push,
            [d.count.div_ceil(64), 1, 1],
        );
    }
    if let Some(p) = profiler {
        p.end(cmd);
    }
    memory_barrier(ctx.device(), cmd);
}

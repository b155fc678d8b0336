//! The compute-shader ray backend: a host-built two-level BVH traversed by
//! `shaders/common/trace_bvh.glsl`.
//!
//! One bottom-level BVH (BLAS) is built per geometry that an instance uses, in object space;
//! a top-level BVH (TLAS) is built over the instances' world-space boxes (each the transformed
//! BLAS root box), so instancing duplicates no triangle. Both levels are built as binary trees
//! with `obvhs` (PLOC, parallel reinsertion, SAH leaf collapse) and collapsed into one array of
//! 4-wide, 64-byte nodes that hold their children's boxes quantized to 8 bits (see [`layout`]).
//! Triangles are stored in leaf order as three exact vertex copies plus their original primitive
//! index (no separate primitive map).
//!
//! With `--bvh-build gpu` the bottom levels are built in compute shaders instead
//! ([`gpu_build`]: Morton codes, radix sort, PLOC, collapse into the same node layout).
//! [`GpuBvh::refit`] recomputes the boxes of both levels on the GPU after vertices or instance
//! transforms moved ([`refit`]).
//!
//! [`BvhData`] is the host form (with a CPU mirror of the traversal in [`cpu`]); [`GpuBvh`]
//! uploads it and owns the `BvhRefs` uniform bound at set 0, binding 2.

mod builder;
pub mod cpu;
pub mod gpu_build;
pub mod layout;
pub mod locality;
pub mod refit;
mod relink;
pub mod sah;
#[cfg(any(test, feature = "testing"))]
pub mod testing;
#[cfg(test)]
mod tests;

use crate::interface::bvh::GpuBvhRefs;
use crate::scene::Scene;
use crate::vk::{
    vk, Binding, Buffer, Context, DescriptorSet, MemoryHeapInfo, MemoryLocation, VkError,
};
use layout::{BvhInstance, BvhNode, BvhTriangle};

/// Node index of the top-level root.
pub const TLAS_ROOT: u32 = 0;

/// Errors of the BVH backend.
#[derive(Debug, thiserror::Error)]
pub enum BvhError {
    /// The scene references something that does not exist.
    #[error("invalid scene for the BVH: {0}")]
    InvalidScene(String),
    /// More primitives/nodes than the node links can address.
    #[error("the BVH cannot address this many {0} (links hold 27-bit primitive and 31-bit node indices)")]
    TooMany(&'static str),
    /// A traversal could need more stack entries than the shader has.
    #[error("the BVH can need {entries} traversal stack entries (top + bottom level) but the shader has {limit}")]
    TooDeep {
        /// Most entries a traversal can push.
        entries: u32,
        /// `BVH_STACK_SIZE`.
        limit: u32,
    },
    /// The BVH would not fit the device's memory.
    #[error("the BVH needs {needed} bytes but the largest device heap has {heap} bytes ({what}); use a smaller scene or a device with more memory")]
    TooLarge {
        /// Estimated or exact size.
        needed: u64,
        /// Largest device-local heap.
        heap: u64,
        /// "estimate" before the build, "exact" after it.
        what: &'static str,
    },
    /// A geometry has more triangles than the GPU build takes.
    #[error("geometry {geometry} has {triangles} triangles; the GPU BVH build takes at most {limit} per geometry (use --bvh-build host)")]
    GpuBuildLimit {
        /// Geometry index.
        geometry: usize,
        /// Its triangle count.
        triangles: usize,
        /// [`gpu_build::GPU_BUILD_MAX_TRIANGLES`].
        limit: usize,
    },
    /// A refit was asked for a scene whose topology differs from the built one, or whose new
    /// positions or transforms cannot be bounded.
    #[error("cannot refit the BVH: {0}; rebuild it instead")]
    Refit(String),
    /// A Vulkan failure while uploading.
    #[error(transparent)]
    Vk(#[from] VkError),
}

impl BvhError {
    fn too_many(what: &'static str) -> Self {
        Self::TooMany(what)
    }
}

/// PLOC neighbourhood search radius (`obvhs` presets 1, 6, 14, 24).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PlocSearch {
    /// 1: fastest build.
    Minimum,
    /// 6.
    Low,
    /// 14: `obvhs`'s medium preset.
    #[default]
    Medium,
    /// 24.
    High,
}

/// Build parameters of both levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhBuildOptions {
    /// PLOC search radius.
    pub search: PlocSearch,
    /// Depth below which PLOC searches with radius 1 (0: always `search`).
    pub search_depth_threshold: usize,
    /// Fraction of nodes reinsertion tries to move per pass (0 disables it).
    pub reinsertion_ratio: f32,
    /// Most triangles per bottom-level leaf (1..=16; top-level leaves hold one instance).
    pub max_leaf_size: u32,
    /// Traversal cost (relative to one triangle test) in the SAH of the leaf collapse; higher
    /// values make bigger leaves.
    pub collapse_traversal_cost: f32,
}

impl Default for BvhBuildOptions {
    fn default() -> Self {
        Self {
            search: PlocSearch::Medium,
            search_depth_threshold: 3,
            reinsertion_ratio: 0.05,
            max_leaf_size: 4,
            collapse_traversal_cost: 1.0,
        }
    }
}

/// Where the bottom levels are built.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BvhBuild {
    /// On the host with `obvhs`.
    Host,
    /// In compute shaders ([`gpu_build`]).
    Gpu,
}

impl BvhBuild {
    /// `"host"` or `"gpu"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Host => "host",
            Self::Gpu => "gpu",
        }
    }
}

/// What the user asked for with `--bvh-build`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BvhBuildChoice {
    /// Decided by measurement where the CLI resolves it ([`crate::device_select::autotune`]: the faster of
    /// both builds on a fixed mesh, ties to the host). Without a measurement
    /// ([`BvhBuildChoice::resolve`], `RQR_NO_AUTOTUNE=1`): the GPU build on discrete and
    /// integrated GPUs, the host build elsewhere (CPU devices such as lavapipe).
    #[default]
    Auto,
    /// Host build (`obvhs`).
    Host,
    /// Compute-shader build.
    Gpu,
}

impl BvhBuildChoice {
    /// Resolves the choice for a device, with a human-readable reason.
    pub fn resolve(self, device: &crate::vk::DeviceInfo) -> (BvhBuild, String) {
        match self {
            Self::Host => (BvhBuild::Host, "forced by --bvh-build host".into()),
            Self::Gpu => (BvhBuild::Gpu, "forced by --bvh-build gpu".into()),
            Self::Auto => match device.device_type.as_str() {
                "discrete" | "integrated" => (
                    BvhBuild::Gpu,
                    format!("auto: {} GPU (not yet measured there)", device.device_type),
                ),
                other => (
                    BvhBuild::Host,
                    format!("auto: {other} device, where the host build measured faster"),
                ),
            },
        }
    }
}

/// Build statistics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// `"host"` or `"gpu"`.
    pub builder: String,
    /// GPU times per phase of the GPU build (`None` for the host build).
    pub gpu_phases: Option<gpu_build::GpuBuildPhases>,
    /// Scratch bytes the GPU build allocated (0 for the host build).
    pub peak_scratch_bytes: u64,
    /// Whole host build (both levels, flattening), milliseconds.
    pub build_ms: f64,
    /// Bottom levels (gather + build + flatten), milliseconds.
    pub blas_ms: f64,
    /// Top level, milliseconds.
    pub tlas_ms: f64,
    /// Bytes of all GPU arrays.
    pub bytes: u64,
    /// Nodes of both levels.
    pub node_count: usize,
    /// Nodes of the top level (with the GPU build: the slots reserved for it, room for a
    /// top level over every instance; unused ones are never linked).
    pub tlas_nodes: usize,
    /// Number of bottom levels (unique geometries with triangles in use).
    pub blas_count: usize,
    /// Triangles stored (each unique geometry once).
    pub triangle_count: usize,
    /// Scene instances.
    pub instance_count: usize,
    /// Nodes on the longest top-level path.
    pub tlas_depth: u32,
    /// Nodes on the longest path of any bottom level.
    pub max_blas_depth: u32,
    /// `tlas_depth + max_blas_depth`.
    pub max_depth: u32,
    /// Most traversal stack entries a ray can need (checked against `BVH_STACK_SIZE`).
    pub max_stack: u32,
    /// Of which the top level's.
    pub tlas_stack: u32,
    /// Leaf size limit used.
    pub max_leaf_size: u32,
    /// Triangles left out (non-finite or repeated vertices: no ray can hit them).
    pub skipped_triangles: usize,
    /// Instances left out (singular or non-finite transform).
    pub skipped_instances: usize,
}

/// The flattened two-level BVH on the host, ready for upload.
#[derive(Clone, Debug, Default)]
pub struct BvhData {
    /// Top level (root = node 0), then every bottom level.
    pub nodes: Vec<BvhNode>,
    /// Triangles in leaf order (each with its original primitive index).
    pub triangles: Vec<BvhTriangle>,
    /// One per scene instance, in scene order.
    pub instances: Vec<BvhInstance>,
    /// Build statistics.
    pub stats: BvhStats,
}

impl BvhData {
    /// Builds the BVH of `scene`.
    pub fn build(scene: &Scene, opts: &BvhBuildOptions) -> Result<Self, BvhError> {
        builder::build(scene, opts)
    }

    /// Bytes of the GPU arrays (without the 48-byte uniform).
    pub fn byte_size(&self) -> u64 {
        (std::mem::size_of_val(self.nodes.as_slice())
            + std::mem::size_of_val(self.triangles.as_slice())
            + std::mem::size_of_val(self.instances.as_slice())) as u64
    }

    /// Upper bound of [`Self::byte_size`] before building: at most one node per triangle
    /// (a tree over n leaves has fewer than n inner nodes, plus one per single-leaf root) and
    /// one top-level node per instance.
    pub fn estimate_bytes(scene: &Scene) -> u64 {
        let tris = scene.unique_triangle_count() as u64;
        let inst = scene.instances.len() as u64;
        let geoms = scene.geometries.len() as u64;
        (tris + geoms + inst + 1) * std::mem::size_of::<BvhNode>() as u64
            + tris * std::mem::size_of::<BvhTriangle>() as u64
            + inst * std::mem::size_of::<BvhInstance>() as u64
    }
}

/// Refuses `needed` bytes when they exceed the largest device-local heap (or the largest
/// heap when none is device-local).
pub fn check_fits(
    heaps: &[MemoryHeapInfo],
    needed: u64,
    what: &'static str,
) -> Result<(), BvhError> {
    let heap = crate::vk::largest_device_heap(heaps);
    if needed > heap {
        return Err(BvhError::TooLarge { needed, heap, what });
    }
    Ok(())
}

/// The BVH on the device: node, triangle (each with its primitive index) and instance
/// buffers, and the `BvhRefs` uniform (set 0, `BINDING_RAY_BACKEND` in every
/// `RAY_BACKEND_BVH` shader).
pub struct GpuBvh {
    nodes: Buffer,
    triangles: Buffer,
    instances: Buffer,
    refs: Buffer,
    refs_data: GpuBvhRefs,
    stats: BvhStats,
    /// Made by the first [`Self::refit`].
    refit_plan: Option<Box<refit::RefitPlan>>,
    /// Made by the first [`Self::refit_device`] (bottom levels only, so top-level rebuilds
    /// keep it; [`Self::rebuild_bottom_levels`] drops it).
    device_refit: Option<Box<refit::RefitPlan>>,
    /// Per geometry of the scene built from: (positions, indices), which a refit must keep.
    built_shape: Option<Vec<(usize, usize)>>,
}

impl GpuBvh {
    /// Builds the BVH of `scene` with the chosen builder.
    pub fn build_with(
        ctx: &Context,
        scene: &Scene,
        opts: &BvhBuildOptions,
        build: BvhBuild,
    ) -> Result<Self, BvhError> {
        match build {
            BvhBuild::Host => Self::build(ctx, scene, opts),
            BvhBuild::Gpu => Ok(gpu_build::build(ctx, scene, opts)?.with_shape_of(scene)),
        }
    }

    /// Records the shape of the scene built from, which [`Self::refit`] checks.
    fn with_shape_of(mut self, scene: &Scene) -> Self {
        self.built_shape = Some(
            scene
                .geometries
                .iter()
                .map(|g| (g.positions.len(), g.indices.len()))
                .collect(),
        );
        self
    }

    /// Builds the BVH of `scene` on the host and uploads it. Checks an upper-bound size
    /// estimate against the device heaps before building and the exact size before allocating.
    pub fn build(ctx: &Context, scene: &Scene, opts: &BvhBuildOptions) -> Result<Self, BvhError> {
        check_fits(
            &ctx.info().memory_heaps,
            BvhData::estimate_bytes(scene),
            "estimate",
        )?;
        let data = BvhData::build(scene, opts)?;
        Ok(Self::upload(ctx, &data)?.with_shape_of(scene))
    }

    /// Uploads a host-built BVH.
    pub fn upload(ctx: &Context, data: &BvhData) -> Result<Self, BvhError> {
        check_fits(&ctx.info().memory_heaps, data.byte_size(), "exact")?;
        let usage = vk::BufferUsageFlags::empty();
        let nodes = Buffer::from_slice(ctx, "bvh nodes", &data.nodes, usage)?;
        let triangles = Buffer::from_slice(ctx, "bvh triangles", &data.triangles, usage)?;
        Self::from_buffers(
            ctx,
            nodes,
            data.nodes.len(),
            triangles,
            data.triangles.len(),
            &data.instances,
            data.stats.clone(),
        )
    }

    /// Wraps node and triangle buffers already on the device (filled by the GPU build),
    /// uploads the instances and creates the `BvhRefs` uniform.
    pub(crate) fn from_buffers(
        ctx: &Context,
        nodes: Buffer,
        node_count: usize,
        triangles: Buffer,
        triangle_count: usize,
        instance_records: &[BvhInstance],
        stats: BvhStats,
    ) -> Result<Self, BvhError> {
        let usage = vk::BufferUsageFlags::empty();
        let instances = Buffer::from_slice(ctx, "bvh instances", instance_records, usage)?;
        // The shader reads every record as 64-bit words.
        for b in [&nodes, &triangles, &instances] {
            if b.address() % 8 != 0 {
                return Err(BvhError::Vk(VkError::Invalid(format!(
                    "BVH buffer at {:#x} is not 8-byte aligned",
                    b.address()
                ))));
            }
        }
        let refs_data = GpuBvhRefs {
            nodes: nodes.address(),
            triangles: triangles.address(),
            instances: instances.address(),
            node_count: node_count as u32,
            triangle_count: triangle_count as u32,
            instance_count: instance_records.len() as u32,
            tlas_root: TLAS_ROOT,
        };
        let mut refs = Buffer::new(
            ctx,
            "bvh refs",
            std::mem::size_of::<GpuBvhRefs>() as u64,
            vk::BufferUsageFlags::UNIFORM_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        refs.write(bytemuck::bytes_of(&refs_data))?;
        Ok(Self {
            nodes,
            triangles,
            instances,
            refs,
            refs_data,
            stats,
            refit_plan: None,
            device_refit: None,
            built_shape: None,
        })
    }

    /// Reads the BVH back into its host form (for tests, SAH costs and the CPU traversal).
    pub fn read_back(&self, ctx: &Context) -> Result<BvhData, BvhError> {
        let mut nodes: Vec<BvhNode> = self.nodes.read(ctx)?;
        nodes.truncate(self.refs_data.node_count as usize);
        let mut triangles: Vec<BvhTriangle> = self.triangles.read(ctx)?;
        triangles.truncate(self.refs_data.triangle_count as usize);
        let mut instances: Vec<BvhInstance> = self.instances.read(ctx)?;
        instances.truncate(self.refs_data.instance_count as usize);
        Ok(BvhData {
            nodes,
            triangles,
            instances,
            stats: self.stats.clone(),
        })
    }

    /// The `BvhRefs` uniform buffer (bind at set 0, binding 2 as a uniform buffer).
    pub fn refs_buffer(&self) -> &Buffer {
        &self.refs
    }

    /// The node array (`BvhNode[]`).
    pub fn nodes_buffer(&self) -> &Buffer {
        &self.nodes
    }

    /// The leaf-ordered triangle array (`BvhTriangle[]`).
    pub fn triangles_buffer(&self) -> &Buffer {
        &self.triangles
    }

    /// What the `BvhRefs` uniform holds.
    pub fn refs_data(&self) -> &GpuBvhRefs {
        &self.refs_data
    }

    /// Binds the `BvhRefs` uniform at set 0, binding 2 (the ray backend's binding).
    pub fn bind(&self, set: &DescriptorSet) {
        set.buffer(
            crate::interface::BINDING_RAY_BACKEND,
            &self.refs,
            Binding::UniformBuffer,
        );
    }

    /// Build statistics.
    pub fn stats(&self) -> &BvhStats {
        &self.stats
    }

    /// Bytes on the device (all arrays plus the uniform).
    pub fn device_bytes(&self) -> u64 {
        self.nodes.size() + self.triangles.size() + self.instances.size() + self.refs.size()
    }
}

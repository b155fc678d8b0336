//! Ray backends: hardware acceleration structures with `VK_KHR_ray_query`, or rqr's own BVH
//! traversed in compute shaders. Both sit behind the same GLSL `trace_closest()/trace_any()`.

pub mod hw;
pub mod hw_update;

use crate::vk::DeviceInfo;

pub mod bvh;

/// What the user asked for with `--backend`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum BackendChoice {
    /// `hw` when the device has acceleration structures and ray queries, else `bvh`.
    #[default]
    Auto,
    /// Hardware acceleration structures + `VK_KHR_ray_query` (fails where unsupported).
    Hw,
    /// rqr's compute-shader BVH (works on every device).
    Bvh,
}

/// The ray backend in use.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// Acceleration structures + ray queries.
    Hw,
    /// Compute-shader BVH.
    Bvh,
}

impl Backend {
    /// `"hw"` or `"bvh"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Hw => "hw",
            Self::Bvh => "bvh",
        }
    }
}

/// The requested backend cannot run on this device.
#[derive(Debug, thiserror::Error)]
#[error("--backend hw needs VK_KHR_acceleration_structure and VK_KHR_ray_query, which '{device}' does not expose; use --backend bvh (or auto)")]
pub struct BackendUnavailable {
    /// Device name.
    pub device: String,
}

impl BackendChoice {
    /// Resolves the choice for a device, with a human-readable reason.
    pub fn resolve(self, device: &DeviceInfo) -> Result<(Backend, String), BackendUnavailable> {
        let hw_ok = device.ray_query && device.acceleration_structure;
        match self {
            Self::Auto if hw_ok => Ok((
                Backend::Hw,
                "auto: device has VK_KHR_acceleration_structure + VK_KHR_ray_query".into(),
            )),
            Self::Auto => Ok((
                Backend::Bvh,
                format!(
                    "auto: device lacks {}; using the compute-shader BVH",
                    if device.acceleration_structure {
                        "VK_KHR_ray_query"
                    } else {
                        "VK_KHR_acceleration_structure"
                    }
                ),
            )),
            Self::Hw if hw_ok => Ok((Backend::Hw, "forced by --backend hw".into())),
            Self::Hw => Err(BackendUnavailable {
                device: device.name.clone(),
            }),
            Self::Bvh => Ok((Backend::Bvh, "forced by --backend bvh".into())),
        }
    }
}

/// The built ray backend of a scene, bound at set 0 binding 2 of every ray-tracing pass.
pub enum RayBackend {
    /// BLAS/TLAS for ray queries.
    Hw(Box<hw::HwAccel>),
    /// BLAS/TLAS of an animated scene, updated per frame (ray queries as [`Self::Hw`]).
    HwAnimated(Box<hw_update::HwAnimatedAccel>),
    /// rqr's two-level BVH for compute traversal.
    Bvh(Box<bvh::GpuBvh>),
}

impl RayBackend {
    /// Builds the backend's structures for an uploaded scene; `bvh_build` chooses where the
    /// compute BVH is built (ignored by the `hw` backend).
    pub fn build(
        ctx: &crate::vk::Context,
        scene: &crate::scene::Scene,
        gpu: &crate::scene::gpu::GpuScene,
        backend: Backend,
        bvh_build: bvh::BvhBuild,
    ) -> crate::Result<Self> {
        match backend {
            Backend::Hw => Ok(Self::Hw(Box::new(hw::HwAccel::build(ctx, scene, gpu)?))),
            Backend::Bvh => Ok(Self::Bvh(Box::new(bvh::GpuBvh::build_with(
                ctx,
                scene,
                &bvh::BvhBuildOptions::default(),
                bvh_build,
            )?))),
        }
    }

    /// Which backend this is.
    pub fn kind(&self) -> Backend {
        match self {
            Self::Hw(_) | Self::HwAnimated(_) => Backend::Hw,
            Self::Bvh(_) => Backend::Bvh,
        }
    }

    /// The descriptor type of binding 2 for this backend.
    pub fn binding(&self) -> crate::vk::Binding {
        match self {
            Self::Hw(_) | Self::HwAnimated(_) => crate::vk::Binding::AccelerationStructure,
            Self::Bvh(_) => crate::vk::Binding::UniformBuffer,
        }
    }

    /// Writes binding 2 of a pass's set.
    pub fn bind(&self, set: &crate::vk::DescriptorSet) {
        match self {
            Self::Hw(a) => {
                set.acceleration_structure(crate::interface::BINDING_RAY_BACKEND, a.tlas());
            }
            Self::HwAnimated(a) => {
                set.acceleration_structure(crate::interface::BINDING_RAY_BACKEND, a.tlas());
            }
            Self::Bvh(b) => b.bind(set),
        }
    }

    /// Build statistics as JSON.
    pub fn stats_json(&self) -> serde_json::Value {
        match self {
            Self::Hw(a) => serde_json::to_value(&a.stats).unwrap_or_default(),
            Self::HwAnimated(a) => serde_json::json!({
                "updates": a.counters, "rebuild_every": a.rebuild_every, "bytes": a.device_bytes(),
            }),
            Self::Bvh(b) => {
                let s = b.stats();
                serde_json::json!({
                    "builder": s.builder, "gpu_phases": s.gpu_phases,
                    "peak_scratch_bytes": s.peak_scratch_bytes,
                    "build_ms": s.build_ms, "blas_ms": s.blas_ms, "tlas_ms": s.tlas_ms, "bytes": s.bytes,
                    "node_count": s.node_count, "tlas_nodes": s.tlas_nodes, "blas_count": s.blas_count,
                    "triangle_count": s.triangle_count, "instance_count": s.instance_count,
                    "max_depth": s.max_depth, "max_stack": s.max_stack, "max_leaf_size": s.max_leaf_size,
                    "skipped_triangles": s.skipped_triangles, "skipped_instances": s.skipped_instances,
                })
            }
        }
    }
}

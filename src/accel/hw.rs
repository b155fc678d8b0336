//! Hardware ray backend: one compacted BLAS per unique geometry and one TLAS over instances,
//! traversed with `VK_KHR_ray_query` (`shaders/common/trace_rayquery.glsl`).

use std::sync::Arc;
use std::time::Instant;

use ash::{khr, vk};
use bytemuck::{Pod, Zeroable};

use crate::scene::gpu::GpuScene;
use crate::scene::{AlphaMode, Scene};
use crate::vk::{
    memory_barrier, AsProperties, Buffer, Context, GpuProfiler, MemoryLocation, Shared, VkError,
    VkResult,
};

/// Build statistics of the hardware acceleration structures.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct HwStats {
    /// Number of BLAS (unique non-empty geometries).
    pub blas_count: usize,
    /// BLAS bytes before compaction.
    pub blas_bytes_uncompacted: u64,
    /// BLAS bytes after compaction.
    pub blas_bytes: u64,
    /// TLAS bytes.
    pub tlas_bytes: u64,
    /// Largest scratch buffer used.
    pub scratch_bytes: u64,
    /// GPU time of the BLAS builds (timestamps), ms.
    pub blas_build_ms: f64,
    /// GPU time of the compaction copies, ms.
    pub compact_ms: f64,
    /// GPU time of the TLAS build, ms.
    pub tlas_build_ms: f64,
    /// Wall time of the whole build on the host, ms.
    pub host_ms: f64,
}

/// `VkAccelerationStructureInstanceKHR` as plain data.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(super) struct TlasInstance {
    pub(super) transform: [f32; 12],
    pub(super) custom_index_and_mask: u32,
    pub(super) sbt_offset_and_flags: u32,
    pub(super) blas_address: u64,
}

/// An acceleration structure and the buffer holding it.
pub(super) struct AccelStructure {
    shared: Arc<Shared>,
    api: khr::acceleration_structure::Device,
    pub(super) handle: vk::AccelerationStructureKHR,
    pub(super) buffer: Buffer,
    pub(super) address: vk::DeviceAddress,
}

impl AccelStructure {
    pub(super) fn new(
        ctx: &Context,
        name: &str,
        ty: vk::AccelerationStructureTypeKHR,
        size: u64,
    ) -> VkResult<Self> {
        let api = ctx
            .accel()
            .cloned()
            .ok_or_else(|| VkError::MissingFeature {
                device: ctx.info().name.clone(),
                feature: "VK_KHR_acceleration_structure".into(),
            })?;
        let buffer = Buffer::new(
            ctx,
            name,
            size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR,
            MemoryLocation::GpuOnly,
        )?;
        let info = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(buffer.raw())
            .size(size)
            .ty(ty);
        // SAFETY: the buffer has AS-storage usage and at least `size` bytes at offset 0.
        let handle = unsafe { api.create_acceleration_structure(&info, None) }
            .map_err(|result| VkError::from_call("vkCreateAccelerationStructureKHR", result))?;
        let address_info =
            vk::AccelerationStructureDeviceAddressInfoKHR::default().acceleration_structure(handle);
        // SAFETY: valid handle.
        let address = unsafe { api.get_acceleration_structure_device_address(&address_info) };
        Ok(Self {
            shared: ctx.shared.clone(),
            api,
            handle,
            buffer,
            address,
        })
    }
}

impl Drop for AccelStructure {
    fn drop(&mut self) {
        let (api, handle) = (self.api.clone(), self.handle);
        // SAFETY: submissions using it have completed (every submission waits; `retire`
        // defers past submissions that timed out). Queued before its buffer's destruction.
        self.shared
            .retire(move |_| unsafe { api.destroy_acceleration_structure(handle, None) });
    }
}

/// BLAS per geometry + TLAS of a scene.
pub struct HwAccel {
    _blas: Vec<AccelStructure>,
    tlas: AccelStructure,
    _instances: Buffer,
    /// Sizes and timings.
    pub stats: HwStats,
}

pub(super) fn align_up(v: u64, a: u64) -> u64 {
    v.div_ceil(a.max(1)) * a.max(1)
}

pub(super) fn scratch_buffer(
    ctx: &Context,
    size: u64,
    align: u64,
) -> VkResult<(Buffer, vk::DeviceAddress)> {
    let buffer = Buffer::new(
        ctx,
        "AS scratch",
        size + align,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::GpuOnly,
    )?;
    let address = align_up(buffer.address(), align);
    Ok((buffer, address))
}

/// One BLAS to build: its triangle geometry and triangle count.
struct BlasInput {
    geometry: vk::AccelerationStructureGeometryKHR<'static>,
    triangle_count: u32,
}

/// The triangle geometries of a scene, one per unique non-empty geometry, in scene order.
struct BlasInputs {
    inputs: Vec<BlasInput>,
    /// Scene geometry index → index into `inputs` (None for empty geometries).
    blas_of_geometry: Vec<Option<usize>>,
}

/// Flags of every BLAS build.
const BLAS_FLAGS: vk::BuildAccelerationStructureFlagsKHR =
    vk::BuildAccelerationStructureFlagsKHR::from_raw(
        vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE.as_raw()
            | vk::BuildAccelerationStructureFlagsKHR::ALLOW_COMPACTION.as_raw(),
    );

/// Runs `record` between a reset and a begin/end of `profiler`'s scope `scope` (no timing when
/// the profiler could not be created).
fn timed(
    profiler: &mut Option<GpuProfiler>,
    cmd: vk::CommandBuffer,
    scope: &str,
    record: impl FnOnce(),
) {
    if let Some(p) = profiler.as_mut() {
        p.reset(cmd);
        p.begin(cmd, scope);
    }
    record();
    if let Some(p) = profiler.as_mut() {
        p.end(cmd);
    }
}

/// GPU milliseconds of the profiler's last scope (0 without a profiler).
fn last_scope_ms(profiler: &Option<GpuProfiler>) -> VkResult<f64> {
    match profiler {
        Some(p) => Ok(p.results()?.first().map_or(0.0, |r| r.1)),
        None => Ok(0.0),
    }
}

impl HwAccel {
    /// Builds (and compacts) a BLAS per non-empty geometry and a TLAS over the instances.
    /// Checks the device's primitive/instance limits and memory before allocating.
    pub fn build(ctx: &Context, scene: &Scene, gpu: &GpuScene) -> VkResult<Self> {
        let start = Instant::now();
        let (api, props) = accel_api(ctx)?;
        let scratch_align = u64::from(props.min_scratch_offset_alignment.max(1));
        if scene.instances.len() as u64 > props.max_instance_count {
            return Err(VkError::Limit {
                what: format!(
                    "scene has {} instances, the device's TLAS holds at most {}",
                    scene.instances.len(),
                    props.max_instance_count
                ),
                needed: scene.instances.len() as u64,
                available: props.max_instance_count,
            });
        }
        let BlasInputs {
            inputs,
            blas_of_geometry,
        } = blas_inputs(scene, gpu, props.max_primitive_count)?;
        let sizes = blas_sizes(api, &inputs);
        let blas_bytes_uncompacted: u64 = sizes
            .iter()
            .map(|s| align_up(s.acceleration_structure_size, 256))
            .sum();
        let max_scratch = sizes
            .iter()
            .map(|s| s.build_scratch_size)
            .max()
            .unwrap_or(0);
        check_memory(
            ctx,
            blas_bytes_uncompacted + max_scratch + scene.instances.len() as u64 * 256,
        )?;

        let mut profiler = GpuProfiler::new(ctx, 4).ok();
        let mut stats = HwStats {
            blas_count: inputs.len(),
            blas_bytes_uncompacted,
            scratch_bytes: max_scratch,
            ..Default::default()
        };
        let (blas, compacted_sizes) = build_blas(
            ctx,
            api,
            &mut profiler,
            &inputs,
            &sizes,
            max_scratch,
            scratch_align,
        )?;
        stats.blas_build_ms = last_scope_ms(&profiler)?;
        let compacted = compact_blas(ctx, api, &mut profiler, blas, &sizes, &compacted_sizes)?;
        if !compacted.is_empty() {
            stats.compact_ms = last_scope_ms(&profiler)?;
        }
        stats.blas_bytes = compacted.iter().map(|b| b.buffer.size()).sum();

        let records = tlas_instances(scene, &blas_of_geometry, &compacted);
        let (tlas, instances, tlas_scratch) =
            build_tlas(ctx, api, &mut profiler, &records, scratch_align)?;
        stats.tlas_build_ms = last_scope_ms(&profiler)?;
        stats.scratch_bytes = stats.scratch_bytes.max(tlas_scratch);
        stats.tlas_bytes = tlas.buffer.size();
        stats.host_ms = start.elapsed().as_secs_f64() * 1e3;
        log::info!(
            "hw AS: {} BLAS, {} -> {} KiB compacted, TLAS {} KiB, build {:.2} ms GPU",
            stats.blas_count,
            stats.blas_bytes_uncompacted >> 10,
            stats.blas_bytes >> 10,
            stats.tlas_bytes >> 10,
            stats.blas_build_ms + stats.compact_ms + stats.tlas_build_ms
        );
        Ok(Self {
            _blas: compacted,
            tlas,
            _instances: instances,
            stats,
        })
    }

    /// The TLAS handle (bind at set 0, binding 2).
    pub fn tlas(&self) -> vk::AccelerationStructureKHR {
        self.tlas.handle
    }
}

/// The acceleration-structure device functions and properties, or the missing feature.
fn accel_api(ctx: &Context) -> VkResult<(&khr::acceleration_structure::Device, AsProperties)> {
    let missing = || VkError::MissingFeature {
        device: ctx.info().name.clone(),
        feature: "VK_KHR_acceleration_structure".into(),
    };
    let api = ctx.accel().ok_or_else(missing)?;
    let props = ctx.info().as_properties.clone().ok_or_else(missing)?;
    Ok((api, props))
}

/// One triangle geometry per unique non-empty scene geometry, in scene order (deterministic);
/// refuses a geometry over the device's `maxPrimitiveCount`.
fn blas_inputs(scene: &Scene, gpu: &GpuScene, max_primitive_count: u64) -> VkResult<BlasInputs> {
    let mut blas_of_geometry = vec![None; gpu.geometry_records.len()];
    let mut inputs = Vec::new();
    for (gi, g) in gpu.geometry_records.iter().enumerate() {
        if g.triangle_count == 0 {
            continue;
        }
        if u64::from(g.triangle_count) > max_primitive_count {
            return Err(VkError::Limit {
                what: format!(
                    "geometry {gi} has {} triangles, the device's BLAS holds at most {} (maxPrimitiveCount)",
                    g.triangle_count, max_primitive_count
                ),
                needed: g.triangle_count.into(),
                available: max_primitive_count,
            });
        }
        let opaque = scene
            .materials
            .get(g.material as usize)
            .is_none_or(|m| m.alpha_mode == AlphaMode::Opaque);
        let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
            .vertex_format(vk::Format::R32G32B32_SFLOAT)
            .vertex_data(vk::DeviceOrHostAddressConstKHR {
                device_address: gpu.positions.address() + u64::from(g.first_vertex) * 12,
            })
            .vertex_stride(12)
            .max_vertex(g.vertex_count.saturating_sub(1))
            .index_type(vk::IndexType::UINT32)
            .index_data(vk::DeviceOrHostAddressConstKHR {
                device_address: gpu.indices.address() + u64::from(g.first_index) * 4,
            });
        let geometry = vk::AccelerationStructureGeometryKHR::default()
            .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
            .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
            .flags(if opaque {
                vk::GeometryFlagsKHR::OPAQUE
            } else {
                vk::GeometryFlagsKHR::empty()
            });
        blas_of_geometry[gi] = Some(inputs.len());
        inputs.push(BlasInput {
            geometry,
            triangle_count: g.triangle_count,
        });
    }
    Ok(BlasInputs {
        inputs,
        blas_of_geometry,
    })
}

/// Build sizes (structure and scratch) of each BLAS, from the driver's size query.
fn blas_sizes(
    api: &khr::acceleration_structure::Device,
    inputs: &[BlasInput],
) -> Vec<vk::AccelerationStructureBuildSizesInfoKHR<'static>> {
    inputs
        .iter()
        .map(|input| {
            let geometries = [input.geometry];
            let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
                .flags(BLAS_FLAGS)
                .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                .geometries(&geometries);
            build_sizes(api, &info, input.triangle_count)
        })
        .collect()
}

/// The driver's structure and scratch sizes for building `info` over `count` primitives.
fn build_sizes(
    api: &khr::acceleration_structure::Device,
    info: &vk::AccelerationStructureBuildGeometryInfoKHR,
    count: u32,
) -> vk::AccelerationStructureBuildSizesInfoKHR<'static> {
    let mut size = vk::AccelerationStructureBuildSizesInfoKHR::default();
    // SAFETY: `info` describes valid device-address geometry (triangles or instances) of
    // `count` primitives.
    unsafe {
        api.get_acceleration_structure_build_sizes(
            vk::AccelerationStructureBuildTypeKHR::DEVICE,
            info,
            &[count],
            &mut size,
        )
    };
    size
}

/// Refuses a build whose estimated bytes exceed 90 % of the largest device heap.
fn check_memory(ctx: &Context, estimate: u64) -> VkResult<()> {
    let heap = ctx.info().largest_device_heap();
    if estimate > heap / 10 * 9 {
        return Err(VkError::Limit {
            what: format!(
                "acceleration structures need about {} MiB, more than 90 % of the largest device heap ({} MiB)",
                estimate >> 20,
                heap >> 20
            ),
            needed: estimate,
            available: heap / 10 * 9,
        });
    }
    Ok(())
}

/// Builds every BLAS (one submission, profiler scope "blas") and queries their compacted
/// sizes; returns the uncompacted structures and those sizes.
fn build_blas(
    ctx: &Context,
    api: &khr::acceleration_structure::Device,
    profiler: &mut Option<GpuProfiler>,
    inputs: &[BlasInput],
    sizes: &[vk::AccelerationStructureBuildSizesInfoKHR],
    max_scratch: u64,
    scratch_align: u64,
) -> VkResult<(Vec<AccelStructure>, Vec<u64>)> {
    let mut blas = Vec::with_capacity(inputs.len());
    for (i, size) in sizes.iter().enumerate() {
        blas.push(AccelStructure::new(
            ctx,
            &format!("BLAS {i}"),
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            size.acceleration_structure_size,
        )?);
    }
    let query_pool = if blas.is_empty() {
        None
    } else {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR)
            .query_count(blas.len() as u32);
        // SAFETY: valid create info.
        Some(
            unsafe { ctx.device().create_query_pool(&info, None) }
                .map_err(|result| VkError::from_call("vkCreateQueryPool", result))?,
        )
    };
    let (_scratch, scratch_address) = scratch_buffer(ctx, max_scratch, scratch_align)?;
    let result = ctx.run("BLAS build", |cmd| {
        timed(profiler, cmd, "blas", || {
            for (input, target) in inputs.iter().zip(&blas) {
                let geometries = [input.geometry];
                let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                    .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
                    .flags(BLAS_FLAGS)
                    .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                    .dst_acceleration_structure(target.handle)
                    .geometries(&geometries)
                    .scratch_data(vk::DeviceOrHostAddressKHR {
                        device_address: scratch_address,
                    });
                let range = [vk::AccelerationStructureBuildRangeInfoKHR::default()
                    .primitive_count(input.triangle_count)];
                // SAFETY: inputs, destination and scratch are alive and sized by the size query.
                unsafe { api.cmd_build_acceleration_structures(cmd, &[info], &[&range[..]]) };
                // The builds share one scratch buffer: serialise them.
                memory_barrier(ctx.device(), cmd);
            }
        });
        if let Some(pool) = query_pool {
            let handles: Vec<_> = blas.iter().map(|b| b.handle).collect();
            // SAFETY: the pool has one query per BLAS; the builds completed (barrier above).
            unsafe {
                ctx.device()
                    .cmd_reset_query_pool(cmd, pool, 0, handles.len() as u32);
                api.cmd_write_acceleration_structures_properties(
                    cmd,
                    &handles,
                    vk::QueryType::ACCELERATION_STRUCTURE_COMPACTED_SIZE_KHR,
                    pool,
                    0,
                );
            }
        }
        Ok(())
    });
    let compacted_sizes = result.and_then(|()| {
        let mut out = vec![0u64; blas.len()];
        if let Some(pool) = query_pool {
            // SAFETY: the queries were written by the completed submission.
            unsafe {
                ctx.device().get_query_pool_results(
                    pool,
                    0,
                    &mut out,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .map_err(|result| VkError::from_call("vkGetQueryPoolResults", result))?;
        }
        Ok(out)
    });
    if let Some(pool) = query_pool {
        // SAFETY: the submission that used the pool has completed or failed to start
        // (`retire` defers past one that timed out).
        ctx.shared
            .retire(move |shared| unsafe { shared.device.destroy_query_pool(pool, None) });
    }
    Ok((blas, compacted_sizes?))
}

/// Compaction: copies each BLAS into a right-sized one (profiler scope "compact") and frees
/// the originals. A compacted size of 0 (not reported) keeps the full size.
fn compact_blas(
    ctx: &Context,
    api: &khr::acceleration_structure::Device,
    profiler: &mut Option<GpuProfiler>,
    blas: Vec<AccelStructure>,
    sizes: &[vk::AccelerationStructureBuildSizesInfoKHR],
    compacted_sizes: &[u64],
) -> VkResult<Vec<AccelStructure>> {
    let mut compacted = Vec::with_capacity(blas.len());
    for (i, size) in compacted_sizes.iter().enumerate() {
        let size = if *size == 0 {
            sizes[i].acceleration_structure_size
        } else {
            *size
        };
        compacted.push(AccelStructure::new(
            ctx,
            &format!("BLAS {i} compacted"),
            vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
            size,
        )?);
    }
    if !blas.is_empty() {
        ctx.run("BLAS compaction", |cmd| {
            timed(profiler, cmd, "compact", || {
                for (src, dst) in blas.iter().zip(&compacted) {
                    let info = vk::CopyAccelerationStructureInfoKHR::default()
                        .src(src.handle)
                        .dst(dst.handle)
                        .mode(vk::CopyAccelerationStructureModeKHR::COMPACT);
                    // SAFETY: src was built with ALLOW_COMPACTION; dst has the compacted size.
                    unsafe { api.cmd_copy_acceleration_structure(cmd, &info) };
                }
            });
            Ok(())
        })?;
    }
    Ok(compacted)
}

/// TLAS instance records: one per scene instance with a non-empty geometry; custom index =
/// scene instance index.
fn tlas_instances(
    scene: &Scene,
    blas_of_geometry: &[Option<usize>],
    compacted: &[AccelStructure],
) -> Vec<TlasInstance> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter_map(|(i, inst)| {
            let b = blas_of_geometry
                .get(inst.geometry as usize)
                .copied()
                .flatten()?;
            let m = inst.transform;
            let mut transform = [0f32; 12];
            for r in 0..3 {
                for c in 0..4 {
                    transform[r * 4 + c] = m.col(c)[r];
                }
            }
            Some(TlasInstance {
                transform,
                custom_index_and_mask: (i as u32 & 0x00FF_FFFF) | (0xFF << 24),
                // Culling off: front faces are decided in shading, the same way in both backends.
                sbt_offset_and_flags: vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE
                    .as_raw()
                    << 24,
                blas_address: compacted[b].address,
            })
        })
        .collect()
}

/// Uploads the instance records and builds the TLAS over them (profiler scope "tlas");
/// returns the TLAS, its instance buffer and the scratch bytes it used.
fn build_tlas(
    ctx: &Context,
    api: &khr::acceleration_structure::Device,
    profiler: &mut Option<GpuProfiler>,
    records: &[TlasInstance],
    scratch_align: u64,
) -> VkResult<(AccelStructure, Buffer, u64)> {
    let instances = Buffer::from_slice(
        ctx,
        "TLAS instances",
        records,
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
    )?;
    let tlas_geometry = vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::INSTANCES)
        .geometry(vk::AccelerationStructureGeometryDataKHR {
            instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                .array_of_pointers(false)
                .data(vk::DeviceOrHostAddressConstKHR {
                    device_address: instances.address(),
                }),
        });
    let geometries = [tlas_geometry];
    let count = records.len() as u32;
    let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
        .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
        .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
        .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
        .geometries(&geometries);
    let size = build_sizes(api, &info, count);
    let tlas = AccelStructure::new(
        ctx,
        "TLAS",
        vk::AccelerationStructureTypeKHR::TOP_LEVEL,
        size.acceleration_structure_size,
    )?;
    let (_scratch, scratch_address) = scratch_buffer(ctx, size.build_scratch_size, scratch_align)?;
    ctx.run("TLAS build", |cmd| {
        timed(profiler, cmd, "tlas", || {
            let info = info.dst_acceleration_structure(tlas.handle).scratch_data(
                vk::DeviceOrHostAddressKHR {
                    device_address: scratch_address,
                },
            );
            let range =
                [vk::AccelerationStructureBuildRangeInfoKHR::default().primitive_count(count)];
            // SAFETY: instances reference live compacted BLAS; sizes come from the size query.
            unsafe { api.cmd_build_acceleration_structures(cmd, &[info], &[&range[..]]) };
        });
        Ok(())
    })?;
    Ok((tlas, instances, size.build_scratch_size))
}

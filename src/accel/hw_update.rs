//! Hardware acceleration structures of an animated scene, updated per frame instead of built
//! again: one BLAS per geometry, those of deformed (skinned or morphed) geometry built with
//! `ALLOW_UPDATE` and refitted in place (mode `UPDATE`) after the skinning pass moved their
//! vertices, and the TLAS rebuilt each frame from the new instance transforms. Static BLASes
//! are built once and never again ([`HwUpdateCounters`] counts every build).
//!
//! A refit keeps the BLAS's tree, whose quality decays as the mesh moves away from the shape
//! it was built for. The driver gives no measure of that decay, so a deformed BLAS is built
//! again after [`DEFAULT_HW_REBUILD_EVERY`] refits (see [`HwAnimatedAccel::rebuild_every`]).
//!
//! Unlike [`super::hw::HwAccel`], BLASes here are not compacted (an updatable BLAS keeps its
//! update room; static ones are left uncompacted to keep one build path).

use ash::vk;

use super::hw::{align_up, scratch_buffer, AccelStructure, TlasInstance};
use crate::scene::gpu::GpuScene;
use crate::scene::layout::GpuGeometry;
use crate::scene::{AlphaMode, Scene};
use crate::vk::{memory_barrier, Buffer, Context, GpuProfiler, MemoryLocation, VkError, VkResult};

/// Refits of a deformed BLAS before it is built again (a tree refitted over more than about
/// a second of motion at 30 fps is rebuilt).
pub const DEFAULT_HW_REBUILD_EVERY: u32 = 30;

/// Name of the BLAS update pass in GPU timings.
pub const BLAS_PASS_NAME: &str = "blas refit";
/// Name of the TLAS build pass in GPU timings.
pub const TLAS_PASS_NAME: &str = "tlas build";

/// How often each kind of build ran (tests check that static geometry is built once).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct HwUpdateCounters {
    /// Builds of static BLASes (one per static geometry, at creation).
    pub static_blas_builds: u64,
    /// Full builds of deformed BLASes (at creation and every `rebuild_every` refits).
    pub deformed_blas_builds: u64,
    /// Refits (mode `UPDATE`) of deformed BLASes.
    pub blas_refits: u64,
    /// TLAS builds.
    pub tlas_builds: u64,
}

struct Blas {
    accel: AccelStructure,
    record: GpuGeometry,
    opaque: bool,
    deformed: bool,
    refits_since_build: u32,
}

/// BLAS per geometry (updatable where deformed) and a TLAS rebuilt per frame.
pub struct HwAnimatedAccel {
    blas: Vec<Blas>,
    blas_of_geometry: Vec<Option<usize>>,
    tlas: AccelStructure,
    instances: Buffer,
    instance_count: u32,
    scratch: Buffer,
    scratch_address: vk::DeviceAddress,
    positions: vk::DeviceAddress,
    indices: vk::DeviceAddress,
    /// Refits of a deformed BLAS before it is built again (0: rebuild every frame).
    pub rebuild_every: u32,
    /// Builds and refits so far.
    pub counters: HwUpdateCounters,
}

fn api(ctx: &Context) -> VkResult<&ash::khr::acceleration_structure::Device> {
    ctx.accel().ok_or_else(|| VkError::MissingFeature {
        device: ctx.info().name.clone(),
        feature: "VK_KHR_acceleration_structure".into(),
    })
}

fn blas_flags(deformed: bool) -> vk::BuildAccelerationStructureFlagsKHR {
    let fast = vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE;
    if deformed {
        fast | vk::BuildAccelerationStructureFlagsKHR::ALLOW_UPDATE
    } else {
        fast
    }
}

/// The TLAS instance records of `scene` (custom index = scene instance index, as in
/// [`super::hw::HwAccel`]).
fn tlas_records(scene: &Scene, blas_address: impl Fn(usize) -> Option<u64>) -> Vec<TlasInstance> {
    scene
        .instances
        .iter()
        .enumerate()
        .filter_map(|(i, inst)| {
            let address = blas_address(inst.geometry as usize)?;
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
                sbt_offset_and_flags: vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE
                    .as_raw()
                    << 24,
                blas_address: address,
            })
        })
        .collect()
}

impl HwAnimatedAccel {
    /// Builds a BLAS per non-empty geometry of the uploaded `scene` (`deformed[g]`: geometry
    /// `g`'s vertices change per frame, so its BLAS is updatable) and the TLAS.
    pub fn build(
        ctx: &Context,
        scene: &Scene,
        gpu: &GpuScene,
        deformed: &[bool],
    ) -> VkResult<Self> {
        let api = api(ctx)?;
        let props = ctx
            .info()
            .as_properties
            .clone()
            .ok_or_else(|| VkError::MissingFeature {
                device: ctx.info().name.clone(),
                feature: "VK_KHR_acceleration_structure".into(),
            })?;
        let align = u64::from(props.min_scratch_offset_alignment.max(1));
        let mut blas_of_geometry = vec![None; gpu.geometry_records.len()];
        let mut specs = Vec::new();
        for (gi, g) in gpu.geometry_records.iter().enumerate() {
            if g.triangle_count == 0 {
                continue;
            }
            if u64::from(g.triangle_count) > props.max_primitive_count {
                return Err(VkError::Limit {
                    what: format!(
                        "geometry {gi} has {} triangles, the device's BLAS holds at most {} (maxPrimitiveCount)",
                        g.triangle_count, props.max_primitive_count
                    ),
                    needed: g.triangle_count.into(),
                    available: props.max_primitive_count,
                });
            }
            let opaque = scene
                .materials
                .get(g.material as usize)
                .is_none_or(|m| m.alpha_mode == AlphaMode::Opaque);
            blas_of_geometry[gi] = Some(specs.len());
            specs.push((*g, opaque, deformed.get(gi).copied().unwrap_or(false)));
        }
        let positions = gpu.positions.address();
        let indices = gpu.indices.address();
        let mut scratch_size = 0u64;
        let mut blas = Vec::with_capacity(specs.len());
        for (i, (record, opaque, deformed)) in specs.into_iter().enumerate() {
            let geometry = [triangles(positions, indices, &record, opaque)];
            let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
                .flags(blas_flags(deformed))
                .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
                .geometries(&geometry);
            let mut size = vk::AccelerationStructureBuildSizesInfoKHR::default();
            // SAFETY: `info` describes valid device-address geometry; counts match.
            unsafe {
                api.get_acceleration_structure_build_sizes(
                    vk::AccelerationStructureBuildTypeKHR::DEVICE,
                    &info,
                    &[record.triangle_count],
                    &mut size,
                )
            };
            scratch_size = scratch_size
                .max(size.build_scratch_size)
                .max(size.update_scratch_size);
            let name = format!("BLAS {i}{}", if deformed { " (updatable)" } else { "" });
            blas.push(Blas {
                accel: AccelStructure::new(
                    ctx,
                    &name,
                    vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                    size.acceleration_structure_size,
                )?,
                record,
                opaque,
                deformed,
                refits_since_build: 0,
            });
        }
        let records = tlas_records(scene, |g| {
            blas_of_geometry
                .get(g)
                .copied()
                .flatten()
                .map(|b| blas[b].accel.address)
        });
        let instance_count = records.len() as u32;
        let instances = Buffer::new(
            ctx,
            "animated TLAS instances",
            (records.len().max(1) * std::mem::size_of::<TlasInstance>()) as u64,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR,
            MemoryLocation::CpuToGpu,
        )?;
        let instance_geometry = [tlas_geometry(instances.address())];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
            .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&instance_geometry);
        let mut size = vk::AccelerationStructureBuildSizesInfoKHR::default();
        // SAFETY: valid instance geometry description.
        unsafe {
            api.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &[instance_count],
                &mut size,
            )
        };
        scratch_size = scratch_size.max(size.build_scratch_size);
        let tlas = AccelStructure::new(
            ctx,
            "animated TLAS",
            vk::AccelerationStructureTypeKHR::TOP_LEVEL,
            size.acceleration_structure_size,
        )?;
        let (scratch, scratch_address) = scratch_buffer(ctx, align_up(scratch_size, 8), align)?;
        let mut accel = Self {
            blas,
            blas_of_geometry,
            tlas,
            instances,
            instance_count,
            scratch,
            scratch_address,
            positions,
            indices,
            rebuild_every: DEFAULT_HW_REBUILD_EVERY,
            counters: HwUpdateCounters::default(),
        };
        accel.write_instances(scene)?;
        ctx.run("animated AS build", |cmd| {
            accel.record_blas(ctx, cmd, true, None)?;
            accel.record_tlas(ctx, cmd, None)
        })?;
        log::info!(
            "hw AS (animated): {} BLAS, {} updatable, TLAS over {} instances",
            accel.blas.len(),
            accel.blas.iter().filter(|b| b.deformed).count(),
            accel.instance_count
        );
        Ok(accel)
    }

    /// The TLAS handle (bind at set 0, binding 2); the same handle every frame.
    pub fn tlas(&self) -> vk::AccelerationStructureKHR {
        self.tlas.handle
    }

    /// Writes this frame's instance transforms of `scene` for the next TLAS build (call
    /// between submissions: the buffer is host-visible and read by the build).
    pub fn write_instances(&mut self, scene: &Scene) -> VkResult<()> {
        let blas = &self.blas;
        let map = &self.blas_of_geometry;
        let records = tlas_records(scene, |g| {
            map.get(g).copied().flatten().map(|b| blas[b].accel.address)
        });
        if records.len() as u32 != self.instance_count {
            return Err(VkError::Invalid(format!(
                "animated frame has {} ray-traced instances, the TLAS was built for {}",
                records.len(),
                self.instance_count
            )));
        }
        if !records.is_empty() {
            self.instances.write(bytemuck::cast_slice(&records))?;
        }
        Ok(())
    }

    /// Records this frame's update after the deformed vertices were written (the caller puts
    /// a barrier between): every deformed BLAS refitted (or built again after
    /// [`Self::rebuild_every`] refits), then the TLAS built from the instances of the last
    /// [`Self::write_instances`]. Timed as [`BLAS_PASS_NAME`] and [`TLAS_PASS_NAME`].
    pub fn record_update(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        mut profiler: Option<&mut GpuProfiler>,
    ) -> VkResult<()> {
        self.record_blas(ctx, cmd, false, profiler.as_deref_mut())?;
        memory_barrier(ctx.device(), cmd);
        self.record_tlas(ctx, cmd, profiler)
    }

    /// Records BLAS builds: with `initial` every BLAS is built, else only deformed ones,
    /// refitted or rebuilt.
    fn record_blas(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        initial: bool,
        profiler: Option<&mut GpuProfiler>,
    ) -> VkResult<()> {
        let api = api(ctx)?.clone();
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, BLAS_PASS_NAME);
        }
        let (positions, indices, scratch) = (self.positions, self.indices, self.scratch_address);
        for b in &mut self.blas {
            if !initial && !b.deformed {
                continue;
            }
            let refit = !initial && b.refits_since_build < self.rebuild_every;
            let geometry = [triangles(positions, indices, &b.record, b.opaque)];
            let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
                .ty(vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL)
                .flags(blas_flags(b.deformed))
                .dst_acceleration_structure(b.accel.handle)
                .geometries(&geometry)
                .scratch_data(vk::DeviceOrHostAddressKHR {
                    device_address: scratch,
                });
            if refit {
                info = info
                    .mode(vk::BuildAccelerationStructureModeKHR::UPDATE)
                    .src_acceleration_structure(b.accel.handle);
                b.refits_since_build += 1;
                self.counters.blas_refits += 1;
            } else {
                info = info.mode(vk::BuildAccelerationStructureModeKHR::BUILD);
                b.refits_since_build = 0;
                if b.deformed {
                    self.counters.deformed_blas_builds += 1;
                } else {
                    self.counters.static_blas_builds += 1;
                }
            }
            let range = [vk::AccelerationStructureBuildRangeInfoKHR::default()
                .primitive_count(b.record.triangle_count)];
            // SAFETY: vertex/index data, destination and scratch are alive and sized by the
            // size query (scratch covers the largest build and update); an update's source
            // was built with ALLOW_UPDATE from the same geometry description and count.
            unsafe { api.cmd_build_acceleration_structures(cmd, &[info], &[&range[..]]) };
            // The builds share one scratch buffer: serialise them.
            memory_barrier(ctx.device(), cmd);
        }
        if let Some(p) = profiler {
            p.end(cmd);
        }
        Ok(())
    }

    fn record_tlas(
        &mut self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        profiler: Option<&mut GpuProfiler>,
    ) -> VkResult<()> {
        let api = api(ctx)?;
        let mut profiler = profiler;
        if let Some(p) = profiler.as_deref_mut() {
            p.begin(cmd, TLAS_PASS_NAME);
        }
        let geometry = [tlas_geometry(self.instances.address())];
        let info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(vk::AccelerationStructureTypeKHR::TOP_LEVEL)
            .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .dst_acceleration_structure(self.tlas.handle)
            .geometries(&geometry)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: self.scratch_address,
            });
        let range = [vk::AccelerationStructureBuildRangeInfoKHR::default()
            .primitive_count(self.instance_count)];
        // SAFETY: the instance records point at live BLASes built earlier in this command
        // buffer (barrier recorded by the caller); TLAS and scratch are sized for this count.
        unsafe { api.cmd_build_acceleration_structures(cmd, &[info], &[&range[..]]) };
        memory_barrier(ctx.device(), cmd);
        self.counters.tlas_builds += 1;
        if let Some(p) = profiler {
            p.end(cmd);
        }
        Ok(())
    }

    /// Bytes of the BLASes, the TLAS and the scratch buffer.
    pub fn device_bytes(&self) -> u64 {
        self.blas.iter().map(|b| b.accel.buffer.size()).sum::<u64>()
            + self.tlas.buffer.size()
            + self.scratch.size()
            + self.instances.size()
    }
}

/// The triangle geometry of one scene geometry in the scene's vertex and index buffers.
fn triangles(
    positions: vk::DeviceAddress,
    indices: vk::DeviceAddress,
    g: &GpuGeometry,
    opaque: bool,
) -> vk::AccelerationStructureGeometryKHR<'static> {
    let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
        .vertex_format(vk::Format::R32G32B32_SFLOAT)
        .vertex_data(vk::DeviceOrHostAddressConstKHR {
            device_address: positions + u64::from(g.first_vertex) * 12,
        })
        .vertex_stride(12)
        .max_vertex(g.vertex_count.saturating_sub(1))
        .index_type(vk::IndexType::UINT32)
        .index_data(vk::DeviceOrHostAddressConstKHR {
            device_address: indices + u64::from(g.first_index) * 4,
        });
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
        .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
        .flags(if opaque {
            vk::GeometryFlagsKHR::OPAQUE
        } else {
            vk::GeometryFlagsKHR::empty()
        })
}

fn tlas_geometry(instances: vk::DeviceAddress) -> vk::AccelerationStructureGeometryKHR<'static> {
    vk::AccelerationStructureGeometryKHR::default()
        .geometry_type(vk::GeometryTypeKHR::INSTANCES)
        .geometry(vk::AccelerationStructureGeometryDataKHR {
            instances: vk::AccelerationStructureGeometryInstancesDataKHR::default()
                .array_of_pointers(false)
                .data(vk::DeviceOrHostAddressConstKHR {
                    device_address: instances,
                }),
        })
}

//! Uploads a [`Scene`] into the GPU records of [`super::layout`].

use glam::{Mat3, Mat4};

use super::layout::*;
use super::types::{AlphaMode, LightKind, Material, Scene, TextureRef};
use crate::vk::{vk, Binding, Buffer, Context, DescriptorSet, VkError, VkResult};

/// Largest float written where the scene says "infinite" (GLSL has no portable infinity literal).
const BIG: f32 = 3.0e38;

/// A scene's buffers on the GPU plus the `SceneRefs` uniform that points at them.
pub struct GpuScene {
    /// `vec3` positions of every geometry (also the BLAS vertex input).
    pub positions: Buffer,
    /// `GpuVertex` attributes.
    pub attributes: Buffer,
    /// Triangle indices, relative to each geometry's first vertex (also the BLAS index input).
    pub indices: Buffer,
    /// `GpuGeometry` records.
    pub geometries: Buffer,
    /// `GpuInstance` records.
    pub instances: Buffer,
    /// `GpuMaterial` records.
    pub materials: Buffer,
    /// `GpuLight` records.
    pub lights: Buffer,
    /// The `SceneRefs` uniform buffer.
    pub refs: Buffer,
    /// CPU copy of the geometry records (BLAS builds read them).
    pub geometry_records: Vec<GpuGeometry>,
    /// CPU copy of `SceneRefs`.
    pub refs_data: GpuSceneRefs,
    /// Bytes uploaded.
    pub bytes: u64,
    /// Whether an instanced triangle's material emits (its emissive factor is not black):
    /// emission then lights the scene beside the light sources, and only rays that meet it
    /// find it.
    pub emissive_geometry: bool,
    /// The previous frame's positions and instances of an animation (motion vectors), once
    /// [`Self::keep_previous_frame`] made them.
    previous: Option<PreviousFrame>,
}

/// Copies of the positions and instances as they were in the previous frame.
struct PreviousFrame {
    positions: Buffer,
    instances: Buffer,
}

fn texture_slot(material: &Material, r: Option<TextureRef>) -> GpuTextureSlot {
    match r {
        None => GpuTextureSlot::default(),
        Some(r) => {
            let m: Mat3 = r.transform;
            GpuTextureSlot {
                texture: r.texture as i32,
                tex_coord: material.stored_uv_set(r.tex_coord),
                row0: [m.x_axis.x, m.y_axis.x, m.z_axis.x],
                row1: [m.x_axis.y, m.y_axis.y, m.z_axis.y],
            }
        }
    }
}

/// Converts a material to its GPU record.
pub fn gpu_material(m: &Material) -> GpuMaterial {
    let layers = m.layers.as_deref().cloned().unwrap_or_default();
    let [t0, t1, t2, t3, t4, t5, t6] = layers.textures().map(|t| texture_slot(m, *t));
    let ext_textures = [
        t0,
        t1,
        t2,
        t3,
        t4,
        t5,
        t6,
        texture_slot(m, m.thickness_texture),
    ];
    GpuMaterial {
        base_color: m.base_color.to_array(),
        emissive: m.emissive.to_array(),
        metallic: m.metallic,
        roughness: m.roughness,
        normal_scale: m.normal_scale,
        occlusion_strength: m.occlusion_strength,
        alpha_cutoff: m.alpha_cutoff,
        alpha_mode: match m.alpha_mode {
            AlphaMode::Opaque => ALPHA_OPAQUE,
            AlphaMode::Mask => ALPHA_MASK,
            AlphaMode::Blend => ALPHA_BLEND,
        },
        double_sided: u32::from(m.double_sided),
        transmission: m.transmission,
        ior: m.ior,
        thickness: m.thickness,
        attenuation_color: m.attenuation_color.to_array(),
        attenuation_distance: if m.attenuation_distance.is_finite() {
            m.attenuation_distance
        } else {
            BIG
        },
        base_color_texture: texture_slot(m, m.base_color_texture),
        metallic_roughness_texture: texture_slot(m, m.metallic_roughness_texture),
        normal_texture: texture_slot(m, m.normal_texture),
        occlusion_texture: texture_slot(m, m.occlusion_texture),
        emissive_texture: texture_slot(m, m.emissive_texture),
        transmission_texture: texture_slot(m, m.transmission_texture),
        specular: layers.specular,
        specular_color: layers.specular_color.to_array(),
        clearcoat: layers.clearcoat,
        clearcoat_roughness: layers.clearcoat_roughness,
        clearcoat_normal_scale: layers.clearcoat_normal_scale,
        sheen_color: layers.sheen_color.to_array(),
        sheen_roughness: layers.sheen_roughness,
        flags: if m.layers.is_some() {
            MATERIAL_LAYERED
        } else {
            0
        } | if ext_textures.iter().any(|t| t.texture >= 0) {
            MATERIAL_EXT_TEXTURES
        } else {
            0
        },
        ext_textures,
    }
}

/// Converts an instance transform to its GPU record.
pub fn gpu_instance(transform: Mat4, geometry: u32) -> GpuInstance {
    let normal = Mat4::from_mat3(Mat3::from_mat4(transform).inverse().transpose());
    GpuInstance {
        object_to_world: transform.to_cols_array(),
        world_to_object: transform.inverse().to_cols_array(),
        normal_to_world: normal.to_cols_array(),
        geometry,
        flags: if transform.determinant() < 0.0 {
            INSTANCE_MIRRORED
        } else {
            0
        },
        pad: [0; 2],
    }
}

/// Converts the scene's lights to their GPU records.
pub fn gpu_lights(scene: &Scene) -> Vec<GpuLight> {
    scene
        .lights
        .iter()
        .map(|l| {
            let (kind, inner_cos, outer_cos) = match l.kind {
                LightKind::Directional => (LIGHT_DIRECTIONAL, 1.0, 1.0),
                LightKind::Point => (LIGHT_POINT, -1.0, -1.0),
                LightKind::Spot {
                    inner_cone,
                    outer_cone,
                } => (LIGHT_SPOT, inner_cone.cos(), outer_cone.cos()),
            };
            GpuLight {
                position: l.position.to_array(),
                kind,
                direction: l.direction.normalize_or_zero().to_array(),
                range: if l.range.is_finite() && l.range > 0.0 {
                    l.range
                } else {
                    BIG
                },
                radiance: (l.color * l.intensity).to_array(),
                inner_cos,
                outer_cos,
                size: l.size.max(0.0),
                pad: [0.0; 2],
            }
        })
        .collect()
}

/// Whether some instance of `scene` draws a geometry whose material emits.
pub fn has_emissive_geometry(scene: &Scene) -> bool {
    scene.instances.iter().any(|i| {
        scene
            .geometries
            .get(i.geometry as usize)
            .and_then(|g| scene.materials.get(g.material as usize))
            .is_some_and(|m| m.emissive.max_element() > 0.0)
    })
}

impl GpuScene {
    /// Uploads every record of `scene`. `bound_textures` is how many of its textures the
    /// passes bind (shaders ignore texture indices at or beyond it).
    pub fn upload(ctx: &Context, scene: &Scene, bound_textures: u32) -> VkResult<Self> {
        let mut positions: Vec<[f32; 3]> = Vec::new();
        let mut attributes: Vec<GpuVertex> = Vec::new();
        let mut indices: Vec<u32> = Vec::new();
        let mut geometries = Vec::with_capacity(scene.geometries.len());
        for (gi, g) in scene.geometries.iter().enumerate() {
            let first_vertex = u32::try_from(positions.len()).map_err(|_| VkError::Limit {
                what: format!("geometry {gi}: more than 2^32 vertices in the scene"),
                needed: positions.len() as u64,
                available: u32::MAX.into(),
            })?;
            let first_index = u32::try_from(indices.len()).map_err(|_| VkError::Limit {
                what: format!("geometry {gi}: more than 2^32 indices in the scene"),
                needed: indices.len() as u64,
                available: u32::MAX.into(),
            })?;
            let mut flags = 0;
            if !g.tangents.is_empty() {
                flags |= GEOMETRY_HAS_TANGENTS;
            }
            if !g.colors.is_empty() {
                flags |= GEOMETRY_HAS_COLORS;
            }
            for (v, p) in g.positions.iter().enumerate() {
                positions.push(p.to_array());
                attributes.push(GpuVertex {
                    normal: g.normals.get(v).map_or([0.0, 0.0, 1.0], |n| n.to_array()),
                    tangent: g.tangents.get(v).map_or([0.0; 4], |t| t.to_array()),
                    uv0: g.uv0.get(v).map_or([0.0; 2], |t| t.to_array()),
                    uv1: g.uv1.get(v).map_or([0.0; 2], |t| t.to_array()),
                    color: g.colors.get(v).map_or([1.0; 4], |c| c.to_array()),
                });
            }
            indices.extend_from_slice(&g.indices);
            geometries.push(GpuGeometry {
                first_index,
                triangle_count: (g.indices.len() / 3) as u32,
                first_vertex,
                vertex_count: g.positions.len() as u32,
                material: g.material,
                flags,
            });
        }
        let instances: Vec<GpuInstance> = scene
            .instances
            .iter()
            .map(|i| gpu_instance(i.transform, i.geometry))
            .collect();
        let mut materials: Vec<GpuMaterial> = scene.materials.iter().map(gpu_material).collect();
        if materials.is_empty() {
            materials.push(gpu_material(&Material::default()));
        }
        let lights = gpu_lights(scene);

        let as_input = if ctx.features().acceleration_structure {
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
        } else {
            vk::BufferUsageFlags::empty()
        };
        let none = vk::BufferUsageFlags::empty();
        let bytes = std::mem::size_of_val(positions.as_slice())
            + std::mem::size_of_val(attributes.as_slice())
            + std::mem::size_of_val(indices.as_slice())
            + std::mem::size_of_val(instances.as_slice());
        ctx.check_memory(
            &format!("{}: the scene's meshes", scene.source),
            bytes as u64,
        )?;
        let positions_buf = Buffer::from_slice(ctx, "scene positions", &positions, as_input)?;
        let attributes_buf = Buffer::from_slice(ctx, "scene attributes", &attributes, none)?;
        let indices_buf = Buffer::from_slice(ctx, "scene indices", &indices, as_input)?;
        let geometries_buf = Buffer::from_slice(ctx, "scene geometries", &geometries, none)?;
        let instances_buf = Buffer::from_slice(ctx, "scene instances", &instances, none)?;
        let materials_buf = Buffer::from_slice(ctx, "scene materials", &materials, none)?;
        let lights_buf = Buffer::from_slice(ctx, "scene lights", &lights, none)?;
        let bounds = if scene.bounds.is_empty() {
            super::types::Aabb {
                min: glam::Vec3::ZERO,
                max: glam::Vec3::ZERO,
            }
        } else {
            scene.bounds
        };
        let refs_data = GpuSceneRefs {
            positions: positions_buf.address(),
            attributes: attributes_buf.address(),
            indices: indices_buf.address(),
            geometries: geometries_buf.address(),
            instances: instances_buf.address(),
            materials: materials_buf.address(),
            lights: lights_buf.address(),
            instance_count: instances.len() as u32,
            geometry_count: geometries.len() as u32,
            light_count: lights.len() as u32,
            texture_count: bound_textures.min(scene.textures.len() as u32),
            bounds_min: bounds.min.to_array(),
            scene_scale: bounds.diagonal().max(1e-3),
            bounds_max: bounds.max.to_array(),
            environment: -1,
            // No previous frame: nothing moved.
            prev_positions: positions_buf.address(),
            prev_instances: instances_buf.address(),
        };
        let refs = Buffer::from_slice(
            ctx,
            "scene refs",
            &[refs_data],
            vk::BufferUsageFlags::UNIFORM_BUFFER,
        )?;
        let bytes = [
            &positions_buf,
            &attributes_buf,
            &indices_buf,
            &geometries_buf,
            &instances_buf,
            &materials_buf,
            &lights_buf,
            &refs,
        ]
        .iter()
        .map(|b| b.size())
        .sum();
        Ok(Self {
            positions: positions_buf,
            attributes: attributes_buf,
            indices: indices_buf,
            geometries: geometries_buf,
            instances: instances_buf,
            materials: materials_buf,
            lights: lights_buf,
            refs,
            geometry_records: geometries,
            previous: None,
            refs_data,
            bytes,
            emissive_geometry: has_emissive_geometry(scene),
        })
    }

    /// Uploads what moves between frames of an animation (instance transforms, lights, the
    /// scene bounds and scale) from `scene`, a posed version of the uploaded scene (same
    /// geometries, instances and lights; vertices are written by the skinning pass). Waits.
    pub fn update_frame(&mut self, ctx: &Context, scene: &Scene) -> VkResult<()> {
        let instances: Vec<GpuInstance> = scene
            .instances
            .iter()
            .map(|i| gpu_instance(i.transform, i.geometry))
            .collect();
        let lights = gpu_lights(scene);
        if instances.len() != self.refs_data.instance_count as usize
            || lights.len() != self.refs_data.light_count as usize
        {
            return Err(VkError::Invalid(format!(
                "{}: animated frame has {} instances and {} lights, the upload had {} and {}",
                scene.source,
                instances.len(),
                lights.len(),
                self.refs_data.instance_count,
                self.refs_data.light_count
            )));
        }
        if !instances.is_empty() {
            self.instances
                .upload(ctx, bytemuck::cast_slice(&instances))?;
        }
        if !lights.is_empty() {
            self.lights.upload(ctx, bytemuck::cast_slice(&lights))?;
        }
        if !scene.bounds.is_empty() {
            self.refs_data.bounds_min = scene.bounds.min.to_array();
            self.refs_data.bounds_max = scene.bounds.max.to_array();
            self.refs_data.scene_scale = scene.bounds.diagonal().max(1e-3);
        }
        self.refs.upload(ctx, bytemuck::bytes_of(&self.refs_data))
    }

    /// Makes `SceneRefs`' `prev_positions` and `prev_instances` point at copies of the
    /// positions and instances (equal to them until [`Self::record_previous_frame`] runs),
    /// so that the G-buffer's motion vectors follow moving objects. Waits.
    pub fn keep_previous_frame(&mut self, ctx: &Context) -> VkResult<()> {
        let copy = |name: &str, of: &Buffer| {
            Buffer::new(
                ctx,
                name,
                of.size(),
                vk::BufferUsageFlags::empty(),
                crate::vk::MemoryLocation::GpuOnly,
            )
        };
        let previous = PreviousFrame {
            positions: copy("scene previous positions", &self.positions)?,
            instances: copy("scene previous instances", &self.instances)?,
        };
        ctx.run("previous frame", |cmd| {
            for (src, dst) in [
                (&self.positions, &previous.positions),
                (&self.instances, &previous.instances),
            ] {
                let region = vk::BufferCopy::default().size(src.size());
                // SAFETY: both buffers are alive and `dst` was made with `src`'s size.
                unsafe {
                    ctx.device()
                        .cmd_copy_buffer(cmd, src.raw(), dst.raw(), &[region])
                };
            }
            Ok(())
        })?;
        self.refs_data.prev_positions = previous.positions.address();
        self.refs_data.prev_instances = previous.instances.address();
        self.previous = Some(previous);
        self.refs.upload(ctx, bytemuck::bytes_of(&self.refs_data))
    }

    /// Records the copy of this frame's instances and of the vertex ranges `moving`
    /// (`(first vertex, count)`: the geometry about to be skinned) into the previous-frame
    /// buffers of [`Self::keep_previous_frame`] (nothing without them). Static vertices are
    /// never copied again: their previous positions are their positions.
    pub fn record_previous_frame(
        &self,
        ctx: &Context,
        cmd: vk::CommandBuffer,
        moving: &[(u32, u32)],
    ) {
        let Some(previous) = &self.previous else {
            return;
        };
        let vertex = std::mem::size_of::<[f32; 3]>() as u64;
        let regions: Vec<vk::BufferCopy> = moving
            .iter()
            .filter(|r| r.1 > 0)
            .map(|&(first, count)| {
                vk::BufferCopy::default()
                    .src_offset(first as u64 * vertex)
                    .dst_offset(first as u64 * vertex)
                    .size(count as u64 * vertex)
            })
            .collect();
        let instances = vk::BufferCopy::default().size(self.instances.size());
        // SAFETY: the buffers are alive, the previous ones have the sizes of the current ones,
        // and the vertex ranges lie inside the geometry records' ranges.
        unsafe {
            let device = ctx.device();
            if !regions.is_empty() {
                device.cmd_copy_buffer(
                    cmd,
                    self.positions.raw(),
                    previous.positions.raw(),
                    &regions,
                );
            }
            device.cmd_copy_buffer(
                cmd,
                self.instances.raw(),
                previous.instances.raw(),
                &[instances],
            );
        }
    }

    /// Points `SceneRefs::environment` at the environment's first bindless texture (-1: none).
    pub fn set_environment(&mut self, ctx: &Context, first_texture: i32) -> VkResult<()> {
        self.refs_data.environment = first_texture;
        self.refs.upload(ctx, bytemuck::bytes_of(&self.refs_data))
    }

    /// Writes set-0 binding 0 (`SceneRefs`) of a pass's descriptor set.
    pub fn bind(&self, set: &DescriptorSet) {
        set.buffer(
            crate::interface::BINDING_SCENE,
            &self.refs,
            Binding::UniformBuffer,
        );
    }
}

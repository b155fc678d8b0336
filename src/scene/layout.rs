//! GPU-side records of a scene, shared with `shaders/common/scene.glsl` (scalar block layout).
//! Every struct here is `#[repr(C)]` with explicit padding so its byte layout equals the GLSL
//! struct of the same name; `tests/gpu/layout.rs` checks each field on the GPU.

use bytemuck::{Pod, Zeroable};

/// Per-vertex shading attributes, parallel to the position array.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuVertex {
    /// Object-space unit normal.
    pub normal: [f32; 3],
    /// Tangent xyz + handedness w (zero when the geometry has none).
    pub tangent: [f32; 4],
    /// TEXCOORD_0.
    pub uv0: [f32; 2],
    /// TEXCOORD_1.
    pub uv1: [f32; 2],
    /// COLOR_0 (linear RGBA; white when absent).
    pub color: [f32; 4],
}

/// One geometry: where its vertices and indices live.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuGeometry {
    /// First element in the index array.
    pub first_index: u32,
    /// Number of triangles.
    pub triangle_count: u32,
    /// Added to every index of this geometry to address the vertex arrays.
    pub first_vertex: u32,
    /// Number of vertices.
    pub vertex_count: u32,
    /// Material index.
    pub material: u32,
    /// Bit 0: has tangents. Bit 1: has COLOR_0.
    pub flags: u32,
}

/// [`GpuGeometry::flags`] bit: tangents present.
pub const GEOMETRY_HAS_TANGENTS: u32 = 1;
/// [`GpuGeometry::flags`] bit: vertex colours present.
pub const GEOMETRY_HAS_COLORS: u32 = 2;

/// One instance (column-major matrices).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuInstance {
    /// Object to world.
    pub object_to_world: [f32; 16],
    /// World to object.
    pub world_to_object: [f32; 16],
    /// Inverse transpose of the object-to-world 3x3, for normals (as a mat4).
    pub normal_to_world: [f32; 16],
    /// Geometry index.
    pub geometry: u32,
    /// Bit 0: the transform mirrors (negative determinant).
    pub flags: u32,
    /// Padding.
    pub pad: [u32; 2],
}

/// [`GpuInstance::flags`] bit: mirrored transform.
pub const INSTANCE_MIRRORED: u32 = 1;

/// A texture slot of a material; `texture < 0` means none.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuTextureSlot {
    /// Index into the bindless texture array, or -1.
    pub texture: i32,
    /// TEXCOORD set.
    pub tex_coord: u32,
    /// First row of the KHR_texture_transform 3x3 (applied to (u, v, 1)).
    pub row0: [f32; 3],
    /// Second row.
    pub row1: [f32; 3],
}

impl Default for GpuTextureSlot {
    fn default() -> Self {
        Self {
            texture: -1,
            tex_coord: 0,
            row0: [1.0, 0.0, 0.0],
            row1: [0.0, 1.0, 0.0],
        }
    }
}

/// Alpha modes as stored in [`GpuMaterial::alpha_mode`].
pub const ALPHA_OPAQUE: u32 = 0;
/// Alpha test.
pub const ALPHA_MASK: u32 = 1;
/// Alpha blend.
pub const ALPHA_BLEND: u32 = 2;

/// A material with every factor resolved.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable, PartialEq)]
pub struct GpuMaterial {
    /// Linear base colour factor.
    pub base_color: [f32; 4],
    /// Emissive factor times emissive strength.
    pub emissive: [f32; 3],
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Normal map scale.
    pub normal_scale: f32,
    /// Occlusion strength.
    pub occlusion_strength: f32,
    /// Alpha cutoff.
    pub alpha_cutoff: f32,
    /// ALPHA_OPAQUE / ALPHA_MASK / ALPHA_BLEND.
    pub alpha_mode: u32,
    /// 1 when double-sided.
    pub double_sided: u32,
    /// Transmission factor.
    pub transmission: f32,
    /// Index of refraction.
    pub ior: f32,
    /// Volume thickness factor (0: thin-walled).
    pub thickness: f32,
    /// Volume attenuation colour.
    pub attenuation_color: [f32; 3],
    /// Volume attenuation distance (a huge value for none).
    pub attenuation_distance: f32,
    /// Base colour (sRGB) texture.
    pub base_color_texture: GpuTextureSlot,
    /// Metallic (B) / roughness (G) texture.
    pub metallic_roughness_texture: GpuTextureSlot,
    /// Normal map.
    pub normal_texture: GpuTextureSlot,
    /// Occlusion (R).
    pub occlusion_texture: GpuTextureSlot,
    /// Emissive (sRGB).
    pub emissive_texture: GpuTextureSlot,
    /// Transmission (R).
    pub transmission_texture: GpuTextureSlot,
    /// KHR_materials_specular factor (1 without the extension).
    pub specular: f32,
    /// KHR_materials_specular colour factor (linear; 1 without the extension).
    pub specular_color: [f32; 3],
    /// KHR_materials_clearcoat factor.
    pub clearcoat: f32,
    /// Clearcoat roughness factor.
    pub clearcoat_roughness: f32,
    /// Scale of the clearcoat normal texture.
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen colour factor (linear).
    pub sheen_color: [f32; 3],
    /// Sheen roughness factor.
    pub sheen_roughness: f32,
    /// `MATERIAL_*` bits.
    pub flags: u32,
    /// Extension textures in `EXT_TEX_*` order: specular (A), specular colour (sRGB),
    /// clearcoat (R), clearcoat roughness (G), clearcoat normal, sheen colour (sRGB), sheen
    /// roughness (A), volume thickness (G).
    pub ext_textures: [GpuTextureSlot; 8],
}

/// [`GpuMaterial::flags`] bit: the material has KHR_materials_specular, _clearcoat or _sheen
/// (shaded by the layered path; others keep the plain metallic-roughness code).
pub const MATERIAL_LAYERED: u32 = 1;
/// [`GpuMaterial::flags`] bit: at least one of `ext_textures` is bound.
pub const MATERIAL_EXT_TEXTURES: u32 = 2;

/// Light kinds as stored in [`GpuLight::kind`].
pub const LIGHT_DIRECTIONAL: u32 = 0;
/// Point light.
pub const LIGHT_POINT: u32 = 1;
/// Spot light.
pub const LIGHT_SPOT: u32 = 2;

/// A punctual light in world space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuLight {
    /// World position.
    pub position: [f32; 3],
    /// LIGHT_* kind.
    pub kind: u32,
    /// Direction the light points to (unit).
    pub direction: [f32; 3],
    /// Range (a huge value for none).
    pub range: f32,
    /// Colour times intensity.
    pub radiance: [f32; 3],
    /// cos(inner cone).
    pub inner_cos: f32,
    /// cos(outer cone).
    pub outer_cos: f32,
    /// Radius of a point or spot light's sphere, or a directional light's angular radius
    /// (radians); 0 for a punctual light (the distributed model; Whitted ignores it).
    pub size: f32,
    /// Padding.
    pub pad: [f32; 2],
}

/// Addresses and counts of a scene's GPU buffers (uniform at set 0, binding 0).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct GpuSceneRefs {
    /// `vec3[]` object-space positions of every geometry.
    pub positions: u64,
    /// `GpuVertex[]`, parallel to positions.
    pub attributes: u64,
    /// `uint[]` triangle indices, relative to each geometry's `first_vertex`.
    pub indices: u64,
    /// `GpuGeometry[]`.
    pub geometries: u64,
    /// `GpuInstance[]`.
    pub instances: u64,
    /// `GpuMaterial[]`.
    pub materials: u64,
    /// `GpuLight[]`.
    pub lights: u64,
    /// Number of instances.
    pub instance_count: u32,
    /// Number of geometries.
    pub geometry_count: u32,
    /// Number of lights.
    pub light_count: u32,
    /// Number of textures bound at binding 1.
    pub texture_count: u32,
    /// World bounds, min corner.
    pub bounds_min: [f32; 3],
    /// Diagonal of the world bounds (for relative epsilons).
    pub scene_scale: f32,
    /// World bounds, max corner.
    pub bounds_max: [f32; 3],
    /// Index of the environment's first texture in the bindless array
    /// (`crate::interface::environment::ENV_TEX_*` follow it), or -1 without an environment.
    pub environment: i32,
    /// `vec3[]` positions of the previous frame of an animation (motion vectors); equal to
    /// `positions` when nothing moved.
    pub prev_positions: u64,
    /// `GpuInstance[]` of the previous frame of an animation; equal to `instances` when
    /// nothing moved.
    pub prev_instances: u64,
}

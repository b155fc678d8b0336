//! The plain, GPU-agnostic scene that every loader produces and every pass consumes.

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box (min = +inf, max = -inf); growing it by a point gives that point.
    pub const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// Grows the box to contain `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Whether nothing was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    /// Centre point.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f32 {
        (self.max - self.min).length()
    }
}

/// One triangle list: a glTF mesh primitive converted to `TRIANGLES`, with every attribute
/// expanded to f32. Shared by every instance that uses it.
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// Object-space positions.
    pub positions: Vec<Vec3>,
    /// Unit normals, one per position (computed when the file has none).
    pub normals: Vec<Vec3>,
    /// Tangents (xyz, w = handedness); empty unless the material uses a normal map.
    pub tangents: Vec<Vec4>,
    /// TEXCOORD_0, or TEXCOORD_n for n = the material's `uv_sets[0]` (empty if absent).
    pub uv0: Vec<Vec2>,
    /// TEXCOORD_1, or TEXCOORD_n for n = the material's `uv_sets[1]` (empty if absent).
    pub uv1: Vec<Vec2>,
    /// COLOR_0 as linear RGBA (empty if absent).
    pub colors: Vec<Vec4>,
    /// Triangle list indices into the arrays above (`len % 3 == 0`).
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// glTF mesh index this came from.
    pub mesh: usize,
    /// Primitive index within that mesh.
    pub primitive: usize,
    /// Skin joints of each vertex (JOINTS_0 then JOINTS_1), indices into the skin of the
    /// node that places the geometry; empty for unskinned geometry.
    pub joints: Vec<[u32; 8]>,
    /// Skin weights matching `joints` (sum 1); empty for unskinned geometry.
    pub weights: Vec<[f32; 8]>,
    /// Morph targets, each with one displacement per vertex per attribute it has.
    pub morph_targets: Vec<MorphTarget>,
}

/// One morph target of a geometry: displacements added with the target's weight. An empty
/// array: the target does not move that attribute.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MorphTarget {
    /// POSITION displacements.
    pub positions: Vec<Vec3>,
    /// NORMAL displacements.
    pub normals: Vec<Vec3>,
    /// TANGENT (xyz) displacements.
    pub tangents: Vec<Vec3>,
}

impl Geometry {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Whether skinning or morphing can move its vertices.
    pub fn is_deformable(&self) -> bool {
        !self.joints.is_empty() || !self.morph_targets.is_empty()
    }
}

/// A placement of a geometry in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instance {
    /// Index into [`Scene::geometries`].
    pub geometry: u32,
    /// Object-to-world transform.
    pub transform: Mat4,
    /// glTF node that placed it.
    pub node: usize,
}

impl Instance {
    /// True when the transform mirrors (negative determinant): triangle winding flips.
    pub fn flips_winding(&self) -> bool {
        self.transform.determinant() < 0.0
    }
}

/// glTF alpha mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlphaMode {
    /// Alpha ignored.
    #[default]
    Opaque,
    /// Alpha tested against the cutoff.
    Mask,
    /// Alpha blended (rendered as partial transparency).
    Blend,
}

/// A texture reference inside a material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub texture: u32,
    /// glTF TEXCOORD set (any n; [`Material::uv_sets`] says where the geometry keeps it).
    pub tex_coord: u32,
    /// KHR_texture_transform as a 3x3 matrix applied to (u, v, 1).
    pub transform: Mat3,
}

/// glTF metallic-roughness material with the supported extensions folded in.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name (may be empty).
    pub name: String,
    /// Linear base colour factor.
    pub base_color: Vec4,
    /// Base colour texture (sRGB).
    pub base_color_texture: Option<TextureRef>,
    /// Metallic factor.
    pub metallic: f32,
    /// Roughness factor.
    pub roughness: f32,
    /// Metallic (B) / roughness (G) texture.
    pub metallic_roughness_texture: Option<TextureRef>,
    /// Tangent-space normal map.
    pub normal_texture: Option<TextureRef>,
    /// Normal map scale.
    pub normal_scale: f32,
    /// Occlusion (R) texture.
    pub occlusion_texture: Option<TextureRef>,
    /// Occlusion strength.
    pub occlusion_strength: f32,
    /// Emissive factor times KHR_materials_emissive_strength.
    pub emissive: Vec3,
    /// Emissive texture (sRGB).
    pub emissive_texture: Option<TextureRef>,
    /// Alpha mode.
    pub alpha_mode: AlphaMode,
    /// Alpha cutoff for [`AlphaMode::Mask`].
    pub alpha_cutoff: f32,
    /// Back faces are shaded (else culled in raster and treated as opaque-from-behind in RT).
    pub double_sided: bool,
    /// KHR_materials_transmission factor.
    pub transmission: f32,
    /// Transmission (R) texture.
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_ior (default 1.5).
    pub ior: f32,
    /// KHR_materials_volume thickness factor (0: thin-walled).
    pub thickness: f32,
    /// KHR_materials_volume attenuation colour.
    pub attenuation_color: Vec3,
    /// KHR_materials_volume attenuation distance (infinite: no absorption).
    pub attenuation_distance: f32,
    /// KHR_materials_volume thickness (G) texture, multiplied with `thickness`.
    pub thickness_texture: Option<TextureRef>,
    /// KHR_materials_specular / clearcoat / sheen parameters (`None`: the material uses
    /// none of them and shades exactly as plain metallic-roughness).
    pub layers: Option<Box<MaterialLayers>>,
    /// The glTF TEXCOORD sets this material's textures read, as geometries using it store
    /// them: `Geometry::uv0` holds TEXCOORD_`uv_sets[0]`, `uv1` TEXCOORD_`uv_sets[1]`.
    /// `[0, 1]` unless a texture reads TEXCOORD_2 or above (see [`Material::assign_uv_sets`]).
    pub uv_sets: [u32; 2],
}

impl Material {
    /// Every texture reference of the material.
    pub fn texture_refs(&self) -> impl Iterator<Item = &TextureRef> {
        [
            &self.base_color_texture,
            &self.metallic_roughness_texture,
            &self.normal_texture,
            &self.occlusion_texture,
            &self.emissive_texture,
            &self.transmission_texture,
            &self.thickness_texture,
        ]
        .into_iter()
        .chain(self.layers.iter().flat_map(|l| l.textures()))
        .flatten()
    }

    /// Chooses [`Material::uv_sets`] from the sets the textures read: `[0, 1]` when they
    /// read only those, else the two lowest sets in use (a single set fills both). A
    /// material whose textures read more than two sets keeps the two lowest; the returned
    /// sets are the ones dropped (their textures read `uv_sets[0]`).
    pub fn assign_uv_sets(&mut self) -> Vec<u32> {
        let mut used: Vec<u32> = self.texture_refs().map(|t| t.tex_coord).collect();
        used.sort_unstable();
        used.dedup();
        if used.iter().all(|&s| s <= 1) {
            self.uv_sets = [0, 1];
            return Vec::new();
        }
        self.uv_sets = [used[0], *used.get(1).unwrap_or(&used[0])];
        used.split_off(2.min(used.len()))
    }

    /// Which of the geometry's two stored UV sets (0: `uv0`, 1: `uv1`) holds TEXCOORD_`set`.
    pub fn stored_uv_set(&self, set: u32) -> u32 {
        u32::from(set == self.uv_sets[1] && set != self.uv_sets[0])
    }
}

impl Default for Material {
    /// The glTF default material.
    fn default() -> Self {
        Self {
            name: String::new(),
            base_color: Vec4::ONE,
            base_color_texture: None,
            metallic: 1.0,
            roughness: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive: Vec3::ZERO,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            double_sided: false,
            transmission: 0.0,
            transmission_texture: None,
            ior: 1.5,
            thickness: 0.0,
            attenuation_color: Vec3::ONE,
            attenuation_distance: f32::INFINITY,
            thickness_texture: None,
            layers: None,
            uv_sets: [0, 1],
        }
    }
}

/// The layered-material extensions of a [`Material`]: KHR_materials_specular, _clearcoat and
/// _sheen, with the glTF defaults for the ones a material does not use.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialLayers {
    /// KHR_materials_specular `specularFactor` (strength of the dielectric specular lobe).
    pub specular: f32,
    /// `specularTexture` (A).
    pub specular_texture: Option<TextureRef>,
    /// `specularColorFactor` (linear; scales the dielectric F0).
    pub specular_color: Vec3,
    /// `specularColorTexture` (RGB, sRGB).
    pub specular_color_texture: Option<TextureRef>,
    /// KHR_materials_clearcoat `clearcoatFactor`.
    pub clearcoat: f32,
    /// `clearcoatTexture` (R).
    pub clearcoat_texture: Option<TextureRef>,
    /// `clearcoatRoughnessFactor`.
    pub clearcoat_roughness: f32,
    /// `clearcoatRoughnessTexture` (G).
    pub clearcoat_roughness_texture: Option<TextureRef>,
    /// `clearcoatNormalTexture` (tangent space, same tangents as the normal map).
    pub clearcoat_normal_texture: Option<TextureRef>,
    /// Scale of `clearcoatNormalTexture`.
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen `sheenColorFactor` (linear).
    pub sheen_color: Vec3,
    /// `sheenColorTexture` (RGB, sRGB).
    pub sheen_color_texture: Option<TextureRef>,
    /// `sheenRoughnessFactor`.
    pub sheen_roughness: f32,
    /// `sheenRoughnessTexture` (A).
    pub sheen_roughness_texture: Option<TextureRef>,
}

impl Default for MaterialLayers {
    /// Each extension's defaults: full-strength white specular, no clearcoat, no sheen.
    fn default() -> Self {
        Self {
            specular: 1.0,
            specular_texture: None,
            specular_color: Vec3::ONE,
            specular_color_texture: None,
            clearcoat: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness: 0.0,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            sheen_color: Vec3::ZERO,
            sheen_color_texture: None,
            sheen_roughness: 0.0,
            sheen_roughness_texture: None,
        }
    }
}

impl MaterialLayers {
    /// The texture slots in GPU order (`EXT_TEX_*` of `shaders/common/scene.glsl`), without
    /// the thickness texture, which belongs to [`Material`].
    pub fn textures(&self) -> [&Option<TextureRef>; 7] {
        [
            &self.specular_texture,
            &self.specular_color_texture,
            &self.clearcoat_texture,
            &self.clearcoat_roughness_texture,
            &self.clearcoat_normal_texture,
            &self.sheen_color_texture,
            &self.sheen_roughness_texture,
        ]
    }
}

/// Texture wrap mode.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Wrap {
    /// REPEAT.
    #[default]
    Repeat,
    /// MIRRORED_REPEAT.
    MirroredRepeat,
    /// CLAMP_TO_EDGE.
    ClampToEdge,
}

/// Sampler state of a texture.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Sampler {
    /// U wrap.
    pub wrap_s: Wrap,
    /// V wrap.
    pub wrap_t: Wrap,
    /// Magnification is linear (else nearest).
    pub mag_linear: bool,
    /// Minification is linear (else nearest).
    pub min_linear: bool,
    /// Mip filtering is linear (else nearest); mips are always generated.
    pub mip_linear: bool,
    /// Whether minification uses the mip chain: false for glTF `minFilter` NEAREST / LINEAR,
    /// which sample mip 0 only (upload clamps the sampler's max LOD to 0).
    pub mipmaps: bool,
}

impl Default for Sampler {
    fn default() -> Self {
        Self {
            wrap_s: Wrap::Repeat,
            wrap_t: Wrap::Repeat,
            mag_linear: true,
            min_linear: true,
            mip_linear: true,
            mipmaps: true,
        }
    }
}

/// A texture: an image and how to sample it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texture {
    /// Index into [`Scene::images`].
    pub image: u32,
    /// Sampler state.
    pub sampler: Sampler,
}

/// A decoded image, RGBA8, uploaded once with a mip chain.
#[derive(Clone, Debug, PartialEq)]
pub struct ImageData {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// RGBA8 texels, row 0 = top.
    pub rgba8: Vec<u8>,
    /// Mip levels 1.. as the file stores them (KTX2), each RGBA8 at `max(1, size >> level)`;
    /// empty: the upload generates the full chain.
    pub mips: Vec<Vec<u8>>,
    /// Sampled as sRGB (base colour / emissive) rather than linear data.
    pub srgb: bool,
    /// The KTX2 file (KHR_texture_basisu) `rgba8` and `mips` were transcoded from, kept so
    /// that the upload can transcode it again to a block format the device samples (BC7,
    /// ASTC 4x4) instead of uploading RGBA8; `None` for other images, when loaded with
    /// [`TextureFormat::Rgba8`](super::textures::TextureFormat::Rgba8), and after
    /// [`Scene::drop_ktx2_files`].
    pub ktx2: Option<std::sync::Arc<[u8]>>,
}

/// KHR_lights_punctual light type.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Infinitely far; `intensity` in lux.
    Directional,
    /// Point; `intensity` in candela.
    Point,
    /// Spot; `intensity` in candela, cone angles in radians.
    Spot {
        /// Inner cone angle.
        inner_cone: f32,
        /// Outer cone angle.
        outer_cone: f32,
    },
}

/// A punctual light in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    /// Type and cone.
    pub kind: LightKind,
    /// Linear RGB colour.
    pub color: Vec3,
    /// Intensity (lux for directional, candela otherwise).
    pub intensity: f32,
    /// Range (infinite: no cut-off).
    pub range: f32,
    /// World position (unused for directional).
    pub position: Vec3,
    /// World direction the light points to (unit; unused for point).
    pub direction: Vec3,
    /// Size for the distributed model: the radius of a point or spot light's sphere (scene
    /// units), or a directional light's angular radius (radians); 0 is a punctual light, and
    /// the Whitted model always treats the light as punctual.
    pub size: f32,
}

/// Camera projection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with vertical field of view (radians).
    Perspective {
        /// Vertical fov.
        yfov: f32,
        /// Aspect ratio from the file, if any (the render's aspect wins).
        aspect: Option<f32>,
        /// Near plane.
        znear: f32,
        /// Far plane (None: infinite).
        zfar: Option<f32>,
    },
    /// Orthographic with half extents.
    Orthographic {
        /// Half width.
        xmag: f32,
        /// Half height.
        ymag: f32,
        /// Near plane.
        znear: f32,
        /// Far plane.
        zfar: f32,
    },
}

/// A camera: pose and projection. Looks down its local -Z with +Y up (glTF convention).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Camera-to-world transform (no scale).
    pub camera_to_world: Mat4,
    /// Projection.
    pub projection: Projection,
}

/// A loaded scene.
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Where it came from (file path or `built-in`).
    pub source: String,
    /// Unique triangle lists.
    pub geometries: Vec<Geometry>,
    /// Placements of geometries.
    pub instances: Vec<Instance>,
    /// Materials used by the chosen scene, in order of first use (not glTF material
    /// indices); always at least one (the glTF default material, named `default`, stands in
    /// for primitives without a material and for scenes without geometry).
    pub materials: Vec<Material>,
    /// Textures used by the materials, in order of first use. A glTF texture used both as
    /// colour (sRGB) and as data (linear) appears twice, once per colour space.
    pub textures: Vec<Texture>,
    /// Decoded images, one per (glTF image, colour space) pair in use.
    pub images: Vec<ImageData>,
    /// Punctual lights (a documented default rig when the file has none).
    pub lights: Vec<Light>,
    /// Whether `lights` is the default rig rather than the file's.
    pub default_lights: bool,
    /// Cameras of the chosen scene, in node order.
    pub cameras: Vec<Camera>,
    /// Number of glTF meshes.
    pub mesh_count: usize,
    /// Number of glTF mesh primitives (including skipped point/line ones).
    pub primitive_count: usize,
    /// `extensionsUsed`.
    pub extensions_used: Vec<String>,
    /// Used extensions rqr ignores.
    pub extensions_unsupported: Vec<String>,
    /// Every extension the file names (used or required), with how rqr treats it.
    pub extensions: Vec<super::extensions::ExtensionStatus>,
    /// KHR_materials_variants names, in the file's order.
    pub variants: Vec<String>,
    /// Index into `variants` of the variant the materials come from; `None`: the defaults.
    pub variant: Option<usize>,
    /// World-space bounds of every instance.
    pub bounds: Aabb,
    /// World transform of every glTF node reached from the chosen scene (indexed by node;
    /// `None` for nodes outside it). Instances and cameras already carry theirs; this is for
    /// tools and tests.
    pub node_world: Vec<Option<Mat4>>,
    /// Node hierarchy, skins and animations, for posing the scene at a time
    /// ([`Scene::posed`]); empty for scenes without glTF nodes.
    pub rig: super::pose::Rig,
}

impl Scene {
    /// Lights the scene by an environment alone: the default rig (added when the file has
    /// no lights) goes, as the Khronos Sample Viewer turns its default lights off under IBL;
    /// the file's own lights stay.
    pub fn drop_default_lights(&mut self) {
        if self.default_lights {
            self.lights.clear();
            self.default_lights = false;
        }
    }

    /// Triangles over every instance.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.geometries[i.geometry as usize].triangle_count())
            .sum()
    }

    /// Triangles counting each geometry once.
    pub fn unique_triangle_count(&self) -> usize {
        self.geometries.iter().map(Geometry::triangle_count).sum()
    }

    /// Images that keep their KTX2 file ([`ImageData::ktx2`]): what `--texture-format`
    /// decides for.
    pub fn ktx2_image_count(&self) -> usize {
        self.images.iter().filter(|i| i.ktx2.is_some()).count()
    }

    /// Forgets every image's KTX2 file, so that the upload takes the RGBA8 levels decoded at
    /// load instead of transcoding to a block format: `--texture-format rgba8` applied after
    /// loading (how `auto` applies a device's measured choice of RGBA8).
    pub fn drop_ktx2_files(&mut self) {
        for image in &mut self.images {
            image.ktx2 = None;
        }
    }
}

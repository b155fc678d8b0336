//! glTF 2.0 (`.gltf` with external / embedded / data-URI resources, and `.glb`) → [`Scene`].
//!
//! The JSON is deserialised with `gltf-json`, but nothing of the `gltf` crate's own
//! validation or accessor reading is used: both can panic on malformed input. Every index,
//! offset and length is checked here instead, and every error names the file and the element.

use std::collections::HashMap;
use std::path::Path;

use ::gltf::json as gj;
use gj::validation::Checked;
use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};

use super::accessor::{self, Buffers, Elements};
use super::animation;
use super::camera::{camera_pose, default_lights};
use super::compression;
use super::draco;
use super::error::SceneError;
use super::extensions::{self, ExtensionStatus, ExtensionSupport};
use super::geometry::{compute_flat_normals, compute_tangents, triangulate, Topology};
use super::image::{self as img, MAX_IMAGE_SIZE};
use super::morph;
use super::pose::{self, Rig};
use super::skin;
use super::textures::TextureFormat;
use super::types::*;
use super::variants;

mod glb;
mod images;
mod limits;
mod materials;
mod mesh;
mod nodes;

use glb::split_glb;

/// Most instances a scene may expand to (node hierarchy × EXT_mesh_gpu_instancing); guards
/// against files whose node graph shares subtrees exponentially.
pub const MAX_INSTANCES: usize = 1 << 22;

/// Most vertices of all unique geometry in a scene (after un-welding for flat normals and
/// tangent seams): bounds the memory a small file can make the loader allocate, e.g. many
/// primitives sharing one large accessor.
pub const MAX_SCENE_VERTICES: usize = 1 << 26;

/// Most triangles of all unique geometry in a scene (instances do not count).
pub const MAX_SCENE_TRIANGLES: usize = 1 << 26;

/// Most texels of all decoded images in a scene (4 GiB as RGBA8): sixteen 8192² or four
/// 16384² images.
pub const MAX_SCENE_TEXELS: u64 = 1 << 30;

/// Most bytes of buffers (their declared `byteLength`s) and of encoded images read for one
/// file: many buffers or images naming the same large file would otherwise each get a copy.
pub const MAX_READ_BYTES: u64 = 1 << 32;

/// Largest world-space coordinate a vertex may reach: squared distances of larger ones
/// overflow `f32` in the shaders' ray math.
pub const MAX_COORDINATE: f32 = 1e18;

/// How to load a file.
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// Scene to load (`--scene N`); `None`: the file's default scene, else scene 0.
    pub scene: Option<usize>,
    /// Largest accepted image width or height, in pixels.
    pub max_image_size: u32,
    /// KHR_materials_variants variant to render (`--variant NAME`); `None`: the default
    /// materials. A name the file does not define fails the load.
    pub variant: Option<String>,
    /// How KTX2 textures reach the GPU (`--texture-format`): `Auto` and `Block` keep each
    /// KTX2 file in [`ImageData::ktx2`] so the upload can transcode it to a block format the
    /// device samples (for `Auto`, unless [`Scene::drop_ktx2_files`] applies the device's
    /// measured choice of RGBA8 first); `Rgba8` drops them at load.
    pub texture_format: TextureFormat,
}

impl Default for LoadOptions {
    fn default() -> Self {
        Self {
            scene: None,
            max_image_size: MAX_IMAGE_SIZE,
            variant: None,
            texture_format: TextureFormat::Auto,
        }
    }
}

/// Loads a `.gltf` or `.glb` file; relative URIs resolve against its directory.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        file: name.clone(),
        source,
    })?;
    load_slice(&bytes, path.parent(), &name, opts)
}

/// Like [`load`], also returning the milliseconds spent decoding images (part of the load):
/// the texture-decode stage of `rqr batch`'s per-job times.
pub fn load_timed(path: &Path, opts: &LoadOptions) -> Result<(Scene, f64), SceneError> {
    let name = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        file: name.clone(),
        source,
    })?;
    let mut decode_ms = 0.0;
    let scene = load_slice_timed(&bytes, path.parent(), &name, opts, &mut decode_ms)?;
    Ok((scene, decode_ms))
}

/// Loads glTF or GLB bytes. `base_dir` resolves relative URIs (`None`: only embedded and
/// data-URI resources are allowed); `name` is the file name used in errors and
/// [`Scene::source`].
pub fn load_slice(
    bytes: &[u8],
    base_dir: Option<&Path>,
    name: &str,
    opts: &LoadOptions,
) -> Result<Scene, SceneError> {
    load_slice_timed(bytes, base_dir, name, opts, &mut 0.0)
}

fn load_slice_timed(
    bytes: &[u8],
    base_dir: Option<&Path>,
    name: &str,
    opts: &LoadOptions,
    decode_ms: &mut f64,
) -> Result<Scene, SceneError> {
    let format = |message: String| SceneError::Format {
        file: name.to_string(),
        message,
    };
    let (json, bin) = if bytes.starts_with(b"glTF") {
        split_glb(bytes).map_err(format)?
    } else {
        (bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes), None)
    };
    let root: gj::Root =
        gj::deserialize::from_slice(json).map_err(|e| format(format!("invalid glTF JSON: {e}")))?;
    if !root.asset.version.starts_with("2.") {
        return Err(format(format!(
            "glTF version {} is not supported (only 2.x)",
            root.asset.version
        )));
    }
    let mut loader = Loader {
        file: name.to_string(),
        base_dir,
        opts,
        buffers: Buffers { data: Vec::new() },
        scene: Scene {
            source: name.to_string(),
            ..Default::default()
        },
        geometry_of: HashMap::new(),
        geometry_bounds: Vec::new(),
        material_of: HashMap::new(),
        texture_of: HashMap::new(),
        image_of: HashMap::new(),
        image_sources: Vec::new(),
        vertices: 0,
        triangles: 0,
        root,
    };
    loader.check_extensions()?;
    loader.load_buffers(bin)?;
    loader.check_node_graph()?;
    loader.load_rig()?;
    loader.load_scene()?;
    let decode_start = std::time::Instant::now();
    loader.decode_images()?;
    *decode_ms = decode_start.elapsed().as_secs_f64() * 1e3;
    loader.finish()
}

pub(super) struct Loader<'a> {
    file: String,
    base_dir: Option<&'a Path>,
    opts: &'a LoadOptions,
    root: gj::Root,
    buffers: Buffers,
    scene: Scene,
    /// (mesh, primitive) → geometry; `None` for skipped (non-triangle) primitives.
    geometry_of: HashMap<(usize, usize), Option<u32>>,
    /// Object-space bounds, parallel to `scene.geometries`.
    geometry_bounds: Vec<Aabb>,
    /// glTF material (None: the default material) → scene material.
    material_of: HashMap<Option<usize>, u32>,
    /// (glTF texture, sRGB) → scene texture.
    texture_of: HashMap<(usize, bool), u32>,
    /// (glTF image, sRGB) → scene image.
    image_of: HashMap<(usize, bool), u32>,
    /// glTF image of each scene image, decoded at the end.
    image_sources: Vec<usize>,
    /// Vertices and triangles of `scene.geometries` so far (see [`MAX_SCENE_VERTICES`]).
    vertices: usize,
    triangles: usize,
}

fn checked<T: Copy>(c: &Checked<T>) -> Option<T> {
    match c {
        Checked::Valid(v) => Some(*v),
        Checked::Invalid => None,
    }
}

/// Fails with [`SceneError::UnsupportedExtensions`] when a required extension is not
/// implemented; else warns once about the ignored ones and returns every extension's status.
fn check_extensions_of(
    file: &str,
    used: &[String],
    required: &[String],
) -> Result<Vec<ExtensionStatus>, SceneError> {
    let all = extensions::classify(used, required);
    let names = |s: ExtensionSupport| -> Vec<String> {
        all.iter()
            .filter(|e| e.status == s)
            .map(|e| e.name.clone())
            .collect()
    };
    let refused = names(ExtensionSupport::UnsupportedRequired);
    if !refused.is_empty() {
        return Err(SceneError::UnsupportedExtensions {
            file: file.to_string(),
            extensions: refused,
            all,
        });
    }
    let ignored = names(ExtensionSupport::Ignored);
    if !ignored.is_empty() {
        log::warn!(
            "{file}: ignoring unsupported glTF extension(s): {}",
            ignored.join(", ")
        );
    }
    Ok(all)
}

impl Loader<'_> {
    pub(super) fn err(&self, element: impl Into<String>, message: impl Into<String>) -> SceneError {
        SceneError::element(&self.file, element, message)
    }

    fn check_extensions(&mut self) -> Result<(), SceneError> {
        let all = check_extensions_of(
            &self.file,
            &self.root.extensions_used,
            &self.root.extensions_required,
        )?;
        self.scene.extensions_used = self.root.extensions_used.clone();
        self.scene.extensions_unsupported = all
            .iter()
            .filter(|e| e.status != ExtensionSupport::Supported)
            .map(|e| e.name.clone())
            .collect();
        self.scene.extensions = all;
        self.scene.variants = variants::names(&self.root).map_err(|e| self.err("root", e))?;
        if let Some(wanted) = &self.opts.variant {
            let v =
                variants::find(&self.scene.variants, wanted).map_err(|e| self.err("root", e))?;
            self.scene.variant = Some(v);
        }
        Ok(())
    }

    /// Reads a URI's bytes: a data URI or a file relative to the base directory.
    fn read_uri(&self, element: &str, uri: &str) -> Result<Vec<u8>, SceneError> {
        if let Some(parsed) = img::parse_data_uri(uri) {
            return parsed
                .map(|(_, data)| data)
                .map_err(|e| self.err(element, e));
        }
        if let Some((scheme, _)) = uri.split_once(':') {
            // A one-letter "scheme" is a Windows drive letter, not a URI scheme.
            if scheme.len() > 1
                && scheme
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
            {
                return Err(self.err(
                    element,
                    format!("URI scheme '{scheme}:' is not supported (only relative paths and data: URIs)"),
                ));
            }
        }
        let Some(base) = self.base_dir else {
            return Err(self.err(
                element,
                format!("external file '{uri}' cannot be resolved: no base directory (embedded data only)"),
            ));
        };
        let path = base.join(img::percent_decode(uri));
        std::fs::read(&path)
            .map_err(|e| self.err(element, format!("cannot read '{}': {e}", path.display())))
    }

    fn load_buffers(&mut self, bin: Option<&[u8]>) -> Result<(), SceneError> {
        let declared = self
            .root
            .buffers
            .iter()
            .fold(0u64, |sum, b| sum.saturating_add(b.byte_length.0));
        if declared > MAX_READ_BYTES {
            return Err(self.err(
                "buffers",
                format!("{declared} bytes in total exceed rqr's limit of {MAX_READ_BYTES}"),
            ));
        }
        let mut data = Vec::with_capacity(self.root.buffers.len());
        for (i, b) in self.root.buffers.iter().enumerate() {
            let element = match &b.uri {
                Some(uri) if !uri.starts_with("data:") => format!("buffer {i} ({uri})"),
                _ => format!("buffer {i}"),
            };
            let mut bytes = match &b.uri {
                Some(uri) => self.read_uri(&element, uri)?,
                None if i == 0 => bin
                    .ok_or_else(|| {
                        self.err(&element, "has no uri and the file has no GLB BIN chunk")
                    })?
                    .to_vec(),
                None if compression::is_fallback(b) => Vec::new(),
                None => {
                    return Err(self.err(
                        &element,
                        "has no uri (only buffer 0 may refer to the GLB BIN chunk)",
                    ))
                }
            };
            let want = b.byte_length.0;
            if (bytes.len() as u64) < want && !compression::is_fallback(b) {
                return Err(self.err(
                    &element,
                    format!(
                        "byteLength is {want} but only {} bytes are available",
                        bytes.len()
                    ),
                ));
            }
            bytes.truncate(want as usize);
            // A file larger than byteLength must not stay allocated in full.
            bytes.shrink_to_fit();
            data.push(bytes);
        }
        self.buffers = Buffers { data };
        compression::decode_views(&self.file, &mut self.root, &mut self.buffers)?;
        draco::decode_primitives(&self.file, &mut self.root, &mut self.buffers)
    }

    fn load_scene(&mut self) -> Result<(), SceneError> {
        let roots: Vec<usize> = if self.root.scenes.is_empty() {
            if let Some(s) = self.opts.scene {
                return Err(self.err(
                    format!("scene {s}"),
                    "does not exist (the file has no scenes)",
                ));
            }
            // A file without scenes: show every root node rather than nothing.
            let mut is_child = vec![false; self.root.nodes.len()];
            for node in &self.root.nodes {
                for c in node.children.iter().flatten() {
                    is_child[c.value()] = true;
                }
            }
            if !self.root.nodes.is_empty() {
                log::warn!("{}: no scenes; showing every root node", self.file);
            }
            (0..self.root.nodes.len())
                .filter(|&n| !is_child[n])
                .collect()
        } else {
            let (index, what) = match (self.opts.scene, &self.root.scene) {
                (Some(s), _) => (s, ""),
                (None, Some(s)) => (s.value(), " (the file's default scene)"),
                (None, None) => (0, ""),
            };
            let scene = self.root.scenes.get(index).ok_or_else(|| {
                self.err(
                    format!("scene {index}{what}"),
                    format!(
                        "does not exist (the file has {} scenes)",
                        self.root.scenes.len()
                    ),
                )
            })?;
            let mut roots = Vec::with_capacity(scene.nodes.len());
            for r in &scene.nodes {
                if r.value() >= self.root.nodes.len() {
                    return Err(self.err(
                        format!("scene {index}"),
                        format!(
                            "node {} does not exist ({} nodes)",
                            r.value(),
                            self.root.nodes.len()
                        ),
                    ));
                }
                roots.push(r.value());
            }
            roots
        };
        self.check_declared_vertices(&roots)?;
        self.scene.mesh_count = self.root.meshes.len();
        self.scene.primitive_count = self.root.meshes.iter().map(|m| m.primitives.len()).sum();

        self.scene.node_world = vec![None; self.root.nodes.len()];
        let mut cameras: Vec<(usize, Camera)> = Vec::new();
        let mut lights: Vec<(usize, Light)> = Vec::new();
        let mut visits = 0usize;
        let mut stack: Vec<(usize, Mat4, Option<usize>)> = roots
            .iter()
            .rev()
            .map(|&r| (r, Mat4::IDENTITY, None))
            .collect();
        while let Some((n, parent, parent_node)) = stack.pop() {
            visits += 1;
            if visits > MAX_INSTANCES {
                return Err(self.err(
                    format!("node {n}"),
                    format!("the node hierarchy expands to more than {MAX_INSTANCES} nodes"),
                ));
            }
            let world = parent * self.node_local(n)?;
            if !world.is_finite() {
                return Err(self.err(format!("node {n}"), "world transform is not finite"));
            }
            let slot = &mut self.scene.node_world[n];
            if slot.is_none() {
                *slot = Some(world);
                self.scene.rig.order.push(n);
                self.scene.rig.nodes[n].parent = parent_node;
            }
            let node = &self.root.nodes[n];
            if let Some(mesh) = node.mesh {
                self.place_mesh(n, mesh.value(), world)?;
            }
            let node = &self.root.nodes[n];
            if let Some(c) = node.camera {
                cameras.push((n, self.camera(n, c.value(), world)?));
            }
            if let Some(l) = node
                .extensions
                .as_ref()
                .and_then(|e| e.khr_lights_punctual.as_ref())
            {
                lights.push((n, self.light(n, l.light.value(), world)?));
            }
            for c in self.root.nodes[n].children.iter().flatten().rev() {
                stack.push((c.value(), world, Some(n)));
            }
        }
        cameras.sort_by_key(|(n, _)| *n);
        lights.sort_by_key(|(n, _)| *n);
        self.scene.rig.camera_nodes = cameras.iter().map(|(n, _)| *n).collect();
        self.scene.rig.light_nodes = lights.iter().map(|(n, _)| *n).collect();
        self.scene.cameras = cameras.into_iter().map(|(_, c)| c).collect();
        self.scene.lights = lights.into_iter().map(|(_, l)| l).collect();
        if self.scene.lights.is_empty() {
            self.scene.lights = default_lights();
            self.scene.default_lights = true;
        }
        Ok(())
    }

    pub(super) fn texture_ref(
        &mut self,
        el: &str,
        slot: &str,
        texture: usize,
        tex_coord: u32,
        transform: Option<gj::extensions::texture::TextureTransform>,
        srgb: bool,
    ) -> Result<TextureRef, SceneError> {
        let element = format!("{el} {slot}");
        if texture >= self.root.textures.len() {
            return Err(self.err(
                &element,
                format!(
                    "texture {texture} does not exist ({} textures)",
                    self.root.textures.len()
                ),
            ));
        }
        let (matrix, tex_coord) = match transform {
            Some(t) => (
                texture_transform_matrix(
                    Vec2::from(t.offset.0),
                    t.rotation.0,
                    Vec2::from(t.scale.0),
                ),
                t.tex_coord.unwrap_or(tex_coord),
            ),
            None => (Mat3::IDENTITY, tex_coord),
        };
        Ok(TextureRef {
            texture: self.texture(texture, srgb)?,
            tex_coord,
            transform: matrix,
        })
    }

    fn finish(mut self) -> Result<Scene, SceneError> {
        // Exact bounds (every transformed vertex) unless that is a lot of work; then the
        // transformed corners of each geometry's box, which is conservative.
        let work: usize = self
            .scene
            .instances
            .iter()
            .map(|i| self.scene.geometries[i.geometry as usize].positions.len())
            .sum();
        let mut bounds = Aabb::EMPTY;
        for inst in &self.scene.instances {
            let g = inst.geometry as usize;
            let mut local = Aabb::EMPTY;
            // Overflowing products can be NaN, which min/max would skip: count them apart.
            let mut overflow = false;
            let mut grow = |p: Vec3| {
                overflow |= !p.is_finite();
                local.grow(p);
            };
            if work <= 1 << 25 {
                for p in &self.scene.geometries[g].positions {
                    grow(inst.transform.transform_point3(*p));
                }
            } else {
                let b = self.geometry_bounds[g];
                for k in 0..8 {
                    let c = Vec3::new(
                        if k & 1 == 0 { b.min.x } else { b.max.x },
                        if k & 2 == 0 { b.min.y } else { b.max.y },
                        if k & 4 == 0 { b.min.z } else { b.max.z },
                    );
                    grow(inst.transform.transform_point3(c));
                }
            }
            if !local.is_empty() || overflow {
                let reach = if overflow {
                    f32::INFINITY
                } else {
                    local.min.abs().max(local.max.abs()).max_element()
                };
                if reach > MAX_COORDINATE {
                    return Err(self.err(
                        format!("node {}", inst.node),
                        format!("mesh vertices reach world coordinate {reach:e}, beyond rqr's limit of ±{MAX_COORDINATE:e} (single-precision ray math would overflow)"),
                    ));
                }
                bounds.grow(local.min);
                bounds.grow(local.max);
            }
        }
        self.scene.bounds = bounds;
        if self.scene.triangle_count() == 0 {
            log::warn!(
                "{}: the scene has no triangles: nothing to render but the background",
                self.file
            );
        }
        if self.scene.materials.is_empty() {
            self.scene.materials.push(Material {
                name: "default".into(),
                ..Default::default()
            });
        }
        Ok(self.scene)
    }
}

/// The KHR_texture_transform matrix `T * R * S` applied to `(u, v, 1)`: scale first, then a
/// rotation by `rotation` radians (counter-clockwise in UV space:
/// `u' = cos·u + sin·v, v' = -sin·u + cos·v`, which matches the extension's worked example), then the offset.
pub fn texture_transform_matrix(offset: Vec2, rotation: f32, scale: Vec2) -> Mat3 {
    let (s, c) = rotation.sin_cos();
    let t = Mat3::from_cols(Vec3::X, Vec3::Y, offset.extend(1.0));
    let r = Mat3::from_cols(Vec3::new(c, -s, 0.0), Vec3::new(s, c, 0.0), Vec3::Z);
    let sc = Mat3::from_diagonal(scale.extend(1.0));
    t * r * sc
}

impl Scene {
    /// The camera to render with: file camera `index` (`--camera N`), else the scene's first
    /// camera, else [`auto_camera`](super::auto_camera) framing the bounds at `aspect`.
    pub fn camera(&self, index: Option<usize>, aspect: f32) -> Result<Camera, SceneError> {
        match index {
            Some(i) => self.cameras.get(i).copied().ok_or_else(|| {
                SceneError::element(
                    &self.source,
                    format!("camera {i}"),
                    format!(
                        "does not exist (the scene has {} cameras)",
                        self.cameras.len()
                    ),
                )
            }),
            None => Ok(self
                .cameras
                .first()
                .copied()
                .unwrap_or_else(|| super::camera::auto_camera(&self.bounds, aspect))),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_transform_matches_spec_example() {
        // KHR_texture_transform README: offset (0, 1), rotation 90°, scale 0.5 selects the
        // lower-left quadrant of the image.
        let m = texture_transform_matrix(
            Vec2::new(0.0, 1.0),
            std::f32::consts::FRAC_PI_2,
            Vec2::splat(0.5),
        );
        for (uv, want) in [
            (Vec2::new(0.0, 0.0), Vec2::new(0.0, 1.0)),
            (Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.5)),
            (Vec2::new(0.0, 1.0), Vec2::new(0.5, 1.0)),
            (Vec2::new(1.0, 1.0), Vec2::new(0.5, 0.5)),
        ] {
            let got = (m * uv.extend(1.0)).truncate();
            assert!(got.abs_diff_eq(want, 1e-6), "{uv} -> {got}, want {want}");
        }
    }
}

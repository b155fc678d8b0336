use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use rqr::scene::{self, ExtensionStatus, LoadOptions, Scene, SceneError};
use serde::Serialize;

use super::outln;

/// `rqr info` arguments.
#[derive(Args, Debug)]
pub struct InfoArgs {
    /// glTF 2.0 file (`.gltf` or `.glb`); omitted: the built-in scene.
    scene: Option<PathBuf>,
    /// Scene index within the file (default: the file's default scene, else 0).
    #[arg(long = "scene", value_name = "N")]
    scene_index: Option<usize>,
    /// KHR_materials_variants variant whose materials to load (the list is printed either way).
    #[arg(long, value_name = "NAME")]
    variant: Option<String>,
    /// Print one JSON object instead of a table.
    #[arg(long)]
    json: bool,
}

/// Loads the scene a command names: a file, or the built-in scene when `path` is `None`.
pub(crate) fn load_scene(
    path: Option<&PathBuf>,
    scene_index: Option<usize>,
    variant: Option<&str>,
) -> Result<Scene> {
    Ok(match path {
        Some(p) => scene::load(
            p,
            &LoadOptions {
                scene: scene_index,
                variant: variant.map(str::to_string),
                ..Default::default()
            },
        )?,
        None if variant.is_some() => {
            super::usage!(
                "--variant",
                "--variant: the built-in scene has no material variants"
            )
        }
        None if scene_index.unwrap_or(0) == 0 => scene::load_default()?,
        None => super::usage!("--scene", "--scene: the built-in scene has only scene 0"),
    })
}

/// Scene bounds in the `--json` document.
#[derive(Serialize)]
struct BoundsJson {
    min: [f32; 3],
    max: [f32; 3],
}

/// The `--json` document (a struct so that keys keep this order).
#[derive(Serialize)]
struct InfoJson<'a> {
    source: &'a str,
    meshes: usize,
    primitives: usize,
    geometries: usize,
    instances: usize,
    triangles: usize,
    unique_triangles: usize,
    materials: usize,
    textures: usize,
    images: usize,
    lights: usize,
    default_lights: bool,
    cameras: usize,
    extensions_used: &'a [String],
    extensions_unsupported: &'a [String],
    /// Every extension the file names: `{"name", "status"}` with status `supported`,
    /// `ignored` or `unsupported-required`.
    extensions: &'a [ExtensionStatus],
    /// KHR_materials_variants names, in the file's order.
    variants: &'a [String],
    /// The variant the materials come from (`--variant`); `null`: the defaults.
    variant: Option<&'a str>,
    /// `null` for a scene without geometry.
    bounds: Option<BoundsJson>,
    /// Animations: name (may be empty), length in seconds, channel count.
    animations: Vec<AnimationJson<'a>>,
    /// Skins of the file.
    skins: usize,
    /// Geometries with morph targets.
    morphed_geometries: usize,
}

#[derive(Serialize)]
struct AnimationJson<'a> {
    name: &'a str,
    duration: f32,
    channels: usize,
}

fn to_json(s: &Scene) -> InfoJson<'_> {
    InfoJson {
        source: &s.source,
        meshes: s.mesh_count,
        primitives: s.primitive_count,
        geometries: s.geometries.len(),
        instances: s.instances.len(),
        triangles: s.triangle_count(),
        unique_triangles: s.unique_triangle_count(),
        materials: s.materials.len(),
        textures: s.textures.len(),
        images: s.images.len(),
        lights: s.lights.len(),
        default_lights: s.default_lights,
        cameras: s.cameras.len(),
        extensions_used: &s.extensions_used,
        extensions_unsupported: &s.extensions_unsupported,
        extensions: &s.extensions,
        variants: &s.variants,
        variant: s.variant.map(|v| s.variants[v].as_str()),
        bounds: (!s.bounds.is_empty()).then(|| BoundsJson {
            min: s.bounds.min.to_array(),
            max: s.bounds.max.to_array(),
        }),
        animations: s
            .rig
            .animations
            .iter()
            .map(|a| AnimationJson {
                name: &a.name,
                duration: a.duration(),
                channels: a.channels.len(),
            })
            .collect(),
        skins: s.rig.skins.len(),
        morphed_geometries: s
            .geometries
            .iter()
            .filter(|g| !g.morph_targets.is_empty())
            .count(),
    }
}

/// Runs `rqr info`.
pub fn run(args: &InfoArgs) -> Result<()> {
    let s = match load_scene(
        args.scene.as_ref(),
        args.scene_index,
        args.variant.as_deref(),
    ) {
        Ok(s) => s,
        Err(e) => {
            // A file refused for a required extension still gets its extension list in
            // JSON (then the error, exit status 1): what to add to support it.
            if let (true, Some(SceneError::UnsupportedExtensions { file, all, .. })) =
                (args.json, e.downcast_ref::<SceneError>())
            {
                let doc =
                    serde_json::json!({"source": file, "error": e.to_string(), "extensions": all});
                outln!("{doc}")?;
            }
            return Err(e);
        }
    };
    if args.json {
        outln!("{}", serde_json::to_string(&to_json(&s))?)?;
        return Ok(());
    }
    let list = |v: &[String]| {
        if v.is_empty() {
            "-".to_string()
        } else {
            v.join(", ")
        }
    };
    let texels: usize = s.images.iter().map(|i| i.rgba8.len() / 4).sum();
    let rows: Vec<(&str, String)> = vec![
        ("source", s.source.clone()),
        ("meshes", s.mesh_count.to_string()),
        ("primitives", s.primitive_count.to_string()),
        ("geometries", s.geometries.len().to_string()),
        ("instances", s.instances.len().to_string()),
        ("triangles", s.triangle_count().to_string()),
        ("unique triangles", s.unique_triangle_count().to_string()),
        ("materials", s.materials.len().to_string()),
        (
            "textures",
            format!(
                "{} ({} images, {:.1} Mtexels)",
                s.textures.len(),
                s.images.len(),
                texels as f64 / 1e6
            ),
        ),
        (
            "lights",
            if s.default_lights {
                format!("{} (default rig: the file has none)", s.lights.len())
            } else {
                s.lights.len().to_string()
            },
        ),
        ("cameras", s.cameras.len().to_string()),
        (
            "animations",
            if s.rig.animations.is_empty() {
                "-".into()
            } else {
                s.rig
                    .animations
                    .iter()
                    .enumerate()
                    .map(|(i, a)| format!("{i} '{}' {:.2} s", a.name, a.duration()))
                    .collect::<Vec<_>>()
                    .join(", ")
            },
        ),
        (
            "skins, morphs",
            format!(
                "{} skins, {} geometries with morph targets",
                s.rig.skins.len(),
                s.geometries
                    .iter()
                    .filter(|g| !g.morph_targets.is_empty())
                    .count()
            ),
        ),
        ("extensions used", list(&s.extensions_used)),
        ("unsupported", list(&s.extensions_unsupported)),
        (
            "variants",
            match s.variant {
                Some(v) => format!("{} (rendering {})", list(&s.variants), s.variants[v]),
                None => list(&s.variants),
            },
        ),
        (
            "bounds",
            if s.bounds.is_empty() {
                "empty".into()
            } else {
                format!(
                    "[{:.3}, {:.3}, {:.3}] .. [{:.3}, {:.3}, {:.3}]",
                    s.bounds.min.x,
                    s.bounds.min.y,
                    s.bounds.min.z,
                    s.bounds.max.x,
                    s.bounds.max.y,
                    s.bounds.max.z
                )
            },
        ),
    ];
    for (k, v) in rows {
        outln!("{k:<18} {v}")?;
    }
    Ok(())
}

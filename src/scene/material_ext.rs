//! Layered-material extensions read from a glTF material's `extensions` object:
//! KHR_materials_specular, KHR_materials_clearcoat and KHR_materials_sheen (which `gltf-json`
//! does not model), and KHR_materials_volume's thickness texture.

use ::gltf::json as gj;
use glam::Vec3;
use serde::Deserialize;
use serde_json::{Map, Value};

use super::error::SceneError;
use super::loader::Loader;
use super::types::{Material, MaterialLayers, TextureRef};

/// A `textureInfo` (or `normalTextureInfo`) as the extensions write it.
#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct TexInfo {
    index: usize,
    #[serde(default)]
    tex_coord: u32,
    #[serde(default = "one")]
    scale: f32,
    #[serde(default)]
    extensions: Option<Map<String, Value>>,
}

fn one() -> f32 {
    1.0
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Specular {
    #[serde(default = "one")]
    specular_factor: f32,
    specular_texture: Option<TexInfo>,
    #[serde(default = "white")]
    specular_color_factor: [f32; 3],
    specular_color_texture: Option<TexInfo>,
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Clearcoat {
    #[serde(default)]
    clearcoat_factor: f32,
    clearcoat_texture: Option<TexInfo>,
    #[serde(default)]
    clearcoat_roughness_factor: f32,
    clearcoat_roughness_texture: Option<TexInfo>,
    clearcoat_normal_texture: Option<TexInfo>,
}

#[derive(Deserialize)]
#[serde(rename_all = "camelCase")]
struct Sheen {
    #[serde(default)]
    sheen_color_factor: [f32; 3],
    sheen_color_texture: Option<TexInfo>,
    #[serde(default)]
    sheen_roughness_factor: f32,
    sheen_roughness_texture: Option<TexInfo>,
}

/// Parses extension `name` of a material, if present.
fn parse<T: for<'de> Deserialize<'de>>(
    others: &Map<String, Value>,
    name: &str,
) -> Result<Option<T>, String> {
    others
        .get(name)
        .map(|v| serde_json::from_value(v.clone()).map_err(|e| format!("{name}: {e}")))
        .transpose()
}

fn check_unit(name: &str, v: f32) -> Result<f32, String> {
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(format!("{name} {v} is outside [0, 1]"))
    }
}

fn check_colour(name: &str, c: [f32; 3], max: f32) -> Result<Vec3, String> {
    if c.iter().all(|v| v.is_finite() && (0.0..=max).contains(v)) {
        Ok(Vec3::from(c))
    } else {
        Err(format!("{name} {c:?} is outside [0, {max}]"))
    }
}

impl Loader<'_> {
    /// A texture reference of an extension (`slot` names it in errors).
    fn ext_texture(
        &mut self,
        el: &str,
        slot: &str,
        info: &TexInfo,
        srgb: bool,
    ) -> Result<TextureRef, SceneError> {
        let transform = info
            .extensions
            .as_ref()
            .and_then(|e| e.get("KHR_texture_transform"))
            .map(|v| serde_json::from_value::<gj::extensions::texture::TextureTransform>(v.clone()))
            .transpose()
            .map_err(|e| self.err(el, format!("{slot} KHR_texture_transform: {e}")))?;
        self.texture_ref(el, slot, info.index, info.tex_coord, transform, srgb)
    }

    /// Folds the layered-material extensions of `others` (a material's `extensions`) into
    /// `m.layers`, and the volume's thickness texture into `m.thickness_texture`.
    pub(super) fn material_extensions(
        &mut self,
        el: &str,
        others: &Map<String, Value>,
        thickness_texture: Option<&gj::texture::Info>,
        m: &mut Material,
    ) -> Result<(), SceneError> {
        if let Some(t) = thickness_texture {
            let transform = t
                .extensions
                .as_ref()
                .and_then(|e| e.texture_transform.clone());
            m.thickness_texture = Some(self.texture_ref(
                el,
                "thicknessTexture",
                t.index.value(),
                t.tex_coord,
                transform,
                false,
            )?);
        }
        let specular: Option<Specular> =
            parse(others, "KHR_materials_specular").map_err(|e| self.err(el, e))?;
        let clearcoat: Option<Clearcoat> =
            parse(others, "KHR_materials_clearcoat").map_err(|e| self.err(el, e))?;
        let sheen: Option<Sheen> =
            parse(others, "KHR_materials_sheen").map_err(|e| self.err(el, e))?;
        if specular.is_none() && clearcoat.is_none() && sheen.is_none() {
            return Ok(());
        }
        let mut l = MaterialLayers::default();
        if let Some(s) = specular {
            // The spec allows specularColorFactor above 1 (F0 is clamped to 1 in shading).
            let fail = |e: String| self.err(el, format!("KHR_materials_specular {e}"));
            l.specular = check_unit("specularFactor", s.specular_factor).map_err(fail)?;
            l.specular_color =
                check_colour("specularColorFactor", s.specular_color_factor, 1e4).map_err(fail)?;
            if let Some(t) = &s.specular_texture {
                l.specular_texture = Some(self.ext_texture(el, "specularTexture", t, false)?);
            }
            if let Some(t) = &s.specular_color_texture {
                l.specular_color_texture =
                    Some(self.ext_texture(el, "specularColorTexture", t, true)?);
            }
        }
        if let Some(c) = clearcoat {
            let fail = |e: String| self.err(el, format!("KHR_materials_clearcoat {e}"));
            l.clearcoat = check_unit("clearcoatFactor", c.clearcoat_factor).map_err(fail)?;
            l.clearcoat_roughness =
                check_unit("clearcoatRoughnessFactor", c.clearcoat_roughness_factor)
                    .map_err(fail)?;
            if let Some(t) = &c.clearcoat_texture {
                l.clearcoat_texture = Some(self.ext_texture(el, "clearcoatTexture", t, false)?);
            }
            if let Some(t) = &c.clearcoat_roughness_texture {
                l.clearcoat_roughness_texture =
                    Some(self.ext_texture(el, "clearcoatRoughnessTexture", t, false)?);
            }
            if let Some(t) = &c.clearcoat_normal_texture {
                l.clearcoat_normal_texture =
                    Some(self.ext_texture(el, "clearcoatNormalTexture", t, false)?);
                l.clearcoat_normal_scale = t.scale;
            }
        }
        if let Some(s) = sheen {
            let fail = |e: String| self.err(el, format!("KHR_materials_sheen {e}"));
            l.sheen_color =
                check_colour("sheenColorFactor", s.sheen_color_factor, 1.0).map_err(fail)?;
            l.sheen_roughness =
                check_unit("sheenRoughnessFactor", s.sheen_roughness_factor).map_err(fail)?;
            if let Some(t) = &s.sheen_color_texture {
                l.sheen_color_texture = Some(self.ext_texture(el, "sheenColorTexture", t, true)?);
            }
            if let Some(t) = &s.sheen_roughness_texture {
                l.sheen_roughness_texture =
                    Some(self.ext_texture(el, "sheenRoughnessTexture", t, false)?);
            }
        }
        m.layers = Some(Box::new(l));
        Ok(())
    }
}

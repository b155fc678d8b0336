//! glTF extensions: which ones rqr implements, and how each extension a file names is
//! treated (`rqr info --json` lists them).

/// Extensions rqr implements. Others in `extensionsUsed` are ignored with a warning; others
/// in `extensionsRequired` make loading fail.
pub const SUPPORTED_EXTENSIONS: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
    "KHR_materials_specular",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "EXT_mesh_gpu_instancing",
    "EXT_meshopt_compression",
    "KHR_draco_mesh_compression",
    "KHR_texture_basisu",
    "EXT_texture_webp",
    "KHR_materials_variants",
];

/// Texture extensions that name an alternative image (`{"source": i}`), in preference order.
const IMAGE_SOURCE_EXTENSIONS: &[&str] = &["KHR_texture_basisu", "EXT_texture_webp"];

/// The image a texture samples: the `source` of KHR_texture_basisu or EXT_texture_webp when
/// present (both are implemented, so they win over the fallback), else the core `source`.
pub(crate) fn texture_source(tex: &::gltf::json::Texture) -> Result<usize, String> {
    let others = tex.extensions.as_ref().map(|e| &e.others);
    for name in IMAGE_SOURCE_EXTENSIONS {
        let Some(ext) = others.and_then(|o| o.get(*name)) else {
            continue;
        };
        return ext
            .get("source")
            .and_then(|s| s.as_u64())
            .filter(|&s| s < u64::from(u32::MAX))
            .map(|s| s as usize)
            .ok_or_else(|| format!("{name}: `source` is missing or not an image index"));
    }
    match tex.source.value() {
        s if s == u32::MAX as usize => Err("has no source image".into()),
        s => Ok(s),
    }
}

/// How rqr treats one extension a file names.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ExtensionSupport {
    /// Implemented.
    Supported,
    /// Not implemented, but only in `extensionsUsed`: the file loads without it (warning).
    Ignored,
    /// Not implemented and in `extensionsRequired`: the file is refused.
    UnsupportedRequired,
}

impl ExtensionSupport {
    /// `supported`, `ignored` or `unsupported-required`.
    pub fn as_str(self) -> &'static str {
        match self {
            ExtensionSupport::Supported => "supported",
            ExtensionSupport::Ignored => "ignored",
            ExtensionSupport::UnsupportedRequired => "unsupported-required",
        }
    }
}

/// One extension named by a file (in `extensionsUsed` or `extensionsRequired`).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct ExtensionStatus {
    /// Extension name, e.g. `KHR_materials_clearcoat`.
    pub name: String,
    /// How rqr treats it.
    pub status: ExtensionSupport,
}

/// Every extension of `used` ∪ `required` (in that order, each once) with its treatment.
pub fn classify(used: &[String], required: &[String]) -> Vec<ExtensionStatus> {
    let mut out: Vec<ExtensionStatus> = Vec::new();
    for name in used.iter().chain(required) {
        if out.iter().any(|e| &e.name == name) {
            continue;
        }
        let status = if SUPPORTED_EXTENSIONS.contains(&name.as_str()) {
            ExtensionSupport::Supported
        } else if required.contains(name) {
            ExtensionSupport::UnsupportedRequired
        } else {
            ExtensionSupport::Ignored
        };
        out.push(ExtensionStatus {
            name: name.clone(),
            status,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classify_names_each_extension_once() {
        let s = |v: &[&str]| v.iter().map(|x| x.to_string()).collect::<Vec<_>>();
        let all = classify(
            &s(&[
                "KHR_materials_clearcoat",
                "KHR_materials_diffuse_transmission",
                "KHR_xmp",
            ]),
            &s(&["KHR_materials_diffuse_transmission"]),
        );
        let got: Vec<(&str, &str)> = all
            .iter()
            .map(|e| (e.name.as_str(), e.status.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                ("KHR_materials_clearcoat", "supported"),
                ("KHR_materials_diffuse_transmission", "unsupported-required"),
                ("KHR_xmp", "ignored"),
            ]
        );
    }
}

//! glTF materials → [`Material`].

use super::*;

impl Loader<'_> {
    /// The scene material for glTF material `index` (None: the glTF default material).
    pub(super) fn material(&mut self, index: Option<usize>) -> Result<u32, SceneError> {
        if let Some(&m) = self.material_of.get(&index) {
            return Ok(m);
        }
        let mat = match index {
            None => Material {
                name: "default".into(),
                ..Default::default()
            },
            Some(i) => self.convert_material(i)?,
        };
        self.scene.materials.push(mat);
        let m = (self.scene.materials.len() - 1) as u32;
        self.material_of.insert(index, m);
        Ok(m)
    }

    pub(super) fn convert_material(&mut self, i: usize) -> Result<Material, SceneError> {
        let j = self.root.materials[i].clone();
        let el = format!("material {i}");
        let pbr = &j.pbr_metallic_roughness;
        let info_transform = |info: &gj::texture::Info| {
            info.extensions
                .as_ref()
                .and_then(|e| e.texture_transform.clone())
        };
        let other_transform = |others: Option<&serde_json::Map<String, serde_json::Value>>| {
            others
                .and_then(|o| o.get("KHR_texture_transform"))
                .map(|v| {
                    serde_json::from_value::<gj::extensions::texture::TextureTransform>(v.clone())
                })
        };
        let mut m = Material {
            name: j.name.clone().unwrap_or_default(),
            base_color: Vec4::from(pbr.base_color_factor.0),
            metallic: pbr.metallic_factor.0,
            roughness: pbr.roughness_factor.0,
            emissive: Vec3::from(j.emissive_factor.0),
            alpha_mode: match checked(&j.alpha_mode) {
                Some(gj::material::AlphaMode::Opaque) => AlphaMode::Opaque,
                Some(gj::material::AlphaMode::Mask) => AlphaMode::Mask,
                Some(gj::material::AlphaMode::Blend) => AlphaMode::Blend,
                None => return Err(self.err(&el, "invalid alphaMode")),
            },
            alpha_cutoff: j.alpha_cutoff.map_or(0.5, |c| c.0),
            double_sided: j.double_sided,
            ..Default::default()
        };
        if let Some(t) = &pbr.base_color_texture {
            m.base_color_texture = Some(self.texture_ref(
                &el,
                "baseColorTexture",
                t.index.value(),
                t.tex_coord,
                info_transform(t),
                true,
            )?);
        }
        if let Some(t) = &pbr.metallic_roughness_texture {
            m.metallic_roughness_texture = Some(self.texture_ref(
                &el,
                "metallicRoughnessTexture",
                t.index.value(),
                t.tex_coord,
                info_transform(t),
                false,
            )?);
        }
        if let Some(t) = &j.normal_texture {
            let tt = other_transform(t.extensions.as_ref().map(|e| &e.others))
                .transpose()
                .map_err(|e| self.err(&el, format!("normalTexture KHR_texture_transform: {e}")))?;
            m.normal_texture = Some(self.texture_ref(
                &el,
                "normalTexture",
                t.index.value(),
                t.tex_coord,
                tt,
                false,
            )?);
            m.normal_scale = t.scale;
        }
        if let Some(t) = &j.occlusion_texture {
            let tt = other_transform(t.extensions.as_ref().map(|e| &e.others))
                .transpose()
                .map_err(|e| {
                    self.err(&el, format!("occlusionTexture KHR_texture_transform: {e}"))
                })?;
            m.occlusion_texture = Some(self.texture_ref(
                &el,
                "occlusionTexture",
                t.index.value(),
                t.tex_coord,
                tt,
                false,
            )?);
            m.occlusion_strength = t.strength.0;
        }
        if let Some(t) = &j.emissive_texture {
            m.emissive_texture = Some(self.texture_ref(
                &el,
                "emissiveTexture",
                t.index.value(),
                t.tex_coord,
                info_transform(t),
                true,
            )?);
        }
        if let Some(ext) = &j.extensions {
            if let Some(s) = &ext.emissive_strength {
                m.emissive *= s.emissive_strength.0;
            }
            if let Some(t) = &ext.transmission {
                m.transmission = t.transmission_factor.0;
                if let Some(tex) = &t.transmission_texture {
                    m.transmission_texture = Some(self.texture_ref(
                        &el,
                        "transmissionTexture",
                        tex.index.value(),
                        tex.tex_coord,
                        info_transform(tex),
                        false,
                    )?);
                }
            }
            if let Some(ior) = &ext.ior {
                m.ior = ior.ior.0;
            }
            if let Some(v) = &ext.volume {
                m.thickness = v.thickness_factor.0;
                m.attenuation_color = Vec3::from(v.attenuation_color.0);
                m.attenuation_distance = v.attenuation_distance.0;
            }
            let thickness = ext
                .volume
                .as_ref()
                .and_then(|v| v.thickness_texture.as_ref());
            self.material_extensions(&el, &ext.others, thickness, &mut m)?;
        }
        for set in m.assign_uv_sets() {
            log::warn!("{}: {el}: a material reads at most two TEXCOORD sets in rqr; textures on TEXCOORD_{set} read TEXCOORD_{}", self.file, m.uv_sets[0]);
        }
        if m.ior != 0.0 && m.ior < 1.0 {
            return Err(self.err(&el, format!("KHR_materials_ior ior {} is below 1", m.ior)));
        }
        if m.attenuation_distance <= 0.0 {
            return Err(self.err(
                &el,
                format!(
                    "KHR_materials_volume attenuationDistance {} must be positive",
                    m.attenuation_distance
                ),
            ));
        }
        Ok(m)
    }
}

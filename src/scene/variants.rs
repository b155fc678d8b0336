//! KHR_materials_variants: the file's named material variants, and which material each
//! primitive takes under the variant chosen at load (`LoadOptions::variant`, `--variant`).

use ::gltf::json as gj;
use serde_json::Value;

const EXT: &str = "KHR_materials_variants";

/// The variant names of the root `KHR_materials_variants` extension, in index order (empty
/// without the extension).
pub(crate) fn names(root: &gj::Root) -> Result<Vec<String>, String> {
    let Some(ext) = root.extensions.as_ref().and_then(|e| e.others.get(EXT)) else {
        return Ok(Vec::new());
    };
    let Some(list) = ext.get("variants").and_then(Value::as_array) else {
        return Err(format!("{EXT}: `variants` is missing or not an array"));
    };
    list.iter()
        .enumerate()
        .map(|(i, v)| {
            v.get("name")
                .and_then(Value::as_str)
                .map(str::to_string)
                .ok_or_else(|| format!("{EXT}: variant {i} has no `name`"))
        })
        .collect()
}

/// The index of variant `wanted` among `names`; an unknown name fails listing the known ones.
pub(crate) fn find(names: &[String], wanted: &str) -> Result<usize, String> {
    names.iter().position(|n| n == wanted).ok_or_else(|| {
        if names.is_empty() {
            format!("variant '{wanted}' requested, but the file has no {EXT} variants")
        } else {
            format!(
                "variant '{wanted}' does not exist (variants: {})",
                names.join(", ")
            )
        }
    })
}

/// The material index a primitive renders with: the one its `KHR_materials_variants`
/// mapping names for `variant`, else its own `material`. Mappings that name a variant index
/// outside `0..variant_count` fail.
pub(crate) fn primitive_material(
    prim: &gj::mesh::Primitive,
    variant: Option<usize>,
    variant_count: usize,
) -> Result<Option<usize>, String> {
    let own = prim.material.map(|m| m.value());
    let Some(ext) = prim.extensions.as_ref().and_then(|e| e.others.get(EXT)) else {
        return Ok(own);
    };
    let Some(mappings) = ext.get("mappings").and_then(Value::as_array) else {
        return Err(format!("{EXT}: `mappings` is missing or not an array"));
    };
    let mut chosen = None;
    for (i, m) in mappings.iter().enumerate() {
        let material = m
            .get("material")
            .and_then(Value::as_u64)
            .ok_or_else(|| format!("{EXT}: mapping {i} has no `material` index"))?;
        let variants = m
            .get("variants")
            .and_then(Value::as_array)
            .ok_or_else(|| format!("{EXT}: mapping {i} has no `variants` array"))?;
        for v in variants {
            let v = v
                .as_u64()
                .filter(|&v| v < variant_count as u64)
                .ok_or_else(|| {
                    format!("{EXT}: mapping {i} names variant {v}, the file has {variant_count}")
                })?;
            if Some(v as usize) == variant && chosen.is_none() {
                chosen = Some(material as usize);
            }
        }
    }
    Ok(chosen.or(own))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn prim(ext: Value) -> gj::mesh::Primitive {
        serde_json::from_value(serde_json::json!({
            "attributes": {"POSITION": 0},
            "material": 0,
            "extensions": {"KHR_materials_variants": ext},
        }))
        .unwrap()
    }

    #[test]
    fn mappings_choose_the_material() {
        let p = prim(serde_json::json!({"mappings": [
            {"material": 2, "variants": [0, 2]},
            {"material": 3, "variants": [1]},
        ]}));
        assert_eq!(primitive_material(&p, None, 3), Ok(Some(0)));
        assert_eq!(primitive_material(&p, Some(0), 3), Ok(Some(2)));
        assert_eq!(primitive_material(&p, Some(1), 3), Ok(Some(3)));
        assert_eq!(primitive_material(&p, Some(2), 3), Ok(Some(2)));
        let e = primitive_material(&p, Some(0), 2).unwrap_err();
        assert!(
            e.contains("mapping 0 names variant 2, the file has 2"),
            "{e}"
        );
        let bad = prim(serde_json::json!({"mappings": [{"variants": [0]}]}));
        assert!(primitive_material(&bad, None, 1)
            .unwrap_err()
            .contains("mapping 0 has no `material`"));
    }

    #[test]
    fn unknown_variant_lists_the_known_ones() {
        let names = vec!["Yellow".to_string(), "Red".to_string()];
        assert_eq!(find(&names, "Red"), Ok(1));
        assert_eq!(
            find(&names, "Blue").unwrap_err(),
            "variant 'Blue' does not exist (variants: Yellow, Red)"
        );
        assert!(find(&[], "Red")
            .unwrap_err()
            .contains("no KHR_materials_variants"));
    }
}

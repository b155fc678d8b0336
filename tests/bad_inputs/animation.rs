//! Bad-input cases of animations, skins and morph targets: joints out of range,
//! weights that do not sum to 1, inverse bind matrix count mismatch, sampler input not
//! increasing, output count mismatch, CUBICSPLINE with the wrong tangent count, morph target
//! count differing across primitives, animation of a missing node, cyclic skeleton; and
//! `--animation` choices that name no animation of the file.

use serde_json::{json, Value};

use super::corpus::{Case, Expect};
use rqr::scene::AnimationSelection;

use crate::support::scene_files::{bytes, load_asset, quad_doc, Builder};

/// What to break in the skinned, animated quad.
#[derive(Clone, Copy, Default)]
struct Skinned {
    /// JOINTS_0 of every vertex.
    joint: u8,
    /// WEIGHTS_0.x of every vertex.
    weight: f32,
    /// Inverse bind matrices stored.
    matrices: usize,
    /// Key times of the animation.
    times: [f32; 2],
    /// Translation values stored (3 floats each).
    values: usize,
    /// Interpolation.
    cubic: bool,
}

const GOOD: Skinned = Skinned {
    joint: 0,
    weight: 1.0,
    matrices: 1,
    times: [0.0, 1.0],
    values: 2,
    cubic: false,
};

/// A quad skinned to joint node 1, whose translation is animated.
fn skinned(s: Skinned) -> (Builder, Value) {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({}));
    let joints = b.view(&[s.joint, 0, 0, 0].repeat(4));
    let joints = b
        .accessor(json!({"bufferView": joints, "componentType": 5121, "count": 4, "type": "VEC4"}));
    let weights = b.floats(&[s.weight, 0.0, 0.0, 0.0].repeat(4), "VEC4");
    let identity: Vec<f32> = glam::Mat4::IDENTITY.to_cols_array().to_vec();
    let ibm_bytes: Vec<u8> = identity
        .repeat(s.matrices)
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
    let ibm = b.view(&ibm_bytes);
    let ibm = b.accessor(
        json!({"bufferView": ibm, "componentType": 5126, "count": s.matrices, "type": "MAT4"}),
    );
    let times = b.floats(&s.times, "SCALAR");
    let values: Vec<f32> = (0..s.values * 3).map(|i| i as f32 * 0.01).collect();
    let values = b.floats(&values, "VEC3");
    let attrs = &mut doc["meshes"][0]["primitives"][0]["attributes"];
    attrs["JOINTS_0"] = json!(joints);
    attrs["WEIGHTS_0"] = json!(weights);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    doc["nodes"] = json!([{"mesh": 0, "skin": 0}, {"translation": [0, 0, 0]}]);
    doc["skins"] = json!([{"joints": [1], "inverseBindMatrices": ibm}]);
    doc["animations"] = json!([{
        "samplers": [{"input": times, "output": values,
                      "interpolation": if s.cubic { "CUBICSPLINE" } else { "LINEAR" }}],
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}],
    }]);
    (b, doc)
}

fn case(name: &str, doc: Value, expect: Expect) -> Case {
    Case {
        name: name.to_string(),
        files: vec![("scene.gltf".into(), bytes(&doc))],
        expect,
    }
}

fn skinned_case(name: &str, s: Skinned, expect: Expect) -> Case {
    let (b, doc) = skinned(s);
    case(name, b.document(doc), expect)
}

fn edited(name: &str, edit: impl Fn(&mut Value), needles: &[&'static str]) -> Case {
    let (b, mut doc) = skinned(GOOD);
    edit(&mut doc);
    case(name, b.document(doc), Expect::Fails(needles.to_vec()))
}

/// A quad with one morph target moving every vertex by +z, and weights animated.
fn morphed(second_primitive_targets: usize) -> Value {
    let mut b = Builder::default();
    let mut doc = quad_doc(&mut b, json!({}));
    let delta = b.floats(&[0.0, 0.0, 1.0].repeat(4), "VEC3");
    let prim = doc["meshes"][0]["primitives"][0].clone();
    doc["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": delta}]);
    let mut second = prim;
    second["targets"] = json!(vec![json!({"POSITION": delta}); second_primitive_targets]);
    doc["meshes"][0]["primitives"]
        .as_array_mut()
        .unwrap()
        .push(second);
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let weights = b.floats(&[0.0, 1.0], "SCALAR");
    doc["animations"] = json!([{
        "samplers": [{"input": times, "output": weights}],
        "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
    }]);
    b.document(doc)
}

pub fn cases(out: &mut Vec<Case>) {
    out.push(skinned_case(
        "anim_skinned_intact",
        GOOD,
        Expect::Loads {
            warning: None,
            render: true,
        },
    ));
    out.push(case(
        "anim_morph_intact",
        morphed(1),
        Expect::Loads {
            warning: None,
            render: false,
        },
    ));
    out.push(skinned_case(
        "skin_joint_out_of_range",
        Skinned { joint: 3, ..GOOD },
        Expect::Fails(vec!["node 0 (skin 0)", "uses joint 3", "1 joints"]),
    ));
    out.push(skinned_case(
        "skin_weights_not_normalized",
        Skinned {
            weight: 0.5,
            ..GOOD
        },
        Expect::Loads {
            warning: Some("do not sum to 1; normalized"),
            render: false,
        },
    ));
    out.push(skinned_case(
        "skin_inverse_bind_count",
        Skinned {
            matrices: 2,
            ..GOOD
        },
        Expect::Fails(vec!["skin 0", "2 matrices for 1 joints"]),
    ));
    out.push(skinned_case(
        "anim_input_not_increasing",
        Skinned {
            times: [1.0, 0.5],
            ..GOOD
        },
        Expect::Fails(vec!["animation 0 sampler 0", "not strictly increasing"]),
    ));
    out.push(skinned_case(
        "anim_output_count",
        Skinned { values: 3, ..GOOD },
        Expect::Fails(vec!["animation 0 sampler 0", "has 9 values", "need 6"]),
    ));
    out.push(skinned_case(
        "anim_cubic_tangents",
        Skinned {
            cubic: true,
            ..GOOD
        },
        Expect::Fails(vec![
            "animation 0 sampler 0",
            "CUBICSPLINE needs 3 elements",
        ]),
    ));
    out.push(case(
        "morph_target_count_differs",
        morphed(2),
        Expect::Fails(vec![
            "mesh 0 primitive 1",
            "2 morph targets but primitive 0 has 1",
        ]),
    ));
    out.push(edited(
        "anim_missing_node",
        |d| d["animations"][0]["channels"][0]["target"]["node"] = json!(9),
        &["animation 0 channel 0", "node 9, which does not exist"],
    ));
    out.push(edited(
        "anim_weights_without_targets",
        |d| d["animations"][0]["channels"][0]["target"] = json!({"node": 0, "path": "weights"}),
        &["animation 0 channel 0", "no morph targets"],
    ));
    out.push(edited(
        "skin_missing_joint_node",
        |d| d["skins"][0]["joints"] = json!([7]),
        &["skin 0", "joint 0 is node 7"],
    ));
    out.push(edited(
        "skin_cyclic_skeleton",
        |d| {
            d["nodes"] = json!([{"mesh": 0, "skin": 0}, {"children": [2]}, {"children": [1]}]);
        },
        &["node hierarchy has a cycle", "node 1"],
    ));
    out.push(edited(
        "anim_missing_skin",
        |d| d["nodes"][0]["skin"] = json!(4),
        &["node 0", "skin 4 does not exist"],
    ));
}

#[test]
fn animation_selection_errors_name_the_file() {
    let s = load_asset("InterpolationTest/InterpolationTest.glb");
    let e = s
        .select_animations(&AnimationSelection::Index(9))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("InterpolationTest.glb") && e.contains("animation 9"),
        "{e}"
    );
    let e = s
        .select_animations(&AnimationSelection::Name("Walk".into()))
        .unwrap_err()
        .to_string();
    assert!(e.contains("'Walk'") && e.contains("Step Scale"), "{e}");
}

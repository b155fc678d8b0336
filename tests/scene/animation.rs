//! Animation playback: interpolation against hand-computed values (InterpolationTest), and
//! skinning / morphing of the Khronos samples, on the CPU (`Scene::posed`) and on the GPU
//! (`render::passes::skin`), against a reference written here from the glTF spec's formulas.

use crate::support;
use crate::support::scene_files;

use glam::{Mat4, Quat, Vec3};
use rqr::render::passes::skin::SkinningPass;
use rqr::scene::{self, AnimationSelection, LoadOptions, Scene};
use scene_files::asset;

fn load(rel: &str) -> Scene {
    scene::load(&asset(rel), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("loading {rel}: {e}"))
}

/// Local TRS of a root node at `time` with every animation playing.
fn root_trs(s: &Scene, node: usize, time: f32) -> (Vec3, Quat, Vec3) {
    let all = s.select_animations(&AnimationSelection::All).unwrap();
    let pose = s.rig.pose(&all, time);
    assert!(s.rig.nodes[node].parent.is_none(), "node {node} is a root");
    let (sc, r, t) = pose.world[node].to_scale_rotation_translation();
    (t, r, sc)
}

fn close(a: f32, b: f32, tol: f32) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn interpolation_test_matches_hand_computed_values() {
    let s = load("InterpolationTest/InterpolationTest.glb");
    assert_eq!(s.rig.animations.len(), 9);
    let names: Vec<&str> = s.rig.animations.iter().map(|a| a.name.as_str()).collect();
    assert!(names.contains(&"CubicSpline Translation"), "{names:?}");
    // Key times of the scale animations (from the file's accessors).
    let (k0, k1) = (0.041_666_668_f32, 0.416_666_66_f32);
    let tol = 1e-5;

    // STEP scale (node 0): keys 1, 0.5, 1, ...: the previous key holds until the next.
    assert!(
        close(root_trs(&s, 0, 0.0).2.x, 1.0, tol),
        "before the first key"
    );
    assert!(close(root_trs(&s, 0, 0.6).2.x, 0.5, tol));
    assert!(close(root_trs(&s, 0, 0.874).2.x, 0.5, tol));
    assert!(
        close(root_trs(&s, 0, 0.875).2.x, 1.0, tol),
        "a key's own time"
    );
    // LINEAR scale (node 3): halfway between 1 and 0.5.
    assert!(close(root_trs(&s, 3, 0.5 * (k0 + k1)).2.y, 0.75, tol));
    // CUBICSPLINE scale (node 4), zero tangents, u = 1/4: h00 = 0.84375, h01 = 0.15625.
    let t = k0 + 0.25 * (k1 - k0);
    let want = 0.84375 * 1.0 + 0.15625 * 0.5;
    let got = root_trs(&s, 4, t).2.z;
    assert!(close(got, want, tol), "cubic scale {got} vs {want}");
    // After the last key: the last value.
    assert!(close(root_trs(&s, 4, 10.0).2.x, 1.0, tol));

    // STEP rotation (node 5) between keys 1 and 2: key 1, -45° about z.
    let r = root_trs(&s, 5, 0.6).1;
    let want = Quat::from_rotation_z(-std::f32::consts::FRAC_PI_4);
    assert!(
        r.abs_diff_eq(want, 1e-5) || r.abs_diff_eq(-want, 1e-5),
        "{r}"
    );
    // LINEAR rotation (node 7) halfway between 0° and -45°: slerp gives -22.5°.
    let r = root_trs(&s, 7, 0.5 * 0.416_666_66).1;
    let want = Quat::from_rotation_z(-std::f32::consts::FRAC_PI_8);
    assert!(
        r.abs_diff_eq(want, 1e-5) || r.abs_diff_eq(-want, 1e-5),
        "{r} vs {want}"
    );
    // CUBICSPLINE rotation (node 6), u = 1/2 of keys 0 (identity, out-tangent identity) and
    // 1 (value -45°, in-tangent (0, 0, -0.04789090, 0.99885267)); then normalized.
    let dt = 0.416_666_66_f32;
    let v0 = glam::Vec4::W;
    let out0 = glam::Vec4::W;
    let v1 = Quat::from_rotation_z(-std::f32::consts::FRAC_PI_4);
    let v1 = glam::Vec4::from(v1);
    let in1 = glam::Vec4::new(0.0, 0.0, -0.047_890_9, 0.998_852_67);
    let q = (0.5 * v0 + 0.125 * dt * out0 + 0.5 * v1 - 0.125 * dt * in1).normalize();
    let r = glam::Vec4::from(root_trs(&s, 6, 0.5 * dt).1);
    assert!(
        r.abs_diff_eq(q, 1e-5) || r.abs_diff_eq(-q, 1e-5),
        "{r} vs {q}"
    );

    // STEP translation (node 8): y 6.665, 10, 6, ...
    assert!(close(root_trs(&s, 8, 0.6).0.y, 10.0, tol));
    // LINEAR translation (node 10) halfway between y 10 and 6.
    assert!(close(root_trs(&s, 10, 0.625).0.y, 8.0, 1e-4));
    // CUBICSPLINE translation (node 9), zero tangents, u = 1/4 between y 6.640117 and 10.
    let want = 0.84375 * 6.640_117 + 0.15625 * 10.0;
    let got = root_trs(&s, 9, 0.25 * 0.416_666_66).0.y;
    assert!(close(got, want, 1e-4), "cubic translation {got} vs {want}");

    // One animation alone moves only its node.
    let step_only = s
        .select_animations(&AnimationSelection::Name("Step Scale".into()))
        .unwrap();
    let pose = s.rig.pose(&step_only, 0.6);
    assert!(close(pose.world[0].x_axis.x, 0.5, tol));
    let rest = s.rig.pose(&[], 0.6);
    assert_eq!(pose.world[9], rest.world[9]);
}

/// World-space positions of instance `k` at `time`, from the spec's formulas: morph
/// (base + Σ w·Δ), then skinning Σ weight · (world(joint) · inverseBind) · p, or the
/// instance's node transform when unskinned.
pub fn reference_positions(s: &Scene, k: usize, time: f32) -> Vec<Vec3> {
    let anims = s.select_animations(&AnimationSelection::All).unwrap();
    let pose = s.rig.pose(&anims, time);
    let inst = &s.instances[k];
    let g = &s.geometries[inst.geometry as usize];
    let weights = &pose.weights[inst.node];
    let skin = s.rig.nodes[inst.node].skin.filter(|_| !g.joints.is_empty());
    (0..g.positions.len())
        .map(|v| {
            let mut p = g.positions[v];
            for (t, w) in g.morph_targets.iter().zip(weights) {
                if let Some(d) = t.positions.get(v) {
                    p += *w * *d;
                }
            }
            match skin {
                None => (pose.world[inst.node] * s.rig.instance_local[k]).transform_point3(p),
                Some(si) => {
                    let skin = &s.rig.skins[si];
                    let mut out = Vec3::ZERO;
                    for i in 0..8 {
                        let w = g.weights[v][i];
                        if w > 0.0 {
                            let j = g.joints[v][i] as usize;
                            let m: Mat4 = pose.world[skin.joints[j]] * skin.inverse_bind[j];
                            out += w * m.transform_point3(p);
                        }
                    }
                    out
                }
            }
        })
        .collect()
}

pub const DEFORMED_SAMPLES: [&str; 6] = [
    "SimpleSkin/SimpleSkin.gltf",
    "RiggedSimple/RiggedSimple.glb",
    "CesiumMan/CesiumMan.glb",
    "SimpleMorph/SimpleMorph.gltf",
    "AnimatedMorphCube/AnimatedMorphCube.glb",
    "MorphStressTest/MorphStressTest.glb",
];

#[test]
fn posed_scene_matches_the_skinning_and_morphing_reference() {
    for rel in DEFORMED_SAMPLES {
        let s = load(rel);
        assert!(s.is_animated(), "{rel} is animated");
        let all = s.select_animations(&AnimationSelection::All).unwrap();
        let duration = s.animation_duration(&all);
        assert!(duration > 0.0, "{rel}");
        let scale = s.bounds.diagonal();
        let mut moved = 0.0f32;
        for f in [0.0, 0.3, 0.55, 0.9] {
            let time = f * duration;
            let posed = s.posed(&all, time);
            for k in 0..s.instances.len() {
                let want = reference_positions(&s, k, time);
                let inst = &posed.instances[k];
                let g = &posed.geometries[inst.geometry as usize];
                assert_eq!(g.positions.len(), want.len());
                for (v, (p, w)) in g.positions.iter().zip(&want).enumerate() {
                    let got = inst.transform.transform_point3(*p);
                    assert!(
                        (got - *w).length() <= 1e-5 * scale,
                        "{rel} t={time} instance {k} vertex {v}: {got} vs {w}"
                    );
                    let rest = s.instances[k].transform.transform_point3(
                        s.geometries[s.instances[k].geometry as usize].positions[v],
                    );
                    moved = moved.max((got - rest).length() / scale);
                }
                for n in &g.normals {
                    assert!((n.length() - 1.0).abs() < 1e-4, "{rel}: unit normals");
                }
            }
        }
        assert!(
            moved > 1e-3,
            "{rel}: the animation moves vertices ({moved})"
        );
    }
}

#[test]
fn skinned_normals_follow_a_rotated_joint() {
    // RiggedSimple bends: after posing, every normal must still be perpendicular to the
    // triangle it belongs to up to smooth-shading spread: compare with face normals.
    let s = load("RiggedSimple/RiggedSimple.glb");
    let all = s.select_animations(&AnimationSelection::All).unwrap();
    let posed = s.posed(&all, 0.5 * s.animation_duration(&all));
    let g = &posed.geometries[posed.instances[0].geometry as usize];
    let mut agree = 0usize;
    for t in g.indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| g.positions[i as usize]);
        let face = (b - a).cross(c - a).normalize_or_zero();
        if face == Vec3::ZERO {
            continue;
        }
        let n = (g.normals[t[0] as usize] + g.normals[t[1] as usize] + g.normals[t[2] as usize])
            .normalize_or_zero();
        if n.dot(face) > 0.5 {
            agree += 1;
        }
    }
    let total = g.triangle_count();
    assert!(
        agree * 10 >= total * 9,
        "{agree} of {total} triangles have normals on their face's side"
    );
}

#[test]
fn gpu_skinning_matches_the_reference() {
    let ctx = support::gpu();
    for rel in DEFORMED_SAMPLES {
        let s = load(rel);
        let all = s.select_animations(&AnimationSelection::All).unwrap();
        let duration = s.animation_duration(&all);
        let scale = s.bounds.diagonal();
        let mut checked = 0usize;
        for k in 0..s.instances.len() {
            let inst = &s.instances[k];
            let g = &s.geometries[inst.geometry as usize];
            if !g.is_deformable() {
                continue;
            }
            let skin = s.rig.nodes[inst.node].skin.filter(|_| !g.joints.is_empty());
            let joint_count = skin.map_or(0, |si| s.rig.skins[si].joints.len());
            let mut pass = SkinningPass::new(&ctx, g, joint_count).unwrap();
            for f in [0.0, 0.35, 0.8] {
                let time = f * duration;
                let pose = s.rig.pose(&all, time);
                let (joints, weights) = s.instance_deformation(k, &pose);
                pass.update(joints.as_deref(), weights).unwrap();
                ctx.run("skin test", |cmd| {
                    pass.record(cmd, None);
                    Ok(())
                })
                .unwrap();
                let gpu = pass.read(&ctx).unwrap();
                // Skinned vertices come out in world space; morphed ones in object space.
                let to_world = match skin {
                    Some(_) => Mat4::IDENTITY,
                    None => pose.world[inst.node] * s.rig.instance_local[k],
                };
                let want = reference_positions(&s, k, time);
                for (v, (p, w)) in gpu.positions.iter().zip(&want).enumerate() {
                    let got = to_world.transform_point3(*p);
                    assert!(
                        (got - *w).length() <= 1e-5 * scale,
                        "{rel} t={time} instance {k} vertex {v}: GPU {got} vs reference {w}"
                    );
                }
                // Normals and tangents against the CPU deformation.
                let cpu = rqr::scene::deform::deform(g, joints.as_deref(), weights);
                for (v, (a, b)) in gpu.normals.iter().zip(&cpu.normals).enumerate() {
                    assert!(a.abs_diff_eq(*b, 1e-4), "{rel} normal {v}: {a} vs {b}");
                }
                assert_eq!(gpu.tangents.len(), cpu.tangents.len(), "{rel}");
                for (v, (a, b)) in gpu.tangents.iter().zip(&cpu.tangents).enumerate() {
                    assert!(a.abs_diff_eq(*b, 1e-4), "{rel} tangent {v}: {a} vs {b}");
                }
                checked += want.len();
            }
        }
        assert!(checked > 0, "{rel}: no deformed instance checked");
    }
    support::assert_validation_clean(&ctx);
}

/// `rqr render --frames` of an animated scene on both backends: the frames differ (the man
/// walks) and each backend's frame matches the other's.
#[test]
fn cli_renders_animated_frames_on_both_backends() {
    let dir = std::env::temp_dir().join(format!("rqr-anim-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = asset("CesiumMan/CesiumMan.glb");
    let mut frames = Vec::new();
    for backend in ["hw", "bvh"] {
        let out = dir.join(format!("{backend}.png"));
        let args = [
            "render",
            scene.to_str().unwrap(),
            "--frames",
            "2",
            "--fps",
            "2",
            "--width",
            "48",
            "--height",
            "48",
            "--backend",
            backend,
            "-o",
            out.to_str().unwrap(),
        ];
        let (o, _) = support::run_rqr(
            &args,
            &[("RQR_VALIDATION", "1"), ("RQR_NO_AUTOTUNE", "1")],
            std::time::Duration::from_secs(600),
        );
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let read = |k: u32| {
            image::open(dir.join(format!("{backend}_{k:04}.png")))
                .unwrap()
                .to_rgba8()
        };
        frames.push((read(0), read(1)));
    }
    let differ = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels().zip(b.pixels()).filter(|(x, y)| x != y).count()
    };
    let (hw, bvh) = (&frames[0], &frames[1]);
    assert!(
        differ(&hw.0, &hw.1) > 20,
        "frame 1 shows the animation moved on"
    );
    for (a, b) in [(&hw.0, &bvh.0), (&hw.1, &bvh.1)] {
        let d = rqr::render::image::metrics::compare(48, 48, a.as_raw(), b.as_raw());
        assert!(d.flip_mean < 0.01, "hw vs bvh frame: FLIP {}", d.flip_mean);
    }
    // Reuse between frames keeps one renderer updated in place (samples move with their
    // objects, tests/temporal/reproject_animated.rs); the per-frame rebuild, which replaces that
    // renderer, is refused with a clear error rather than rendered wrongly.
    let run = |extra: &[&str], name: &str| {
        let out = dir.join(name);
        let mut a = vec![
            "render",
            scene.to_str().unwrap(),
            "--width",
            "48",
            "--height",
            "48",
            "--frames",
            "2",
            "--reproject",
            "-o",
            out.to_str().unwrap(),
        ];
        a.extend_from_slice(extra);
        support::run_rqr(
            &a,
            &[("RQR_NO_AUTOTUNE", "1")],
            std::time::Duration::from_secs(120),
        )
        .0
    };
    for backend in ["hw", "bvh"] {
        let o = run(&["--backend", backend], &format!("r_{backend}.png"));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(dir.join(format!("r_{backend}_0001.png")).exists());
    }
    // A usage mistake (exit 2, as clap's), not a failed render.
    let o = run(&["--animation-update", "rebuild"], "rr.png");
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--animation-update refit"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn only_geometry_motion_counts_as_moving() {
    let s = load("BoxAnimated/BoxAnimated.glb");
    let all = s.select_animations(&AnimationSelection::All).unwrap();
    assert!(s.animation_moves_geometry(&all));
    assert!(!s.animation_moves_geometry(&[]));
    let s = load("InterpolationTest/InterpolationTest.glb");
    let step_scale = s
        .select_animations(&AnimationSelection::Name("Step Scale".into()))
        .unwrap();
    assert!(s.animation_moves_geometry(&step_scale));

    // A quad and an animated camera: only the camera moves.
    let mut b = scene_files::Builder::default();
    let mut doc = scene_files::quad_doc(&mut b, serde_json::json!({}));
    let times = b.floats(&[0.0, 1.0], "SCALAR");
    let moves = b.floats(&[0.0, 0.0, 3.0, 1.0, 0.0, 3.0], "VEC3");
    doc["scenes"] = serde_json::json!([{"nodes": [0, 1]}]);
    doc["nodes"] = serde_json::json!([{"mesh": 0}, {"camera": 0, "translation": [0, 0, 3]}]);
    doc["cameras"] =
        serde_json::json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
    doc["animations"] = serde_json::json!([{
        "samplers": [{"input": times, "output": moves}],
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}}],
    }]);
    let bytes = scene_files::bytes(&b.document(doc));
    let s = scene::load_slice(&bytes, None, "camera.gltf", &LoadOptions::default()).unwrap();
    let all = s.select_animations(&AnimationSelection::All).unwrap();
    assert!(!s.animation_moves_geometry(&all));
    let posed = s.posed(&all, 0.5);
    let eye = posed.cameras[0].camera_to_world.w_axis.truncate();
    assert!(
        eye.abs_diff_eq(Vec3::new(0.5, 0.0, 3.0), 1e-5),
        "animated camera at {eye}"
    );
}

#[test]
fn info_lists_animations_skins_and_morphs() {
    let (o, _) = support::run_rqr(
        &[
            "info",
            "--json",
            asset("CesiumMan/CesiumMan.glb").to_str().unwrap(),
        ],
        &[],
        std::time::Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["skins"], 1);
    assert_eq!(v["animations"].as_array().unwrap().len(), 1);
    assert!(v["animations"][0]["duration"].as_f64().unwrap() > 1.0);
    let (o, _) = support::run_rqr(
        &[
            "info",
            "--json",
            asset("MorphStressTest/MorphStressTest.glb")
                .to_str()
                .unwrap(),
        ],
        &[],
        std::time::Duration::from_secs(120),
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(v["morphed_geometries"].as_u64().unwrap() >= 1, "{v}");
}

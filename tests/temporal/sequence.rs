//! Camera paths of a sequence (orbit, dolly, a glTF camera animation) and `rqr render
//! --frames` end to end: frames, JSON lines, report and plot (the options it refuses are in
//! the bad-input binary, `cli_errors`).

use std::process::Command;

use glam::Vec3;
use rqr::render::drivers::sequence::{CameraAnimation, CameraPath, CameraPathSpec};
use rqr::scene::procedural::look_at;

#[test]
fn camera_paths() {
    let base = look_at(Vec3::new(0.0, 2.0, 8.0), Vec3::new(0.0, 1.0, 0.0), 40.0);
    let pivot = Vec3::new(0.0, 1.0, 0.0);
    let orbit = CameraPath::Orbit {
        degrees_per_frame: 0.5,
        pivot,
    };
    assert_eq!(orbit.camera(&base, 0), base);
    let c = orbit.camera(&base, 180);
    // 90 degrees counter-clockwise seen from above: +Z goes to +X; height and distance kept.
    assert!(
        (c.position() - Vec3::new(8.0, 2.0, 0.0)).length() < 1e-4,
        "{}",
        c.position()
    );
    let (f, b) = (c.forward(), base.forward());
    assert!((f.y - b.y).abs() < 1e-6, "the tilt is kept");
    assert!(
        (Vec3::new(f.x, 0.0, f.z).normalize() - Vec3::NEG_X).length() < 1e-5,
        "{f}"
    );
    let dolly = CameraPath::Dolly {
        distance_per_frame: 0.25,
    };
    let d = dolly.camera(&base, 4);
    assert!((d.position() - (base.position() + base.forward())).length() < 1e-5);
    assert_eq!(d.forward(), base.forward());

    assert_eq!(
        "orbit:0.5".parse::<CameraPathSpec>(),
        Ok(CameraPathSpec::Orbit(0.5))
    );
    assert_eq!(
        "dolly:-1".parse::<CameraPathSpec>(),
        Ok(CameraPathSpec::Dolly(-1.0))
    );
    assert_eq!("gltf".parse::<CameraPathSpec>(), Ok(CameraPathSpec::Gltf));
    for bad in ["orbit", "orbit:x", "dolly:inf", "spin:1", ""] {
        assert!(bad.parse::<CameraPathSpec>().is_err(), "{bad}");
    }
}

/// A glTF file with a triangle and a camera node, with or without an animation of it.
fn camera_gltf(dir: &std::path::Path, animated: bool) -> std::path::PathBuf {
    // Buffer: 3 positions (36 bytes), times [0, 1] (8), translations (24), rotations (32).
    let mut bytes: Vec<u8> = Vec::new();
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for v in [0.0f32, 1.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 5.0, 2.0, 0.0, 5.0] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let half = std::f32::consts::FRAC_PI_4.sin(); // 90 degrees about +Y at t = 1
    for v in [0.0f32, 0.0, 0.0, 1.0, 0.0, half, 0.0, half] {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let bin = if animated {
        "animated.bin"
    } else {
        "still.bin"
    };
    std::fs::write(dir.join(bin), &bytes).unwrap();
    let uri = bin;
    let animations = if animated {
        r#","animations": [{"channels": [
            {"sampler": 0, "target": {"node": 1, "path": "translation"}},
            {"sampler": 1, "target": {"node": 1, "path": "rotation"}}],
          "samplers": [{"input": 1, "output": 2}, {"input": 1, "output": 3}]}]"#
    } else {
        ""
    };
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
          "nodes": [{{"mesh": 0}}, {{"camera": 0, "translation": [0, 0, 5]}}],
          "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "znear": 0.01}}}}],
          "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
          "buffers": [{{"byteLength": {len}, "uri": "{uri}"}}],
          "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}},
                          {{"buffer": 0, "byteOffset": 36, "byteLength": 8}},
                          {{"buffer": 0, "byteOffset": 44, "byteLength": 24}},
                          {{"buffer": 0, "byteOffset": 68, "byteLength": 32}}],
          "accessors": [
            {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
            {{"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]}},
            {{"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}},
            {{"bufferView": 3, "componentType": 5126, "count": 2, "type": "VEC4"}}]
          {animations}}}"#,
        len = bytes.len()
    );
    let path = dir.join(if animated {
        "animated.gltf"
    } else {
        "still.gltf"
    });
    std::fs::write(&path, json).unwrap();
    path
}

fn temp_dir(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("rqr-sequence-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn gltf_camera_animation() {
    let dir = temp_dir("anim");
    let file = camera_gltf(&dir, true);
    let scene = rqr::scene::load(&file, &Default::default()).unwrap();
    assert_eq!(scene.cameras.len(), 1);
    let base = scene.cameras[0];
    let anim = CameraAnimation::load(&file, None, 0, 4.0).unwrap();
    let path = CameraPath::Animation(Box::new(anim));
    let c0 = path.camera(&base, 0);
    assert!((c0.position() - Vec3::new(0.0, 0.0, 5.0)).length() < 1e-5);
    assert!((c0.forward() - Vec3::NEG_Z).length() < 1e-5);
    // Frame 2 at 4 fps: t = 0.5, halfway (linear translation, slerped rotation).
    let c2 = path.camera(&base, 2);
    assert!(
        (c2.position() - Vec3::new(1.0, 0.0, 5.0)).length() < 1e-5,
        "{}",
        c2.position()
    );
    let expected = Vec3::new(
        -(45f32.to_radians().sin()),
        0.0,
        -(45f32.to_radians().cos()),
    );
    assert!(
        (c2.forward() - expected).length() < 1e-4,
        "{}",
        c2.forward()
    );
    // After the last key the animation holds.
    let c9 = path.camera(&base, 9);
    assert!((c9.position() - Vec3::new(2.0, 0.0, 5.0)).length() < 1e-5);
    assert!(
        (c9.forward() - Vec3::NEG_X).length() < 1e-4,
        "{}",
        c9.forward()
    );
    assert_eq!(c9.projection, base.projection);

    let still = camera_gltf(&dir, false);
    let e = CameraAnimation::load(&still, None, 0, 24.0).unwrap_err();
    assert!(
        e.to_string().contains("scene has no camera animation"),
        "{e}"
    );
    let e = CameraAnimation::load(&file, None, 3, 24.0).unwrap_err();
    assert!(e.to_string().contains("camera 3 does not exist"), "{e}");
    let e = CameraAnimation::load(&file, None, 0, 0.0).unwrap_err();
    assert!(e.to_string().contains("--fps"), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

fn rqr(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_rqr"))
        .args(args)
        .env("VK_LOADER_DEBUG", "none")
        .env("RQR_NO_AUTOTUNE", "1")
        .output()
        .unwrap()
}

#[test]
fn cli_sequence_writes_frames_and_json_lines() {
    let dir = temp_dir("cli");
    let out = dir.join("seq.png");
    let out_s = out.to_str().unwrap();
    let report = dir.join("report.md");
    let plot = dir.join("plot.png");
    let o = rqr(&[
        "render",
        "--width",
        "32",
        "--height",
        "32",
        "--frames",
        "4",
        "--frame-range",
        "1..4",
        "--camera-path",
        "orbit:1",
        "--reproject",
        "--reference",
        "--json",
        "-o",
        out_s,
        "--report",
        report.to_str().unwrap(),
        "--plot",
        plot.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{}\n{stdout}",
        String::from_utf8_lossy(&o.stderr)
    );
    let lines: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 4, "{stdout}");
    for (i, l) in lines[..3].iter().enumerate() {
        assert_eq!(l["type"], "frame");
        assert_eq!(l["frame"], i as u64 + 1);
        let r = &l["reuse"];
        let sum = r["reused"].as_u64().unwrap()
            + r["traced"].as_u64().unwrap()
            + r["interpolated"].as_u64().unwrap();
        assert_eq!(sum, 32 * 32);
        assert!(l["reference"]["flip_mean"].as_f64().unwrap() < 0.1);
        assert!(l["rays"]["primary"].as_u64().is_some());
        assert!(l["gpu_ms"].is_object());
    }
    // The range starts from an empty cache.
    assert_eq!(lines[0]["reuse"]["traced"], 32 * 32);
    assert!(lines[2]["reuse"]["reused"].as_u64().unwrap() > 0);
    assert_eq!(lines[3]["type"], "summary");
    for k in 1..4 {
        let f = dir.join(format!("seq_{k:04}.png"));
        assert!(f.exists(), "{} missing", f.display());
    }
    assert!(!dir.join("seq_0000.png").exists());
    assert!(std::fs::read_to_string(&report).unwrap().contains("| 3 |"));
    assert!(image::open(&plot).is_ok());

    let _ = std::fs::remove_dir_all(&dir);
}

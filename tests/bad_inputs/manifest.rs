//! Bad `rqr batch` manifest lines: each fails alone with an error naming the manifest line
//! and the field, through the library parser and through the binary (where the good job of
//! the same manifest is still rendered). Every case is also a seed of the `parse_manifest`
//! fuzz target (`fuzz/seeds_manifest/<case>.jsonl`).

use std::path::Path;

use rqr::batch::manifest::{self, Entry, JobFields};

/// A good line every case is checked next to.
const GOOD: &str = r#"{"id": "good", "scene": "Box.glb", "width": 16, "height": 16, "cameras": {"orbit": {"n": 1}}}"#;

/// (case name, line, field named in the error, text the error contains).
pub const CASES: &[(&str, &str, Option<&str>, &str)] = &[
    ("not_json", "{\"id\": \"a\",", None, "not JSON"),
    (
        "not_an_object",
        "[1, 2]",
        Some("(line)"),
        "expected a JSON object",
    ),
    (
        "unknown_field",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "resolution": 4}"#,
        Some("resolution"),
        "unknown field `resolution`",
    ),
    (
        "missing_scene_field",
        r#"{"id": "a", "cameras": {"orbit": {"n": 1}}}"#,
        Some("scene"),
        "missing",
    ),
    (
        "duplicate_id",
        r#"{"id": "good", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}}"#,
        Some("id"),
        "duplicate id 'good' (first used on line 1)",
    ),
    (
        "id_escapes_output",
        r#"{"id": "../etc", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}}"#,
        Some("id"),
        "cannot be in a directory name",
    ),
    (
        "camera_scaled",
        r#"{"id": "a", "scene": "Box.glb", "cameras": [{"c2w": [[2,0,0,0],[0,2,0,0],[0,0,2,0],[0,0,0,1]]}]}"#,
        Some("cameras[0].c2w"),
        "not a rigid transform",
    ),
    (
        "camera_mirrored",
        r#"{"id": "a", "scene": "Box.glb", "cameras": [{"c2w": [[-1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]}"#,
        Some("cameras[0].c2w"),
        "mirror",
    ),
    (
        "camera_projective",
        r#"{"id": "a", "scene": "Box.glb", "cameras": [{"c2w": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,1,1]]}]}"#,
        Some("cameras[0].c2w"),
        "last row",
    ),
    (
        "camera_without_pose",
        r#"{"id": "a", "scene": "Box.glb", "cameras": [{"fov_y_deg": 30}]}"#,
        Some("cameras[0]"),
        "needs `c2w` or `look_from`",
    ),
    (
        "orbit_no_views",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 0}}}"#,
        Some("cameras.orbit.n"),
        "outside",
    ),
    (
        "fov_out_of_range",
        r#"{"id": "a", "scene": "Box.glb", "cameras": [{"look_from": [0,0,3], "look_at": [0,0,0], "fov_y_deg": 180}]}"#,
        Some("cameras[0].fov_y_deg"),
        "outside (0, 180)",
    ),
    (
        "width_wrong_type",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "width": "big"}"#,
        Some("width"),
        "invalid type",
    ),
    (
        "width_zero",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "width": 0}"#,
        Some("width"),
        "outside 1..=",
    ),
    (
        "unknown_mode",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "mode": "raster"}"#,
        Some("mode"),
        "unknown variant `raster`",
    ),
    (
        "unsupported_shading",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "shading": "path"}"#,
        Some("shading"),
        "not supported by this build",
    ),
    (
        "environment_not_a_path",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "environment": 7}"#,
        Some("environment"),
        "must be null",
    ),
    (
        "unknown_aov",
        r#"{"id": "a", "scene": "Box.glb", "cameras": {"orbit": {"n": 1}}, "aovs": ["albedo", "emission"]}"#,
        Some("aovs[1]"),
        "unknown AOV 'emission'",
    ),
    (
        "late_defaults",
        r#"{"defaults": {"width": 8}}"#,
        Some("defaults"),
        "only be given on the first line",
    ),
];

fn manifest_text(line: &str) -> String {
    format!("{GOOD}\n{line}\n")
}

fn seed_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/seeds_manifest")
}

#[test]
fn bad_manifest_lines_name_line_and_field() {
    for (name, line, field, needle) in CASES {
        let entries = manifest::parse(
            &manifest_text(line),
            "m.jsonl",
            Path::new("."),
            &JobFields::default(),
        );
        assert!(
            matches!(entries[0], Entry::Job(_)),
            "{name}: the good line must stay good"
        );
        let Entry::Invalid { error, .. } = &entries[1] else {
            panic!("{name}: accepted: {:?}", entries[1]);
        };
        assert_eq!(error.line, 2, "{name}");
        assert_eq!(error.field.as_deref(), *field, "{name}: {error}");
        let text = error.to_string();
        assert!(text.starts_with("m.jsonl:2: "), "{name}: {text}");
        assert!(text.contains(needle), "{name}: {text}");
    }
}

/// `RQR_WRITE_SEEDS=1` (re)writes the seeds after the cases changed.
#[test]
fn manifest_cases_are_fuzz_seeds() {
    let write = std::env::var_os("RQR_WRITE_SEEDS").is_some();
    let mut missing = Vec::new();
    for (name, line, _, _) in CASES {
        let seed = seed_dir().join(format!("{name}.jsonl"));
        let text = manifest_text(line);
        if write {
            std::fs::write(&seed, &text).unwrap();
        }
        if std::fs::read_to_string(&seed).ok().as_deref() != Some(text.as_str()) {
            missing.push(seed.display().to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "fuzz seeds missing or stale (RQR_WRITE_SEEDS=1 rewrites them): {missing:?}"
    );
}

#[test]
fn every_bad_line_fails_alone_in_the_binary() {
    let dir = crate::work_dir("manifest");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/gltf/Box/Box.glb"),
        dir.join("Box.glb"),
    )
    .unwrap();
    let mut text = format!("{GOOD}\n");
    for (_, line, _, _) in CASES {
        text.push_str(line);
        text.push('\n');
    }
    // A scene that does not exist fails when its job runs, naming the file.
    text.push_str(r#"{"id": "gone", "scene": "missing.glb", "cameras": {"orbit": {"n": 1}}}"#);
    text.push('\n');
    let path = dir.join("m.jsonl");
    std::fs::write(&path, text).unwrap();
    let out = dir.join("out");
    let (output, _) = crate::rqr(
        &[
            "batch",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ],
        crate::RENDER_LIMIT,
    );
    crate::no_panic_or_validation("rqr batch", &output);
    assert_eq!(output.status.code(), Some(1));
    assert!(
        out.join("good/000.png").is_file(),
        "the good job was not rendered"
    );
    let results = std::fs::read_to_string(out.join("results-0-of-1.jsonl")).unwrap();
    let lines: Vec<serde_json::Value> = results
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), CASES.len() + 2);
    for (k, (name, _, field, needle)) in CASES.iter().enumerate() {
        let r = &lines[k + 1];
        assert_eq!(r["status"], "failed", "{name}");
        let e = r["error"].as_str().unwrap();
        assert!(e.contains(&format!("m.jsonl:{}: ", k + 2)), "{name}: {e}");
        if let Some(f) = field {
            assert!(e.contains(&format!("field `{f}`")), "{name}: {e}");
        }
        assert!(e.contains(needle), "{name}: {e}");
    }
    let gone = lines.last().unwrap();
    assert_eq!(gone["status"], "failed");
    assert!(
        gone["error"].as_str().unwrap().contains("missing.glb"),
        "{gone}"
    );
}

/// What the `parse_manifest` fuzz target asserts, on every seed (and on cut-off seeds): one
/// entry per line, every error naming its own line.
#[test]
fn the_fuzz_targets_invariant_holds_on_its_seeds() {
    for entry in std::fs::read_dir(seed_dir()).unwrap().flatten() {
        let text = std::fs::read_to_string(entry.path()).unwrap();
        for cut in [text.len(), text.len() / 2, text.len() / 3] {
            let Some(text) = text.get(..cut) else {
                continue;
            };
            let entries =
                manifest::parse(text, "fuzz.jsonl", Path::new("."), &JobFields::default());
            assert_eq!(entries.len(), text.lines().count());
            for (k, e) in entries.iter().enumerate() {
                if let Entry::Invalid { error, .. } = e {
                    let prefix = format!("fuzz.jsonl:{}: ", k + 1);
                    assert!(error.to_string().starts_with(&prefix), "{error}");
                }
            }
        }
    }
}

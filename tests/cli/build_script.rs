//! `build.rs` on its own (it needs only std, so rustc compiles it in about a second): with no
//! environment but `PATH` it compiles every shader to the same SPIR-V the crate embeds, so a
//! plain `cargo build` needs nothing sourced; and without a shader compiler it fails
//! with one line naming `scripts/setup-vulkan.sh`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("rqr-test-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Compiles `build.rs` into `dir/build-script`.
fn compile_build_script(dir: &Path) -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let exe = dir.join("build-script");
    let out = Command::new(std::env::var_os("RUSTC").unwrap_or_else(|| "rustc".into()))
        .args([
            "--edition=2021",
            "--crate-type=bin",
            "--crate-name=build_script",
        ])
        .arg(root.join("build.rs"))
        .arg("-o")
        .arg(&exe)
        .output()
        .expect("running rustc");
    assert!(
        out.status.success(),
        "rustc build.rs: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    exe
}

/// Runs the build script with an empty environment plus `vars`.
fn run_build_script(exe: &Path, out_dir: &Path, vars: &[(&str, &str)]) -> std::process::Output {
    let mut cmd = Command::new(exe);
    cmd.env_clear()
        .env("CARGO_MANIFEST_DIR", env!("CARGO_MANIFEST_DIR"))
        .env("OUT_DIR", out_dir);
    for (k, v) in vars {
        cmd.env(k, v);
    }
    cmd.output().expect("running the build script")
}

#[test]
fn build_script_needs_only_path_and_embeds_what_it_compiles() {
    let dir = tmpdir("build-script");
    let exe = compile_build_script(&dir);
    let out_dir = dir.join("out");
    std::fs::create_dir_all(&out_dir).unwrap();
    let path = std::env::var("PATH").unwrap_or_default();
    let out = run_build_script(&exe, &out_dir, &[("PATH", &path)]);
    assert!(
        out.status.success(),
        "build script without environment: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let generated = std::fs::read_to_string(out_dir.join("shaders.rs")).unwrap();
    let spv: Vec<PathBuf> = std::fs::read_dir(&out_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "spv"))
        .collect();
    assert!(spv.len() >= 20, "only {} SPIR-V files", spv.len());
    assert_eq!(generated.matches("pub const ").count(), spv.len());
    for p in &spv {
        let bytes = std::fs::read(p).unwrap();
        assert_eq!(
            &bytes[..4],
            &0x0723_0203u32.to_le_bytes(),
            "{}",
            p.display()
        );
    }
    // The same compiler and flags as the build that produced this test binary's crate.
    for (embedded, file) in [
        (rqr::shaders::RAYTRACE_COMP_HW, "raytrace.comp_hw.spv"),
        (rqr::shaders::RAYTRACE_COMP_BVH, "raytrace.comp_bvh.spv"),
        (rqr::shaders::GBUFFER_VERT, "gbuffer.vert.spv"),
        (rqr::shaders::TONEMAP_COMP, "tonemap.comp.spv"),
    ] {
        assert!(
            embedded == std::fs::read(out_dir.join(file)).unwrap().as_slice(),
            "{file} differs from the embedded SPIR-V"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn build_script_without_compiler_fails_with_one_line_naming_setup() {
    let dir = tmpdir("build-script-no-glslc");
    let exe = compile_build_script(&dir);
    let out = run_build_script(&exe, &dir, &[("GLSLC", "/nonexistent/glslc")]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.trim().lines().count(), 1, "{stderr}");
    assert!(stderr.contains("scripts/setup-vulkan.sh"), "{stderr}");
    assert!(stderr.contains("/nonexistent/glslc"), "{stderr}");
    assert!(!dir.join("shaders.rs").exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

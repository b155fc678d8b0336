//! Compiles every shader in `shaders/` to SPIR-V (GLSL 460, Vulkan 1.2, SPIR-V 1.4) and writes
//! `$OUT_DIR/shaders.rs` with one `include_bytes!` constant per compiled variant.
//!
//! A shader whose first line is `// variants: A B` is compiled once per name with
//! `#define RAY_BACKEND_A` (etc.) and gets constants `NAME_EXT_A`, `NAME_EXT_B`.
//! `#include "x.glsl"` resolves against `shaders/common/`, then `shaders/`, then the generated
//! interface headers: `build/interface.rs` translates every `src/interface/NAME.rs`
//! (binding numbers, flags, counter slots, push-constant and uniform structs) into
//! `$OUT_DIR/glsl/interface_NAME.glsl`, so the Rust file is the one source of both sides.
//!
//! The compiler is the `glslc` executable (shaderc's command-line front end; `$GLSLC` or `PATH`),
//! not the `shaderc` crate: that crate's `shaderc-sys` build script picks a native library from
//! the environment at its first build and never re-runs when the environment changes, so one
//! `cargo build` without `SHADERC_LIB_DIR` linked Debian's incomplete `libshaderc.so` into the
//! target directory for good. An executable found at every build cannot leave such a state
//! behind, and a missing one fails here with one line naming the setup script. Debian 12's
//! glslc is the same shaderc 2023.2 the crate linked, and produces byte-identical SPIR-V.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

#[path = "build/interface.rs"]
mod interface;

fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            walk(&path, out);
        } else {
            out.push(path);
        }
    }
}

/// Folder of the generated interface headers, relative to OUT_DIR.
const GENERATED_INCLUDE_DIR: &str = "glsl";

/// One compilation: a shader file, optionally with a ray backend variant.
struct Job {
    rel: String,
    variant: Option<String>,
    spv: PathBuf,
    ident: String,
    file: String,
}

fn main() {
    let root = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let shader_dir = root.join("shaders");
    let out_dir = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    println!("cargo:rerun-if-changed=shaders");
    println!("cargo:rerun-if-env-changed=GLSLC");
    println!("cargo:rerun-if-changed=build/interface.rs");
    let glslc = std::env::var_os("GLSLC").unwrap_or_else(|| "glslc".into());
    let generated_dir = out_dir.join(GENERATED_INCLUDE_DIR);
    let interface_headers = interface::generate(&root, &generated_dir);

    let mut files = Vec::new();
    walk(&shader_dir, &mut files);
    files.sort();
    for f in &files {
        println!("cargo:rerun-if-changed={}", f.display());
    }

    let mut jobs = Vec::new();
    for path in &files {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(ext, "comp" | "vert" | "frag") {
            continue;
        }
        let source = std::fs::read_to_string(path).unwrap();
        let rel = path.strip_prefix(&root).unwrap().display().to_string();
        let stem = path.file_stem().unwrap().to_str().unwrap();
        let variants: Vec<String> = source
            .lines()
            .next()
            .and_then(|l| l.trim().strip_prefix("// variants:"))
            .map(|v| v.split_whitespace().map(str::to_string).collect())
            .unwrap_or_default();
        let runs: Vec<Option<String>> = if variants.is_empty() {
            vec![None]
        } else {
            variants.into_iter().map(Some).collect()
        };
        for variant in runs {
            let suffix = variant
                .as_deref()
                .map(|v| format!("_{v}"))
                .unwrap_or_default();
            let file = format!("{stem}.{ext}{suffix}.spv");
            let ident = format!("{stem}_{ext}{suffix}")
                .to_uppercase()
                .replace(['-', '.'], "_");
            jobs.push(Job {
                rel: rel.clone(),
                variant,
                spv: out_dir.join(&file),
                ident,
                file,
            });
        }
    }

    let spawn = |job: &Job| -> Child {
        // Run in OUT_DIR and name the generated headers' folder relatively: `-g` records every
        // include's path in the SPIR-V, and `glsl/…` is the same for every OUT_DIR (the SPIR-V
        // does not depend on where the build puts it; tests/build_script.rs compares).
        let mut cmd = Command::new(&glslc);
        cmd.current_dir(&out_dir)
            .args(["--target-env=vulkan1.2", "--target-spv=spv1.4", "-g", "-O"])
            .arg("-I")
            .arg(shader_dir.join("common"))
            .arg("-I")
            .arg(&shader_dir)
            .arg("-I")
            .arg(GENERATED_INCLUDE_DIR);
        if let Some(v) = &job.variant {
            cmd.arg(format!("-DRAY_BACKEND_{}=1", v.to_uppercase()));
        }
        cmd.arg(root.join(&job.rel))
            .arg("-o")
            .arg(&job.spv)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        match cmd.spawn() {
            Ok(child) => child,
            Err(e) => {
                eprintln!(
                    "rqr: cannot run the shader compiler '{}' ({e}): run scripts/setup-vulkan.sh (Debian 12), or install glslc (Vulkan SDK / shaderc) and put it on PATH or in $GLSLC",
                    Path::new(&glslc).display()
                );
                std::process::exit(1);
            }
        }
    };

    // glslc is single-threaded: run as many at once as there are cores.
    let parallel = std::thread::available_parallelism().map_or(2, |n| n.get());
    let mut generated =
        String::from("// Generated by build.rs: SPIR-V of every shader under shaders/.\n");
    let mut failures = Vec::new();
    for chunk in jobs.chunks(parallel) {
        let children: Vec<Child> = chunk.iter().map(spawn).collect();
        for (job, child) in chunk.iter().zip(children) {
            let out = child.wait_with_output().expect("waiting for glslc");
            let messages = String::from_utf8_lossy(&out.stderr).trim().to_string();
            let label = format!(
                "{}{}",
                job.rel,
                job.variant
                    .as_deref()
                    .map(|v| format!(" [{v}]"))
                    .unwrap_or_default()
            );
            if !out.status.success() {
                failures.push(format!("{label}: {messages}"));
                continue;
            }
            if !messages.is_empty() {
                println!("cargo:warning={label}: {}", messages.replace('\n', " | "));
            }
            writeln!(
                generated,
                "/// SPIR-V of `{}`{}.\npub const {}: &[u8] = include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{}\"));",
                job.rel,
                job.variant.as_deref().map(|v| format!(" (RAY_BACKEND_{})", v.to_uppercase())).unwrap_or_default(),
                job.ident,
                job.file,
            )
            .unwrap();
        }
    }
    if !failures.is_empty() {
        for f in &failures {
            eprintln!("shader error: {f}");
        }
        panic!(
            "{} shader(s) failed to compile:\n{}",
            failures.len(),
            failures.join("\n")
        );
    }
    // The headers' text goes into a file of its own: shaders.rs holds exactly one constant per
    // compiled SPIR-V.
    let mut headers = String::from(
        "/// The generated interface headers (`$OUT_DIR/glsl`): file name and GLSL text.\npub const INTERFACE_GLSL: &[(&str, &str)] = &[\n",
    );
    for name in &interface_headers {
        writeln!(
            headers,
            "    (\"{name}\", include_str!(concat!(env!(\"OUT_DIR\"), \"/glsl/{name}\"))),"
        )
        .unwrap();
    }
    headers.push_str("];\n");
    std::fs::write(out_dir.join("interface_glsl.rs"), headers).unwrap();
    std::fs::write(out_dir.join("shaders.rs"), generated).unwrap();
}

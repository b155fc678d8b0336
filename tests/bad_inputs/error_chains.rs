//! Error messages never repeat a clause: an error whose message interpolates its own
//! `source` prints the cause twice once a printer walks the chain (`rqr: error:` does, as
//! anyhow's `{:#}`). Checked through the scene loader's file errors (missing file, a
//! directory, a permission error), through the binary's top-level printer for the same three
//! paths, and over every `#[error(...)]` in `src/`.

use crate::support;

use std::error::Error as _;
use std::io::ErrorKind;
use std::path::{Path, PathBuf};
use std::time::Duration;

use rqr::scene::{self, LoadOptions, SceneError};

/// A file that even root cannot read: procfs sysctls are checked against their mode bits for
/// every user, root included (`proc_sys_permission`), and `drop_caches` is write-only
/// (`--w-------`), so opening it for reading fails with `EACCES`. `chmod 000` on a file of our
/// own would not do: root (the CI containers run as root) bypasses it.
const UNREADABLE_EVEN_FOR_ROOT: &str = "/proc/sys/vm/drop_caches";

/// Environment in which any Vulkan use fails (the scene is read before a device is opened).
const NO_VULKAN: &[(&str, &str)] = &[
    ("VK_DRIVER_FILES", "/nonexistent/icd.json"),
    ("VK_ICD_FILENAMES", "/nonexistent/icd.json"),
];

fn tmp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rqr-chain-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The three unreadable scene paths, with the error kind each must give.
fn unreadable_paths(dir: &Path) -> Vec<(PathBuf, ErrorKind)> {
    let folder = dir.join("a-folder.glb");
    std::fs::create_dir_all(&folder).unwrap();
    let denied = PathBuf::from(UNREADABLE_EVEN_FOR_ROOT);
    // Not skipped where the trick does not work: the test would then prove nothing.
    assert_eq!(
        std::fs::read(&denied).map_err(|e| e.kind()).err(),
        Some(ErrorKind::PermissionDenied),
        "{UNREADABLE_EVEN_FOR_ROOT} must be unreadable here (is /proc mounted?)"
    );
    vec![
        (dir.join("missing.glb"), ErrorKind::NotFound),
        (folder, ErrorKind::IsADirectory),
        (denied, ErrorKind::PermissionDenied),
    ]
}

/// Every message of `e`'s chain, outermost first.
fn chain(e: &(dyn std::error::Error + 'static)) -> Vec<String> {
    let mut out = vec![e.to_string()];
    let mut cause = e.source();
    while let Some(c) = cause {
        out.push(c.to_string());
        cause = c.source();
    }
    out
}

/// No link of the chain contains its cause's message, and the printed line (`a: b: c`) has
/// no clause twice.
fn assert_no_repeated_clause(links: &[String], line: &str) {
    for pair in links.windows(2) {
        assert!(
            !pair[0].contains(&pair[1]),
            "'{}' repeats its source '{}'",
            pair[0],
            pair[1]
        );
    }
    let clauses: Vec<&str> = line.split(": ").collect();
    for (i, c) in clauses.iter().enumerate() {
        assert!(
            !clauses[i + 1..].contains(c),
            "clause '{c}' appears twice in: {line}"
        );
    }
}

#[test]
fn loader_file_errors_carry_the_os_error_once() {
    let dir = tmp_dir("loader");
    for (path, kind) in unreadable_paths(&dir) {
        let e = scene::load(&path, &LoadOptions::default()).unwrap_err();
        let shown = path.display().to_string();
        assert!(
            matches!(&e, SceneError::Io { file, .. } if *file == shown),
            "{e:?}"
        );
        let links = chain(&e);
        assert_eq!(links.len(), 2, "{links:?}");
        assert_eq!(links[0], format!("{shown}: cannot read"));
        let os = e
            .source()
            .and_then(|s| s.downcast_ref::<std::io::Error>())
            .expect("the OS error is the source");
        assert_eq!(os.kind(), kind, "{shown}");
        let line = rqr::error_chain(&e);
        assert_eq!(line, format!("{shown}: cannot read: {os}"));
        assert_no_repeated_clause(&links, &line);
        // Through the library's error type (transparent), the same chain.
        let wrapped = rqr::Error::from(e);
        assert_eq!(rqr::error_chain(&wrapped), line);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_injected_permission_error_prints_once() {
    let e = SceneError::Io {
        file: "lamp.glb".into(),
        source: std::io::Error::from(ErrorKind::PermissionDenied),
    };
    let line = rqr::error_chain(&e);
    assert_eq!(line, "lamp.glb: cannot read: permission denied");
    assert_no_repeated_clause(&chain(&e), &line);
    let cache = rqr::device_select::autotune::CacheError::Io {
        path: "autotune.json".into(),
        source: std::io::Error::from(ErrorKind::PermissionDenied),
    };
    let line = rqr::error_chain(&cache);
    assert_eq!(
        line,
        "autotune.json: cannot read or write the autotune cache: permission denied"
    );
    assert_no_repeated_clause(&chain(&cache), &line);
}

#[test]
fn the_cli_prints_each_file_error_clause_once() {
    let dir = tmp_dir("cli");
    for (path, _) in unreadable_paths(&dir) {
        let shown = path.display().to_string();
        let os = std::fs::read(&path).unwrap_err().to_string();
        for command in ["render", "info"] {
            let args = [command, shown.as_str()];
            let (out, _) = support::run_rqr(&args, NO_VULKAN, Duration::from_secs(30));
            let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
            assert_eq!(out.status.code(), Some(1), "rqr {args:?}: {stderr}");
            let lines: Vec<&str> = stderr.lines().collect();
            assert_eq!(
                lines,
                [format!("rqr: error: {shown}: cannot read: {os}")],
                "rqr {args:?}"
            );
            assert_eq!(stderr.matches(&os).count(), 1, "{stderr}");
            assert_no_repeated_clause(&[], lines[0]);
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The fields of the variant or struct an `#[error(...)]` at `start` describes: the text up
/// to the next `#[error` or the end of the item (a `}` at the start of a line).
fn described_fields(text: &str, start: usize) -> &str {
    let rest = &text[start + 1..];
    let end = [rest.find("#[error"), rest.find("\n}")]
        .into_iter()
        .flatten()
        .min()
        .unwrap_or(rest.len());
    &rest[..end]
}

/// The names thiserror takes as the source among `fields`: a field named `source`, and one
/// marked `#[source]` or `#[from]` (`0` for a tuple field).
fn source_fields(fields: &str) -> Vec<String> {
    let mut names = Vec::new();
    if fields.contains("source:") {
        names.push("source".to_string());
    }
    for marker in ["#[source]", "#[from]"] {
        for (at, _) in fields.match_indices(marker) {
            let after = fields[at + marker.len()..].trim_start();
            let ident: String = after
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            let tail = after[ident.len()..].trim_start();
            let named = tail.starts_with(':') && !tail.starts_with("::");
            names.push(if named { ident } else { "0".to_string() });
        }
    }
    names.sort();
    names.dedup();
    names
}

#[test]
fn no_error_message_in_src_interpolates_its_source() {
    let mut files = Vec::new();
    let mut stack = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join("src")];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap().flatten() {
            let p = entry.path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|e| e == "rs") {
                files.push(p);
            }
        }
    }
    let mut seen = 0;
    let mut offenders = Vec::new();
    for file in files {
        let text = std::fs::read_to_string(&file).unwrap();
        for (at, _) in text.match_indices("#[error(") {
            seen += 1;
            let attr_end = text[at..].find(")]").map_or(text.len(), |e| at + e);
            let message = &text[at..attr_end];
            if message.contains("transparent") {
                continue;
            }
            let fields = described_fields(&text, at);
            // A message naming its own source prints the cause twice in a chain.
            for name in source_fields(fields) {
                if message.contains(&format!("{{{name}}}"))
                    || message.contains(&format!("{{{name}:"))
                {
                    offenders.push(format!(
                        "{}: {message})] names its source '{name}'",
                        file.display()
                    ));
                }
            }
        }
    }
    assert!(seen >= 20, "only {seen} #[error] attributes found");
    assert!(offenders.is_empty(), "{}", offenders.join("\n"));
}

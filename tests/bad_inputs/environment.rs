//! Broken environment maps (`--environment`): each fails with one clear error naming the file,
//! through the library and through `rqr render`, never a panic or a hang.

use rqr::environment::map::{self, EnvironmentMap};
use rqr::environment::EnvironmentSource;

/// A Radiance header for `width` x `height` (flat or RLE pixels follow).
fn hdr_header(width: u32, height: u32) -> Vec<u8> {
    format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {height} +X {width}\n").into_bytes()
}

/// An OpenEXR header with `channels`, `compression` and a 16x8 data window, no pixels.
fn exr_header(channels: &[&str], compression: u8) -> Vec<u8> {
    let mut out = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut attr = |name: &str, ty: &str, value: &[u8]| {
        out.extend_from_slice(name.as_bytes());
        out.push(0);
        out.extend_from_slice(ty.as_bytes());
        out.push(0);
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(value);
    };
    let mut list = Vec::new();
    for c in channels {
        list.extend_from_slice(c.as_bytes());
        list.push(0);
        list.extend_from_slice(&2i32.to_le_bytes()); // FLOAT
        list.extend_from_slice(&[0, 0, 0, 0]);
        list.extend_from_slice(&1i32.to_le_bytes());
        list.extend_from_slice(&1i32.to_le_bytes());
    }
    list.push(0);
    attr("channels", "chlist", &list);
    attr("compression", "compression", &[compression]);
    let window: Vec<u8> = [0i32, 0, 15, 7]
        .iter()
        .flat_map(|v| v.to_le_bytes())
        .collect();
    attr("dataWindow", "box2i", &window);
    attr("displayWindow", "box2i", &window);
    out.push(0);
    out
}

/// (name, bytes or None for "no file written", what the error must say).
fn cases() -> Vec<(&'static str, Option<Vec<u8>>, &'static str)> {
    let good = map::encode_hdr(&EnvironmentMap::constant(16, [1.0, 0.5, 0.25]));
    let mut truncated = good.clone();
    truncated.truncate(good.len() - 40);
    // New-style RLE scanline of width 16 whose first run claims 100 bytes.
    let mut rle_past_end = hdr_header(16, 8);
    rle_past_end.extend_from_slice(&[2, 2, 0, 16, 128 + 100, 7]);
    let square = map::encode_hdr(&EnvironmentMap {
        width: 8,
        height: 8,
        texels: vec![[1.0; 3]; 64],
    });
    let mut absurd = hdr_header(400_000, 200_000);
    absurd.extend_from_slice(&[0; 64]);
    vec![
        ("truncated.hdr", Some(truncated), "Radiance"),
        (
            "wrong_magic.hdr",
            Some(b"P6\n16 8\n255\n".to_vec()),
            "not a Radiance .hdr",
        ),
        ("rle_past_line_end.hdr", Some(rle_past_end), "Radiance"),
        ("square.hdr", Some(square), "twice as wide"),
        ("zero.hdr", Some(hdr_header(0, 0)), "hdr"),
        ("absurd.hdr", Some(absurd), "limit"),
        ("dwa.exr", Some(exr_header(&["B", "G", "R"], 8)), "DWA"),
        (
            "no_rgb.exr",
            Some(exr_header(&["Y"], 0)),
            "no R, G and B channels",
        ),
        (
            "truncated_header.exr",
            Some(exr_header(&["R", "G", "B"], 3)[..30].to_vec()),
            "OpenEXR",
        ),
        ("directory", None, "directory"),
        ("missing.hdr", None, "cannot read"),
    ]
}

#[test]
fn broken_environment_maps_fail_cleanly() {
    let dir = super::work_dir("environment");
    for (name, bytes, needle) in cases() {
        let path = dir.join(name);
        match &bytes {
            Some(b) => std::fs::write(&path, b).unwrap(),
            None if name == "directory" => std::fs::create_dir_all(&path).unwrap(),
            None => {}
        }
        let source = EnvironmentSource::parse(path.to_str().unwrap()).unwrap();
        let err = source.load().expect_err(name);
        let chain = anyhow::Error::from(err);
        let message = format!("{chain:#}");
        assert!(message.contains(name), "{name}: {message}");
        assert!(
            message.to_lowercase().contains(&needle.to_lowercase()),
            "{name}: {message} lacks {needle:?}"
        );
        // And through the binary: exit code 1, one line naming the file, before any render.
        let (out, _) = super::rqr(
            &[
                "render",
                "--width",
                "8",
                "--height",
                "8",
                "--environment",
                path.to_str().unwrap(),
                "-o",
                dir.join("out.png").to_str().unwrap(),
            ],
            super::RENDER_LIMIT,
        );
        super::no_panic_or_validation(name, &out);
        assert_eq!(out.status.code(), Some(1), "{name}: {out:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(name), "{name}: {err}");
    }
}

#[test]
fn environment_argument_errors_are_usage_errors() {
    for bad in ["", "--environment-rotation=nan"] {
        let args: Vec<&str> = if bad.is_empty() {
            vec!["render", "--environment", ""]
        } else {
            vec!["render", bad]
        };
        let (out, _) = super::rqr(&args, super::INFO_LIMIT);
        super::no_panic_or_validation(bad, &out);
        assert_ne!(out.status.code(), Some(0), "{bad}");
    }
}

/// Malformed physical-sky arguments: the library names the argument and what is wrong, and
/// the binary refuses them as usage errors (exit code 2) before any work.
#[test]
fn bad_sky_arguments_fail_with_what_is_wrong() {
    for (bad, says) in [
        ("sky:abc", "elevation \"abc\" is not a number"),
        ("sky:95,0", "sun elevation 95° is outside 0..90"),
        ("sky:-10,0", "outside 0..90"),
        ("sky:30,0,0.5", "turbidity 0.5 is outside 1..10"),
        ("sky:30,0,3,9", "4 value(s) after `sky:`"),
        ("sky:30", "1 value(s) after `sky:`"),
        ("sky:30,east", "azimuth \"east\" is not a number"),
    ] {
        let err = EnvironmentSource::parse(bad).expect_err(bad).to_string();
        assert!(err.contains(bad) && err.contains(says), "{bad}: {err}");
        let (out, _) = super::rqr(&["render", "--environment", bad], super::INFO_LIMIT);
        super::no_panic_or_validation(bad, &out);
        assert_eq!(out.status.code(), Some(2), "{bad}: {out:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(stderr.contains(says), "{bad}: {stderr}");
    }
}

#[test]
fn every_cut_and_flipped_byte_of_a_map_fails_cleanly() {
    // A poor man's fuzzer over the two formats' seeds (the fuzz target `load_environment`
    // goes further): no input panics, every error names the file.
    let hdr = map::encode_hdr(&EnvironmentMap::from_fn(8, |d| [d.x.abs(), d.y.abs(), 1.0]));
    let exr = exr_header(&["B", "G", "R"], 0);
    for seed in [hdr, exr] {
        for cut in 0..seed.len() {
            if let Err(e) = map::decode("cut.hdr", &seed[..cut]) {
                assert!(e.to_string().starts_with("cut.hdr: "), "{e}");
            }
        }
        for i in 0..seed.len() {
            for flip in [0x01u8, 0x80, 0xff] {
                let mut b = seed.clone();
                b[i] ^= flip;
                if let Err(e) = map::decode("flip.hdr", &b) {
                    assert!(e.to_string().starts_with("flip.hdr: "), "{e}");
                }
            }
        }
    }
}

//! glTF / GLB bytes → `rqr::scene::load_slice`: every input must give a `Scene` or a
//! `SceneError` that names the file, never a panic, an abort or an unbounded allocation.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rqr::scene::{load_slice, LoadOptions};

fuzz_target!(|data: &[u8]| {
    // Small images keep each run within libFuzzer's memory limit; the size check itself is
    // the same code at any limit.
    let opts = LoadOptions {
        max_image_size: 256,
        ..Default::default()
    };
    match load_slice(data, None, "fuzz.glb", &opts) {
        Ok(scene) => {
            for g in &scene.geometries {
                assert!(g.indices.iter().all(|&i| (i as usize) < g.positions.len()));
            }
            assert!(scene.instances.iter().all(|i| i.transform.is_finite()));
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.glb: "), "{e}"),
    }
});

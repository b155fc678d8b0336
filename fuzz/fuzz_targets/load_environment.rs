//! `.hdr` / `.exr` bytes → `rqr::environment::map::decode`: every input must give a map of
//! the checked shape or an error that names the file, never a panic, an abort or an
//! unbounded allocation (sizes are checked from the header first).
#![no_main]

use libfuzzer_sys::fuzz_target;
use rqr::environment::map::decode;

fuzz_target!(|data: &[u8]| {
    match decode("fuzz.hdr", data) {
        Ok(map) => {
            assert_eq!(map.width, 2 * map.height);
            assert_eq!(map.texels.len(), (map.width * map.height) as usize);
        }
        Err(e) => assert!(e.to_string().starts_with("fuzz.hdr: "), "{e}"),
    }
});

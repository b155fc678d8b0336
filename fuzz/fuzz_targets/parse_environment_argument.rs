//! `--environment` argument text → `rqr::environment::EnvironmentSource::parse`, and for the
//! physical sky the model and a small bake: every input gives a source or an error naming the
//! argument, never a panic; a sky that parses bakes to finite, non-negative texels.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rqr::environment::EnvironmentSource;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match EnvironmentSource::parse(text) {
        Ok(EnvironmentSource::Sky(spec)) => {
            let model = spec.model().expect("a parsed sky is in the model's range");
            let map = model.bake(16);
            assert!(map
                .texels
                .iter()
                .flatten()
                .all(|v| v.is_finite() && *v >= 0.0));
            let sun = model.sun_light(0.0, 1.0);
            assert!(sun.intensity.is_finite() && sun.intensity >= 0.0);
        }
        Ok(_) => {}
        Err(e) => assert!(e.to_string().starts_with("--environment "), "{e}"),
    }
});

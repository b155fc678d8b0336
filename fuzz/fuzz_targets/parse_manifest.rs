//! `rqr batch` manifest text → `rqr::batch::manifest::parse`: every line becomes a job or an
//! error naming the manifest and the line, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use rqr::batch::manifest::{parse, Entry, JobFields};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let entries = parse(text, "fuzz.jsonl", std::path::Path::new("."), &JobFields::default());
    assert_eq!(entries.len(), text.lines().count());
    for (k, e) in entries.iter().enumerate() {
        if let Entry::Invalid { error, .. } = e {
            assert!(error.to_string().starts_with(&format!("fuzz.jsonl:{}: ", k + 1)), "{error}");
        }
    }
});

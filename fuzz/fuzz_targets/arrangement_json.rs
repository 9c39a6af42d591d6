//! Arrangement files: any bytes either parse into a valid arrangement or give an error naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use neuroom_core::formats::parse_arrangement;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz/arrangement.json");
    if let Err(e) = parse_arrangement(file, data) {
        assert_eq!(e.path, file);
    }
});

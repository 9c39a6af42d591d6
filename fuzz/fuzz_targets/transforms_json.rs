//! `transforms.json`: any bytes either parse into a valid capture or give an error naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use neuroom_core::formats::parse_capture;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz/transforms.json");
    match parse_capture(file, data) {
        Ok(c) => assert!(!c.frames.is_empty()),
        Err(e) => assert_eq!(e.path, file),
    }
});

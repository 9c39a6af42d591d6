//! `room.json`: any bytes either parse into a valid room or give an error naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use neuroom_core::formats::parse_room;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz/room.json");
    if let Err(e) = parse_room(file, data) {
        assert_eq!(e.path, file);
    }
});

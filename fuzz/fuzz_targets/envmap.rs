//! Environment maps (`.exr`, `.hdr`, `.exr.js`): any bytes either decode into a finite, non-negative 2:1
//! map or give an error naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use neuroom_core::formats::decode_envmap;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz/map.exr");
    match decode_envmap(file, data) {
        Ok(map) => {
            assert_eq!(map.width, 2 * map.height);
            assert!(
                map.data
                    .iter()
                    .flatten()
                    .all(|c| c.is_finite() && *c >= 0.0)
            );
        }
        Err(e) => assert_eq!(e.path, file),
    }
});

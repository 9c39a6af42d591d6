//! Image files (PNG and JPEG): every image reader — colour as RGB and RGBA, depth, instance mask and the
//! header-only size — on the same bytes. Each either decodes an image whose pixel count matches its size
//! or gives an error naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use neuroom_core::FormatResult;
use neuroom_core::formats::{
    decode_depth, decode_image_size, decode_mask, decode_rgb, decode_rgba,
};
use neuroom_core::image::Image;
use std::path::Path;

/// Checks one reader's outcome: a consistent image, or an error about `file`.
fn check<T>(file: &Path, result: FormatResult<Image<T>>) {
    match result {
        Ok(img) => assert_eq!(img.data.len(), img.width as usize * img.height as usize),
        Err(e) => assert_eq!(e.path, file),
    }
}

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz/image.png");
    check(file, decode_rgb(file, data).map(|d| d.image));
    check(file, decode_rgba(file, data).map(|d| d.image));
    check(file, decode_depth(file, data, 0.001));
    check(file, decode_mask(file, data));
    if let Err(e) = decode_image_size(file, data) {
        assert_eq!(e.path, file);
    }
});

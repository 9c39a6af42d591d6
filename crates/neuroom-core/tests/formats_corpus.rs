//! Malformed inputs (in `tests/corpus/`; the `gen_*` files come from `tools/make_corpus.py`): every reader
//! must reject each one with an error that names the file and the field or problem, and no reader may panic
//! on any of them. Images with a sensible conversion (grayscale, 16-bit, palette, CMYK) are read and the
//! conversion is reported.

use neuroom_core::FormatError;
use neuroom_core::formats::{
    Conversion, read_arrangement, read_capture, read_depth, read_envmap, read_image_size,
    read_intrinsics_file, read_mask, read_rgb, read_rgba, read_room,
};
use neuroom_core::mesh::read_ply;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

/// Which reader a corpus file is fed to.
#[derive(Clone, Copy, Debug)]
enum Reader {
    Room,
    Capture,
    Arrangement,
    Rgb,
    Rgba,
    ImageSize,
    Depth,
    Mask,
    EnvMap,
    Ply,
    Intrinsics,
}

/// Every reader, for the sweep over the whole corpus.
const ALL_READERS: [Reader; 11] = [
    Reader::Room,
    Reader::Capture,
    Reader::Arrangement,
    Reader::Rgb,
    Reader::Rgba,
    Reader::ImageSize,
    Reader::Depth,
    Reader::Mask,
    Reader::EnvMap,
    Reader::Ply,
    Reader::Intrinsics,
];

/// Runs `reader` on `path`.
fn run(reader: Reader, path: &Path) -> Result<(), FormatError> {
    match reader {
        Reader::Room => read_room(path).map(drop),
        Reader::Capture => read_capture(path).map(drop),
        Reader::Arrangement => read_arrangement(path).map(drop),
        Reader::Rgb => read_rgb(path).map(drop),
        Reader::Rgba => read_rgba(path).map(drop),
        Reader::ImageSize => read_image_size(path).map(drop),
        Reader::Depth => read_depth(path, 0.001).map(drop),
        Reader::Mask => read_mask(path).map(drop),
        Reader::EnvMap => read_envmap(path).map(drop),
        Reader::Ply => read_ply(path).map(drop),
        Reader::Intrinsics => read_intrinsics_file(path).map(drop),
    }
}

/// Runs `reader` on `path` and returns its error (panicking if it accepted the file).
fn reject(reader: Reader, path: &Path) -> FormatError {
    match run(reader, path) {
        Ok(()) => panic!("{reader:?} accepted {}", path.display()),
        Err(e) => e,
    }
}

fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/corpus")
        .join(name)
}

#[test]
fn every_malformed_file_is_rejected_with_file_field_and_reason() {
    use Reader::*;
    let cases: &[(&str, Reader, Option<&str>, &str)] = &[
        ("truncated.png", Rgb, None, "cannot decode PNG"),
        ("empty.png", Rgb, None, "empty"),
        ("empty.png", Mask, None, "empty"),
        ("not_an_image.png", Rgb, None, "not a PNG or JPEG"),
        ("not_an_image.png", Depth, None, "not a PNG"),
        ("depth_8bit.png", Depth, None, "16-bit"),
        ("mask_rgb.png", Mask, None, "8- or 16-bit grayscale"),
        ("huge.png", Rgb, None, "20000×2"),
        ("huge.png", Depth, None, "16384"),
        ("not_an_envmap.exr", EnvMap, None, "not an OpenEXR"),
        ("bad_module.exr.js", EnvMap, None, "invalid base64"),
        (
            "room_wrong_type.json",
            Room,
            Some("objects[0].id"),
            "integer",
        ),
        (
            "room_id_zero.json",
            Room,
            Some("objects[0].id"),
            "1..=65535",
        ),
        (
            "room_id_too_big.json",
            Room,
            Some("objects[0].id"),
            "1..=65535",
        ),
        (
            "room_missing_size.json",
            Room,
            Some("objects[0].size"),
            "missing",
        ),
        (
            "room_negative_size.json",
            Room,
            Some("objects[0].size"),
            "positive",
        ),
        (
            "room_scaled_pose.json",
            Room,
            Some("objects[0].capture_to_object"),
            "orthonormal",
        ),
        (
            "room_absolute_capture.json",
            Room,
            Some("objects[0].capture"),
            "relative",
        ),
        (
            "room_duplicate_id.json",
            Room,
            Some("objects[1].id"),
            "duplicate id 1",
        ),
        (
            "room_duplicate_name.json",
            Room,
            Some("objects[1].name"),
            "duplicate name",
        ),
        (
            "room_bad_format.json",
            Room,
            Some("format"),
            "neuroom.room/1",
        ),
        (
            "room_missing_background.json",
            Room,
            Some("background"),
            "missing",
        ),
        ("room_nan.json", Room, None, "NaN"),
        ("room_truncated.json", Room, None, "not valid JSON"),
        ("room_not_object.json", Room, None, "top level"),
        (
            "intrinsics_missing_fl_y.json",
            Intrinsics,
            Some("fl_y"),
            "a photo's intrinsics need it",
        ),
        (
            "intrinsics_negative_width.json",
            Intrinsics,
            Some("w"),
            "integer",
        ),
        (
            "transforms_fisheye.json",
            Capture,
            Some("camera_model"),
            "OPENCV_FISHEYE",
        ),
        (
            "transforms_missing_fl.json",
            Capture,
            Some("frames[0].fl_y"),
            "missing",
        ),
        (
            "transforms_negative_fl.json",
            Capture,
            Some("frames[0].fl_x"),
            "positive",
        ),
        (
            "transforms_fractional_width.json",
            Capture,
            Some("w"),
            "integer",
        ),
        (
            "transforms_short_row.json",
            Capture,
            Some("frames[0].transform_matrix"),
            "row 0",
        ),
        (
            "transforms_non_orthonormal.json",
            Capture,
            Some("frames[0].transform_matrix"),
            "orthonormal",
        ),
        (
            "transforms_bad_last_row.json",
            Capture,
            Some("frames[0].transform_matrix"),
            "last row",
        ),
        (
            "transforms_no_frames.json",
            Capture,
            Some("frames"),
            "at least one",
        ),
        (
            "transforms_path_not_string.json",
            Capture,
            Some("frames[0].depth_file_path"),
            "string",
        ),
        (
            "transforms_pinhole_distorted.json",
            Capture,
            Some("k1"),
            "PINHOLE",
        ),
        ("transforms_k3.json", Capture, Some("k3"), "k1, k2, p1, p2"),
        (
            "transforms_bad_depth_unit.json",
            Capture,
            Some("depth_unit_scale_factor"),
            "positive",
        ),
        (
            "transforms_tracked_not_bool.json",
            Capture,
            Some("tracked_poses"),
            "true or false",
        ),
        (
            "transforms_bad_depth_noise.json",
            Capture,
            Some("depth_noise"),
            "at_0m",
        ),
        (
            "arrangement_duplicate_name.json",
            Arrangement,
            Some("objects[1].name"),
            "duplicate",
        ),
        (
            "arrangement_reflection.json",
            Arrangement,
            Some("camera_to_world"),
            "reflection",
        ),
        (
            "arrangement_wrong_format.json",
            Arrangement,
            Some("format"),
            "neuroom.arrangement/1",
        ),
        (
            "arrangement_missing_pose.json",
            Arrangement,
            Some("objects[0].object_to_world"),
            "missing",
        ),
        (
            "arrangement_objects_not_array.json",
            Arrangement,
            Some("objects"),
            "array",
        ),
        // Generated by tools/make_corpus.py.
        ("gen_truncated.jpg", Rgb, None, "cannot decode JPEG"),
        ("gen_huge.jpg", Rgb, None, "20000×8; sides must be"),
        ("gen_huge.jpg", ImageSize, None, "16384"),
        ("gen_bomb.jpg", Rgba, None, "cannot hold a 16000×16000 JPEG"),
        ("gen_bomb.png", Rgb, None, "cannot hold a 16000×16000 PNG"),
        ("gen_bomb.png", Depth, None, "truncated or corrupt"),
        ("gen_bad_crc.png", Rgb, None, "CRC"),
        ("gen_zero_width.png", Mask, None, "dimensions"),
        ("gen_depth_rgb16.png", Depth, None, "found a 16-bit RGB PNG"),
        ("gen_depth_no_idat.png", Depth, None, "IDAT"),
        ("gen_gray8.png", Depth, None, "at most 255 units"),
        ("gen_mask_palette.png", Mask, None, "palette"),
        ("gen_gray_alpha.png", Mask, None, "grayscale+alpha"),
        ("gen_cmyk.jpg", Mask, None, "not a PNG"),
        ("gen_envmap_square.hdr", EnvMap, None, "twice as wide"),
        ("gen_envmap_square.exr", EnvMap, None, "4×4"),
        ("gen_envmap_truncated.hdr", EnvMap, None, "Radiance HDR"),
        ("gen_envmap_truncated.exr", EnvMap, None, "OpenEXR"),
        ("gen_envmap_huge.hdr", EnvMap, None, "40000×20000"),
        (
            "gen_envmap_tall.hdr",
            EnvMap,
            None,
            "cannot hold a 16000×8000",
        ),
        (
            "gen_envmap_nan.exr",
            EnvMap,
            None,
            "pixel (3, 2) is not finite",
        ),
        ("gen_envmap_no_blue.exr", EnvMap, None, "no channel B"),
        ("gen_ply_no_magic.ply", Ply, None, "magic"),
        ("gen_ply_no_end_header.ply", Ply, None, "end_header"),
        ("gen_ply_bad_index.ply", Ply, Some("face"), "vertex index 7"),
        ("gen_ply_fractional_index.ply", Ply, Some("face"), "1.5"),
        ("gen_ply_nan_vertex.ply", Ply, Some("vertex"), "non-finite"),
        ("gen_ply_ends_early.ply", Ply, None, "ends early"),
        ("gen_ply_bad_count.ply", Ply, Some("element"), "-3"),
        (
            "gen_ply_big_endian.ply",
            Ply,
            Some("format"),
            "binary_big_endian",
        ),
        ("gen_ply_unknown_type.ply", Ply, Some("property"), "quad"),
        ("gen_ply_truncated_binary.ply", Ply, None, "truncated"),
        ("gen_empty.json", Room, None, "empty"),
        ("gen_whitespace.json", Capture, None, "empty"),
        ("gen_not_utf8.json", Room, None, "not valid JSON"),
        (
            "gen_deep_nesting.json",
            Arrangement,
            None,
            "recursion limit",
        ),
        ("gen_huge_number.json", Room, None, "out of range"),
        ("gen_transforms_nan.json", Capture, None, "NaN"),
        (
            "gen_transforms_too_wide.json",
            Capture,
            Some("w"),
            "1..=16384",
        ),
        (
            "gen_transforms_no_file_path.json",
            Capture,
            Some("frames[0].file_path"),
            "missing",
        ),
        (
            "gen_arrangement_duplicate_id.json",
            Arrangement,
            Some("objects[1].id"),
            "duplicate id 1",
        ),
        ("gen_arrangement_nan.json", Arrangement, None, "NaN"),
        (
            "gen_arrangement_skewed.json",
            Arrangement,
            Some("camera_to_world"),
            "orthonormal",
        ),
    ];
    for &(name, reader, field, reason) in cases {
        let path = corpus(name);
        let err = reject(reader, &path);
        let shown = err.to_string();
        assert_eq!(err.path, path, "{name}: {shown}");
        assert!(
            shown.contains(name),
            "{name}: message does not name the file: {shown}"
        );
        assert_eq!(err.field.as_deref(), field, "{name}: {shown}");
        if let Some(field) = field {
            assert!(
                shown.contains(field),
                "{name}: message does not name the field: {shown}"
            );
        }
        assert!(
            shown.contains(reason),
            "{name}: expected `{reason}` in: {shown}"
        );
    }
}

#[test]
fn an_element_without_properties_is_skipped_whatever_its_count() {
    let mesh = read_ply(&corpus("gen_ply_endless_element.ply")).unwrap();
    assert!(mesh.positions.is_empty() && mesh.triangles.is_empty());
}

#[test]
fn missing_files_and_folders_are_named() {
    let err = read_room(corpus("no_such_room")).unwrap_err();
    assert!(err.to_string().contains("no_such_room"), "{err}");
    let err = read_capture(corpus("no_such_capture/transforms.json")).unwrap_err();
    assert!(err.to_string().contains("cannot read"), "{err}");
}

#[test]
fn every_reader_on_every_corpus_file_names_the_file_and_never_panics() {
    let dir = corpus("");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    assert!(files.len() >= 80, "corpus has only {} files", files.len());
    let mut failures = Vec::new();
    for path in &files {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        for reader in ALL_READERS {
            match catch_unwind(AssertUnwindSafe(|| run(reader, path))) {
                Err(_) => failures.push(format!("{reader:?} panicked on {name}")),
                Ok(Err(e)) if e.path != *path || !e.to_string().contains(&name) => {
                    failures.push(format!("{reader:?} on {name}: error does not name it: {e}"))
                }
                Ok(_) => {}
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn images_with_a_sensible_conversion_are_converted_and_say_so() {
    use Conversion::*;
    let cases: &[(&str, &[Conversion], [f32; 3])] = &[
        ("gen_gray8.png", &[GrayToRgb], [0.0; 3]),
        ("gen_rgb16.png", &[SixteenBit], [0x1234 as f32 / 65535.0; 3]),
        ("gen_palette.png", &[PaletteExpanded], [1.0, 0.0, 0.0]),
        (
            "gen_gray_alpha.png",
            &[GrayToRgb, AlphaDropped],
            [128.0 / 255.0; 3],
        ),
        ("gen_cmyk.jpg", &[CmykToRgb], [1.0, 0.0, 0.0]),
        ("gen_gray.jpg", &[GrayToRgb], [128.0 / 255.0; 3]),
    ];
    for &(name, conversions, first) in cases {
        let decoded = read_rgb(corpus(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(decoded.conversions, conversions, "{name}");
        let got = decoded.image.data[0];
        assert!(
            got.iter().zip(first).all(|(a, b)| (a - b).abs() < 0.03),
            "{name}: first pixel {got:?}, expected {first:?}"
        );
        assert!(!decoded.conversions[0].to_string().is_empty());
    }
}

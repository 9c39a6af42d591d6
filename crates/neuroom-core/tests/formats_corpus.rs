//! Malformed inputs (in `tests/corpus/`): every reader must reject each one with an error that names the
//! file and the field or problem.

use neuroom_core::FormatError;
use neuroom_core::formats::{
    read_arrangement, read_capture, read_depth, read_envmap, read_mask, read_rgb, read_room,
};
use std::path::{Path, PathBuf};

/// Which reader a corpus file is fed to.
#[derive(Clone, Copy, Debug)]
enum Reader {
    Room,
    Capture,
    Arrangement,
    Rgb,
    Depth,
    Mask,
    EnvMap,
}

/// Runs `reader` on `path` and returns its error (panicking if it accepted the file).
fn reject(reader: Reader, path: &Path) -> FormatError {
    let result = match reader {
        Reader::Room => read_room(path).map(drop),
        Reader::Capture => read_capture(path).map(drop),
        Reader::Arrangement => read_arrangement(path).map(drop),
        Reader::Rgb => read_rgb(path).map(drop),
        Reader::Depth => read_depth(path, 0.001).map(drop),
        Reader::Mask => read_mask(path).map(drop),
        Reader::EnvMap => read_envmap(path).map(drop),
    };
    match result {
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
fn missing_files_and_folders_are_named() {
    let err = read_room(corpus("no_such_room")).unwrap_err();
    assert!(err.to_string().contains("no_such_room"), "{err}");
    let err = read_capture(corpus("no_such_capture/transforms.json")).unwrap_err();
    assert!(err.to_string().contains("cannot read"), "{err}");
}

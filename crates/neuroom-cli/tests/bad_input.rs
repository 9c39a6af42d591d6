//! Bad input on the command line: `info`, `train`, `render`, `fit` and `locate` fed a missing, corrupt, wrongly sized
//! or inconsistent file must exit with code 2 and a message naming that file, never panic. Each case starts
//! from the tiny valid room of neuroom-core's tests and breaks one file of a copy.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The tiny valid room the cases break.
fn tiny_room() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny")
}

/// A corpus file of neuroom-core's tests.
fn corpus(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../neuroom-core/tests/corpus")
        .join(name)
}

/// A fresh, empty folder for one case.
fn scratch(case: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!(
        "bad_input_{case}_{}_{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// A copy of the tiny room, for one case to break.
fn room_copy(case: &str) -> PathBuf {
    let room = scratch(case).join("room");
    neuroom_testing::copy_folder(&tiny_room(), &room);
    room
}

/// Runs `neuroom` with `args`.
fn neuroom(args: &[&Path]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_neuroom"))
        .args(args)
        .output()
        .unwrap()
}

/// Asserts that the command failed with exit code 2 and a message naming `file` (and `what`).
fn assert_rejects(out: &Output, file: &Path, what: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    let shown = file.display().to_string();
    assert!(
        stderr.contains(&shown),
        "message does not name {shown}: {stderr}"
    );
    assert!(stderr.contains(what), "expected `{what}` in: {stderr}");
}

#[test]
fn info_accepts_the_intact_tiny_room() {
    let out = neuroom(&[Path::new("info"), &tiny_room()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("room `tiny`"), "{stdout}");
    assert!(stdout.contains("panorama p0.png 16×8"), "{stdout}");
}

#[test]
fn info_names_a_missing_room() {
    let room = scratch("missing").join("nowhere");
    let out = neuroom(&[Path::new("info"), &room]);
    assert_rejects(&out, &room, "cannot read");
}

#[test]
fn info_names_each_broken_file_of_a_room() {
    // (file to replace, replacement, words expected in the message)
    let cases: &[(&str, PathBuf, &str)] = &[
        ("room.json", corpus("room_nan.json"), "NaN"),
        (
            "captures/box/transforms.json",
            corpus("transforms_non_orthonormal.json"),
            "orthonormal",
        ),
        (
            "captures/box/images/1.png",
            corpus("truncated.png"),
            "cannot decode PNG",
        ),
        (
            "captures/background/images/0.png",
            corpus("empty.png"),
            "empty",
        ),
        (
            "captures/background/depths/1.png",
            tiny_room().join("panoramas/p0.depth.png"),
            "must match",
        ),
        (
            "captures/box/masks/0.png",
            tiny_room().join("panoramas/p0.mask.png"),
            "must match",
        ),
        (
            "captures/box/depths/0.png",
            corpus("depth_8bit.png"),
            "16-bit",
        ),
        (
            "panoramas/p0.png",
            tiny_room().join("captures/box/images/0.png"),
            "twice as wide",
        ),
        (
            "panoramas/p0.json",
            corpus("gen_arrangement_nan.json"),
            "NaN",
        ),
        ("panoramas/p0.mask.png", corpus("mask_rgb.png"), "grayscale"),
        (
            "meshes/box.ply",
            corpus("gen_ply_nan_vertex.ply"),
            "non-finite",
        ),
    ];
    for (file, replacement, what) in cases {
        let room = room_copy("broken");
        let target = room.join(file);
        fs::copy(replacement, &target).unwrap();
        assert_rejects(&neuroom(&[Path::new("info"), &room]), &target, what);
    }
}

#[test]
fn info_names_a_mask_holding_an_id_room_json_lacks() {
    let room = room_copy("unknown_id");
    let json = fs::read_to_string(room.join("room.json")).unwrap();
    fs::write(
        room.join("room.json"),
        json.replace("\"id\": 1", "\"id\": 2"),
    )
    .unwrap();
    let out = neuroom(&[Path::new("info"), &room]);
    let mask = room.join("captures/box/masks/0.png");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("captures/box/masks/") && stderr.contains("id 1"),
        "expected {} and id 1 in: {stderr}",
        mask.display()
    );
}

#[test]
fn train_checks_every_file_before_it_starts() {
    let room = room_copy("train");
    let bad = room.join("captures/box/images/1.png");
    fs::copy(corpus("truncated.png"), &bad).unwrap();
    let models = room.parent().unwrap().join("models");
    let out = neuroom(&[Path::new("train"), &room, Path::new("--out"), &models]);
    assert_rejects(&out, &bad, "cannot decode PNG");
    assert!(!models.join("tiny").exists(), "training started");
}

#[test]
fn render_names_a_bad_arrangement_and_missing_models() {
    let dir = scratch("render");
    let out_png = dir.join("out.png");
    let bad = corpus("arrangement_reflection.json");
    let out = neuroom(&[Path::new("render"), &dir, &bad, Path::new("-o"), &out_png]);
    assert_rejects(&out, &bad, "reflection");
    let good = tiny_room().join("panoramas/p0.json");
    let out = neuroom(&[Path::new("render"), &dir, &good, Path::new("-o"), &out_png]);
    assert_rejects(&out, &dir.join("manifest.json"), "cannot read");
    assert!(!out_png.exists());
}

#[test]
fn fit_names_a_bad_panorama_and_a_bad_initial_arrangement() {
    let dir = scratch("fit");
    let out_json = dir.join("solved.json");
    let init = tiny_room().join("panoramas/p0.json");
    for (panorama, what) in [
        (corpus("truncated.png"), "cannot decode PNG"),
        (corpus("gen_bomb.jpg"), "truncated or corrupt"),
        (dir.join("absent.png"), "cannot read"),
        (
            tiny_room().join("captures/box/images/0.png"),
            "twice as wide as it is high",
        ),
        (tiny_room().join("panoramas/p0.depth.png"), "depth map"),
    ] {
        let out = neuroom(&[
            Path::new("fit"),
            &dir,
            &panorama,
            Path::new("--init"),
            &init,
            Path::new("-o"),
            &out_json,
        ]);
        assert_rejects(&out, &panorama, what);
    }
    let panorama = tiny_room().join("panoramas/p0.png");
    let bad_init = corpus("gen_arrangement_duplicate_id.json");
    let out = neuroom(&[
        Path::new("fit"),
        &dir,
        &panorama,
        Path::new("--init"),
        &bad_init,
        Path::new("-o"),
        &out_json,
    ]);
    assert_rejects(&out, &bad_init, "duplicate id");
    assert!(!out_json.exists());
}

#[test]
fn locate_names_a_bad_panorama_and_a_photo_whose_intrinsics_do_not_fit() {
    let dir = scratch("locate");
    let out_json = dir.join("arrangement.json");
    let photo = tiny_room().join("captures/background/images/0.png");
    let locate = |image: &Path, extra: &[&Path]| {
        let mut args: Vec<&Path> = vec![Path::new("locate"), &dir, &dir, image];
        args.extend_from_slice(extra);
        args.extend_from_slice(&[Path::new("-o"), &out_json]);
        neuroom(&args)
    };
    // Without intrinsics an image must be a panorama.
    assert_rejects(&locate(&photo, &[]), &photo, "--intrinsics");
    // A panorama's depth map (16-bit, one channel, 2:1) is not its colour.
    let depth = tiny_room().join("panoramas/p0.depth.png");
    assert_rejects(&locate(&depth, &[]), &depth, "depth map");
    let bad = corpus("intrinsics_missing_fl_y.json");
    let out = locate(&photo, &[Path::new("--intrinsics"), &bad]);
    assert_rejects(&out, &bad, "fl_y");
    // Intrinsics for another size (the photo is 8 × 6).
    let other = dir.join("camera.json");
    fs::write(
        &other,
        r#"{"w": 640, "h": 480, "fl_x": 500, "fl_y": 500, "cx": 320, "cy": 240}"#,
    )
    .unwrap();
    let out = locate(&photo, &[Path::new("--intrinsics"), &other]);
    assert_rejects(&out, &photo, "640×480");
    assert!(!out_json.exists());
}

/// A `neuroom` built without the `rerun` feature refuses `export --rrd` before reading anything, and
/// says how to get it.
#[cfg(not(feature = "rerun"))]
#[test]
fn export_rrd_without_the_feature_says_to_rebuild() {
    let dir = scratch("rrd");
    let rrd = dir.join("room.rrd");
    let args = [
        Path::new("export"),
        &dir.join("models"),
        &dir.join("solved.json"),
        Path::new("--rrd"),
        &rrd,
    ];
    let out = neuroom(&args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "stderr: {stderr}");
    assert!(stderr.contains("--features rerun"), "{stderr}");
    assert!(!rrd.exists());
}

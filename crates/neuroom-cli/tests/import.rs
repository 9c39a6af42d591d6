//! `neuroom import` end to end: a recording into a room folder that `neuroom info` accepts, the
//! capture never overwritten, and bad recordings refused with exit code 2 and the file named. The
//! importers' conversions are tested against known captures in `neuroom-import/tests/`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use neuroom::Pose;
use neuroom::image::Image;
use serde_json::json;

/// A fresh folder for one test.
fn scratch(case: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join(format!("import_{case}_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn neuroom(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_neuroom"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A nerfstudio folder of four upright cameras in a z-up world, turning about the room's centre.
fn nerfstudio_recording(dir: &Path) {
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let frames: Vec<_> = (0..4)
        .map(|i| {
            let image = Image::filled(64, 48, [0.2 + 0.1 * i as f32, 0.5, 0.7]);
            neuroom::formats::write_rgb(dir.join(format!("images/{i}.png")), &image).unwrap();
            let heading = glam::DMat3::from_rotation_z(i as f64 * std::f64::consts::FRAC_PI_2);
            // Looking along +x with +z up: the camera's −z is +x, its +y is +z.
            let upright =
                glam::DMat3::from_cols(glam::DVec3::NEG_Y, glam::DVec3::Z, glam::DVec3::NEG_X);
            let pose = Pose::new(heading * upright, glam::DVec3::new(1.0, 1.0, 1.4));
            json!({ "file_path": format!("images/{i}.png"), "transform_matrix": pose.to_rows() })
        })
        .collect();
    let transforms = json!({
        "camera_model": "OPENCV", "w": 64, "h": 48, "fl_x": 50, "fl_y": 50, "cx": 32, "cy": 24,
        "frames": frames,
    });
    std::fs::write(dir.join("transforms.json"), transforms.to_string()).unwrap();
}

#[test]
fn an_imported_empty_room_is_a_room_info_accepts_and_is_never_overwritten() {
    let dir = scratch("room");
    nerfstudio_recording(&dir.join("scan"));
    let args = [
        "import",
        "nerfstudio",
        "scan",
        "--room",
        "office",
        "--name",
        "background",
    ];
    let first = neuroom(&args, &dir);
    assert!(first.status.success(), "{}", stderr(&first));
    let info = neuroom(&["info", "office"], &dir);
    assert!(info.status.success(), "{}", stderr(&info));
    assert!(String::from_utf8_lossy(&info.stdout).contains("4 frames (64×48)"));
    let again = neuroom(&args, &dir);
    assert_eq!(again.status.code(), Some(2));
    assert!(
        stderr(&again).contains("captures/background: already exists"),
        "{}",
        stderr(&again)
    );
}

#[test]
fn bad_recordings_exit_with_code_2_naming_the_file() {
    let dir = scratch("bad");
    std::fs::create_dir_all(dir.join("stray")).unwrap();
    std::fs::create_dir_all(dir.join("scanner")).unwrap();
    std::fs::write(
        dir.join("scanner/frame_00000.json"),
        "{\"cameraPoseARFrame\": [1, 2]}",
    )
    .unwrap();
    let image = Image::filled(8, 6, [0.5f32; 3]);
    neuroom::formats::write_rgb(dir.join("scanner/frame_00000.jpg"), &image).unwrap();
    let cases = [
        ("stray", "stray", "stray/odometry.csv"),
        ("3d-scanner-app", "scanner", "frame_00000.json"),
        ("nerfstudio", "missing", "missing"),
    ];
    for (format, src, named) in cases {
        let out = neuroom(&["import", format, src, "--room", "r", "--name", "x"], &dir);
        assert_eq!(out.status.code(), Some(2), "{format}: {}", stderr(&out));
        assert!(stderr(&out).contains(named), "{format}: {}", stderr(&out));
        assert!(
            !dir.join("r/captures/x").exists(),
            "{format}: nothing is left behind"
        );
    }
}

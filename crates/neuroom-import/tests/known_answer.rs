//! Each importer on a capture whose answer is known: frames rendered nowhere but made here, with
//! exact poses in neuroom's world, written as each app writes them (its world, its camera axes,
//! its files), imported back and compared. No app's own sample files can be redistributed here,
//! so the files follow the formats' specifications (docs/capture.md).

use std::path::Path;

use glam::{DMat3, DQuat, DVec3};
use neuroom_core::camera::Pinhole;
use neuroom_core::depth_upsample::upsample_depth;
use neuroom_core::formats::{self, Capture};
use neuroom_core::image::{DepthImage, Image, RgbImage};
use neuroom_core::pose::Pose;
use neuroom_import::nerfstudio::NerfstudioRecording;
use neuroom_import::scanner_app::ScannerAppRecording;
use neuroom_import::stray::{read_camera_matrix, read_odometry};
use neuroom_import::video::VideoSize;
use neuroom_import::{FrameSize, ImportOptions, Recording, import_recording};
use rand::{Rng, SeedableRng};
use serde_json::json;

const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

/// ARKit's world from neuroom's: ARKit's y is up, its x is neuroom's x, its z neuroom's −y.
fn to_arkit() -> DMat3 {
    DMat3::from_cols(
        DVec3::new(1.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, -1.0),
        DVec3::new(0.0, 1.0, 0.0),
    )
}

/// A known frame: pose (OpenGL camera, z-up world), colour and depth.
struct TrueFrame {
    pose: Pose,
    rgb: RgbImage,
    depth: DepthImage,
}

fn camera() -> Pinhole {
    Pinhole {
        width: WIDTH,
        height: HEIGHT,
        fx: 80.0,
        fy: 81.0,
        cx: 48.5,
        cy: 35.5,
        k1: 0.0,
        k2: 0.0,
        p1: 0.0,
        p2: 0.0,
    }
}

/// Upright cameras in a room, each leaning a little and looking any way, with smooth images.
fn true_frames(count: usize) -> Vec<TrueFrame> {
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    (0..count)
        .map(|k| {
            let yaw = DMat3::from_rotation_z(rng.random_range(-3.1..3.1));
            // An upright OpenGL camera looking along +x: −z → +x, +y → +z.
            let upright = DMat3::from_cols(DVec3::NEG_Y, DVec3::Z, DVec3::NEG_X);
            let lean = DMat3::from_rotation_x(rng.random_range(-0.3..0.3));
            let pose = Pose::new(
                yaw * upright * lean,
                DVec3::new(rng.random_range(0.5..4.0), rng.random_range(0.5..3.0), 1.4),
            );
            let rgb = Image {
                width: WIDTH,
                height: HEIGHT,
                data: (0..WIDTH * HEIGHT)
                    .map(|i| {
                        let (u, v) = (
                            (i % WIDTH) as f32 / WIDTH as f32,
                            (i / WIDTH) as f32 / HEIGHT as f32,
                        );
                        [0.2 + 0.6 * u, 0.3 + 0.4 * v, 0.1 + 0.05 * k as f32]
                    })
                    .collect(),
            };
            let depth = Image {
                width: WIDTH / 2,
                height: HEIGHT / 2,
                data: (0..WIDTH * HEIGHT / 4)
                    .map(|i| 1.0 + 0.001 * (i % 997) as f32)
                    .collect(),
            };
            TrueFrame { pose, rgb, depth }
        })
        .collect()
}

fn options() -> ImportOptions {
    ImportOptions {
        size: FrameSize { max_width: 640 },
        ..ImportOptions::default()
    }
}

fn import(recording: &mut dyn Recording, out: &Path) -> Capture {
    let mut reports = Vec::new();
    let capture =
        import_recording(recording, out, &options(), &mut |d, t| reports.push((d, t))).unwrap();
    assert_eq!(reports.last().map(|r| r.0), Some(capture.frames.len()));
    // What was written reads back as a capture of the project's format, one a phone took.
    let back = formats::read_capture(out).unwrap();
    assert_eq!(back.frames.len(), capture.frames.len());
    assert!(back.device.auto_exposure && back.device.tracked_poses);
    capture
}

fn assert_same_pose(found: &Pose, truth: &Pose, what: &str) {
    let rotation = (found.rotation - truth.rotation)
        .to_cols_array()
        .iter()
        .map(|x| x.abs())
        .fold(0.0, f64::max);
    let translation = (found.translation - truth.translation).length();
    assert!(
        rotation < 1e-6 && translation < 1e-6,
        "{what}: rotation off by {rotation:.2e}, translation by {translation:.2e}"
    );
}

fn assert_frames(capture: &Capture, truth: &[TrueFrame], colour_tolerance: f32) {
    assert_eq!(capture.frames.len(), truth.len());
    for (k, (frame, t)) in capture.frames.iter().zip(truth).enumerate() {
        assert_same_pose(&frame.camera_to_world, &t.pose, &format!("frame {k}"));
        assert_eq!(frame.camera, camera());
        let rgb = formats::read_rgb(capture.resolve(&frame.image))
            .unwrap()
            .image;
        let diff = rgb
            .data
            .iter()
            .zip(&t.rgb.data)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs()))
            .sum::<f32>()
            / (3 * rgb.data.len()) as f32;
        assert!(
            diff < colour_tolerance,
            "frame {k}: colour off by {diff} on average"
        );
        let depth = formats::read_depth(
            capture.resolve(frame.depth.as_ref().unwrap()),
            capture.depth_unit_scale_factor,
        )
        .unwrap();
        let expected = upsample_depth(&t.depth, WIDTH, HEIGHT);
        for (d, e) in depth.data.iter().zip(&expected.data) {
            assert!((d - e).abs() <= 0.0006, "frame {k}: depth {d} where {e}");
        }
    }
}

#[test]
fn a_3d_scanner_app_export_comes_back_in_neuroom_s_world() {
    let truth = true_frames(5);
    let src = tempfile::tempdir().unwrap();
    let k = camera();
    for (i, t) in truth.iter().enumerate() {
        let arkit = Pose::new(
            to_arkit() * t.pose.rotation,
            to_arkit() * t.pose.translation,
        );
        let rows: Vec<f64> = arkit.to_rows().iter().flatten().copied().collect();
        let meta = json!({
            "cameraPoseARFrame": rows,
            "intrinsics": [k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0],
            "motionQuality": 1.0,
        });
        std::fs::write(
            src.path().join(format!("frame_{i:05}.json")),
            meta.to_string(),
        )
        .unwrap();
        write_jpeg(&src.path().join(format!("frame_{i:05}.jpg")), &t.rgb);
        formats::write_depth(
            src.path().join(format!("depth_{i:05}.png")),
            &t.depth,
            0.001,
        )
        .unwrap();
        let confident = Image::filled(t.depth.width, t.depth.height, 2u16);
        formats::write_mask(src.path().join(format!("conf_{i:05}.png")), &confident).unwrap();
    }
    // A frame with only its JSON (the app keeps more poses than images) is skipped.
    std::fs::copy(
        src.path().join("frame_00000.json"),
        src.path().join("frame_00009.json"),
    )
    .unwrap();
    let out = tempfile::tempdir().unwrap();
    let mut recording = ScannerAppRecording::open(src.path(), 2).unwrap();
    let capture = import(&mut recording, out.path());
    assert_frames(&capture, &truth, 0.02);
}

#[test]
fn low_confidence_depth_is_left_out() {
    let truth = true_frames(1);
    let src = tempfile::tempdir().unwrap();
    let t = &truth[0];
    let arkit = Pose::new(
        to_arkit() * t.pose.rotation,
        to_arkit() * t.pose.translation,
    );
    let k = camera();
    let meta = json!({
        "cameraPoseARFrame": arkit.to_rows().iter().flatten().copied().collect::<Vec<f64>>(),
        "intrinsics": [k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0],
    });
    std::fs::write(src.path().join("frame_00000.json"), meta.to_string()).unwrap();
    write_jpeg(&src.path().join("frame_00000.jpg"), &t.rgb);
    formats::write_depth(src.path().join("depth_00000.png"), &t.depth, 0.001).unwrap();
    let mut confidence = Image::filled(t.depth.width, t.depth.height, 2u16);
    confidence.data[..t.depth.width as usize].fill(1);
    formats::write_mask(src.path().join("conf_00000.png"), &confidence).unwrap();
    let out = tempfile::tempdir().unwrap();
    let mut recording = ScannerAppRecording::open(src.path(), 2).unwrap();
    let capture = import(&mut recording, out.path());
    let depth = formats::read_depth(
        capture.resolve(capture.frames[0].depth.as_ref().unwrap()),
        0.001,
    )
    .unwrap();
    assert!(
        depth.data[..2 * WIDTH as usize].iter().all(|&d| d == 0.0),
        "the first source row is a hole"
    );
    assert!(depth.data[2 * WIDTH as usize..].iter().all(|&d| d > 0.9));
}

#[test]
fn nerfstudio_data_of_a_z_up_world_and_of_a_y_up_one_come_back_the_same() {
    let truth = true_frames(6);
    for world in [DMat3::IDENTITY, to_arkit()] {
        let src = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(src.path().join("images")).unwrap();
        std::fs::create_dir_all(src.path().join("depth")).unwrap();
        let k = camera();
        let frames: Vec<_> = truth
            .iter()
            .enumerate()
            .map(|(i, t)| {
                formats::write_rgb(src.path().join(format!("images/frame_{i:05}.png")), &t.rgb)
                    .unwrap();
                formats::write_depth(
                    src.path().join(format!("depth/frame_{i:05}.png")),
                    &t.depth,
                    0.001,
                )
                .unwrap();
                let pose = Pose::new(world * t.pose.rotation, world * t.pose.translation);
                json!({
                    "file_path": format!("./images/frame_{i:05}.png"),
                    "depth_file_path": format!("./depth/frame_{i:05}.png"),
                    "transform_matrix": pose.to_rows(),
                })
            })
            .collect();
        let transforms = json!({
            "camera_model": "OPENCV", "w": k.width, "h": k.height,
            "fl_x": k.fx, "fl_y": k.fy, "cx": k.cx, "cy": k.cy,
            "orientation_override": "none", "frames": frames,
        });
        std::fs::write(src.path().join("transforms.json"), transforms.to_string()).unwrap();
        let out = tempfile::tempdir().unwrap();
        let mut recording = NerfstudioRecording::open(src.path()).unwrap();
        let capture = import(&mut recording, out.path());
        // The up axis is found from the cameras and turned onto z by the smallest rotation: for
        // ARKit's y that is exactly `to_arkit`'s inverse, so both give the true poses back.
        assert_frames(&capture, &truth, 0.003);
    }
}

#[test]
fn stray_odometry_with_and_without_its_header_gives_the_opengl_cameras() {
    let truth = true_frames(4);
    let dir = tempfile::tempdir().unwrap();
    let flip = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
    let lines: Vec<String> = truth
        .iter()
        .map(|t| {
            // Stray writes ARKit's camera turned by 180° about x: OpenCV axes, ARKit's world.
            let rotation = to_arkit() * t.pose.rotation * flip;
            let q = DQuat::from_mat3(&rotation);
            let p = to_arkit() * t.pose.translation;
            format!(
                "{}, {}, {}, {}, {}, {}, {}",
                p.x, p.y, p.z, q.x, q.y, q.z, q.w
            )
        })
        .collect();
    let with_header: Vec<String> = lines
        .iter()
        .enumerate()
        .map(|(i, l)| format!("{}, {i:06}, {l}", 0.1 * i as f64))
        .collect();
    for (name, text) in [
        (
            "with header",
            format!(
                "timestamp, frame, x, y, z, qx, qy, qz, qw\n{}\n",
                with_header.join("\n")
            ),
        ),
        ("legacy", lines.join("\n")),
    ] {
        let path = dir.path().join("odometry.csv");
        std::fs::write(&path, text).unwrap();
        let rows = read_odometry(&path).unwrap();
        assert_eq!(rows.len(), truth.len(), "{name}");
        for (i, (row, t)) in rows.iter().zip(&truth).enumerate() {
            assert_eq!(row.frame, i as u64, "{name}");
            let ours = Pose::new(
                to_arkit().transpose() * row.camera_to_world.rotation,
                to_arkit().transpose() * row.camera_to_world.translation,
            );
            assert_same_pose(&ours, &t.pose, name);
        }
    }
    let matrix = dir.path().join("camera_matrix.csv");
    std::fs::write(
        &matrix,
        "1350.5, 0.0, 961.2\n0.0, 1350.5, 719.8\n0.0, 0.0, 1.0\n",
    )
    .unwrap();
    let camera = read_camera_matrix(
        &matrix,
        VideoSize {
            width: 1920,
            height: 1440,
        },
    )
    .unwrap();
    assert_eq!((camera.fx, camera.cx, camera.cy), (1350.5, 961.2, 719.8));
    let wrong = read_camera_matrix(
        &matrix,
        VideoSize {
            width: 640,
            height: 480,
        },
    )
    .unwrap_err();
    assert!(wrong.to_string().contains("camera_matrix.csv"), "{wrong}");
}

fn write_jpeg(path: &Path, rgb: &RgbImage) {
    let bytes: Vec<u8> = rgb
        .data
        .iter()
        .flatten()
        .map(|c| (c * 255.0).round() as u8)
        .collect();
    let buffer = image::RgbImage::from_raw(rgb.width, rgb.height, bytes).unwrap();
    let mut file = std::fs::File::create(path).unwrap();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut file, 95)
        .encode_image(&buffer)
        .unwrap();
}

#[test]
#[ignore = "needs Debian's ffmpeg (with libx265); .ci/run runs it where ffmpeg is installed"]
fn ffmpeg_a_stray_scanner_recording_comes_back_in_neuroom_s_world() {
    let truth = true_frames(8);
    let src = tempfile::tempdir().unwrap();
    let dir = src.path();
    let frames = dir.join("frames");
    for sub in ["frames", "depth", "confidence"] {
        std::fs::create_dir_all(dir.join(sub)).unwrap();
    }
    let flip = DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0));
    let mut odometry = String::from("timestamp, frame, x, y, z, qx, qy, qz, qw\n");
    for (i, t) in truth.iter().enumerate() {
        formats::write_rgb(frames.join(format!("{i:06}.png")), &t.rgb).unwrap();
        formats::write_depth(dir.join(format!("depth/{i:06}.png")), &t.depth, 0.001).unwrap();
        let confident = Image::filled(t.depth.width, t.depth.height, 2u16);
        formats::write_mask(dir.join(format!("confidence/{i:06}.png")), &confident).unwrap();
        let q = DQuat::from_mat3(&(to_arkit() * t.pose.rotation * flip));
        let p = to_arkit() * t.pose.translation;
        odometry += &format!(
            "{}, {i:06}, {}, {}, {}, {}, {}, {}, {}\n",
            i as f64 / 60.0,
            p.x,
            p.y,
            p.z,
            q.x,
            q.y,
            q.z,
            q.w
        );
    }
    std::fs::write(dir.join("odometry.csv"), odometry).unwrap();
    let k = camera();
    std::fs::write(
        dir.join("camera_matrix.csv"),
        format!(
            "{}, 0.0, {}\n0.0, {}, {}\n0.0, 0.0, 1.0\n",
            k.fx, k.cx, k.fy, k.cy
        ),
    )
    .unwrap();
    let encoded = std::process::Command::new("ffmpeg")
        .args(["-v", "error", "-y", "-framerate", "60", "-i"])
        .arg(frames.join("%06d.png"))
        .args([
            "-c:v",
            "libx265",
            "-x265-params",
            "log-level=error:lossless=1",
        ])
        .args(["-pix_fmt", "yuv444p"])
        .arg(dir.join("rgb.mp4"))
        .status()
        .unwrap();
    assert!(encoded.success());
    std::fs::remove_dir_all(&frames).unwrap();

    let opts = ImportOptions {
        max_frames: 4,
        ..options()
    };
    let mut recording = neuroom_import::stray::StrayRecording::open(dir, &opts).unwrap();
    let out = tempfile::tempdir().unwrap();
    let capture = import_recording(&mut recording, out.path(), &opts, &mut |_, _| {}).unwrap();
    // Four evenly spread frames of eight: 0, 2, 5 and 7.
    let picked: Vec<TrueFrame> = [0, 2, 5, 7]
        .iter()
        .map(|&i| TrueFrame {
            pose: truth[i].pose,
            rgb: truth[i].rgb.clone(),
            depth: truth[i].depth.clone(),
        })
        .collect();
    assert_frames(&capture, &picked, 0.01);
}

//! Every writer's output reads back to what was written, and the readers' conversions are reported.

use glam::{DMat3, DVec3, EulerRot};
use neuroom_core::Pose;
use neuroom_core::camera::Pinhole;
use neuroom_core::formats::{
    ArrangedObject, Arrangement, BackgroundSpec, Capture, CaptureDevice, Conversion, DepthNoise,
    Frame, Room, RoomObject, check_same_size, read_arrangement, read_capture, read_depth,
    read_image_size, read_intrinsics_file, read_mask, read_rgb, read_rgba, read_room,
    write_arrangement, write_capture, write_depth, write_mask, write_rgb, write_rgba, write_room,
};
use neuroom_core::image::Image;
use serde_json::json;
use std::path::{Path, PathBuf};

fn pose(yaw: f64, pitch: f64, roll: f64, t: [f64; 3]) -> Pose {
    Pose::new(
        DMat3::from_euler(EulerRot::ZYX, yaw, pitch, roll),
        DVec3::from(t),
    )
}

fn assert_pose_close(a: &Pose, b: &Pose) {
    assert!(a.rotation.abs_diff_eq(b.rotation, 1e-12), "{a:?} vs {b:?}");
    assert!(
        a.translation.abs_diff_eq(b.translation, 1e-12),
        "{a:?} vs {b:?}"
    );
}

fn room_object(id: u16, name: &str, capture: &str) -> RoomObject {
    RoomObject {
        id,
        name: name.into(),
        category: "chair".into(),
        capture: capture.into(),
        size: DVec3::new(0.5, 0.45, 0.9),
        capture_to_object: pose(0.4, 0.0, 0.0, [0.1, -0.2, 0.0]),
        relations: vec!["floor".into()],
    }
}

#[test]
fn room_round_trip_keeps_everything() {
    let dir = tempfile::tempdir().unwrap();
    let mut extra = serde_json::Map::new();
    extra.insert(
        "room_box".into(),
        json!({"min": [0, 0, 0], "max": [4, 3, 2.5]}),
    );
    let room = Room {
        root: dir.path().to_path_buf(),
        name: "study".into(),
        background: BackgroundSpec {
            capture: "captures/background".into(),
        },
        objects: vec![
            room_object(1, "chair_a", "captures/chair"),
            room_object(300, "chair_b", "captures/chair"),
            room_object(65535, "desk", "captures/desk"),
        ],
        extra,
    };
    write_room(dir.path(), &room).unwrap();
    let back = read_room(dir.path()).unwrap();
    assert_eq!(back.name, room.name);
    assert_eq!(back.extra, room.extra);
    assert_eq!(back.background, room.background);
    for (a, b) in back.objects.iter().zip(&room.objects) {
        assert_pose_close(&a.capture_to_object, &b.capture_to_object);
        assert_eq!(
            (a.id, &a.name, &a.capture, a.size, &a.relations),
            (b.id, &b.name, &b.capture, b.size, &b.relations)
        );
    }
    let groups = back.objects_by_capture();
    assert_eq!(groups.len(), 2);
    assert_eq!(groups[0].0, Path::new("captures/chair"));
    assert_eq!(
        groups[0].1.iter().map(|o| o.id).collect::<Vec<_>>(),
        vec![1, 300]
    );
    assert_eq!(back.object_by_name("desk").unwrap().id, 65535);
    assert_eq!(
        back.capture_dir(groups[1].0),
        dir.path().join("captures/desk")
    );
    // The same file read through its path.
    assert_eq!(
        read_room(dir.path().join("room.json"))
            .unwrap()
            .objects
            .len(),
        3
    );
}

#[test]
fn room_writer_refuses_what_the_reader_would_reject() {
    let dir = tempfile::tempdir().unwrap();
    let mut room = Room {
        root: PathBuf::new(),
        name: "r".into(),
        background: BackgroundSpec {
            capture: "bg".into(),
        },
        objects: vec![room_object(1, "a", "c"), room_object(1, "b", "c")],
        extra: Default::default(),
    };
    let err = write_room(dir.path(), &room).unwrap_err();
    assert_eq!(err.field.as_deref(), Some("objects[1].id"));
    room.objects[1].id = 2;
    room.objects[1].size.x = f64::NAN;
    assert_eq!(
        write_room(dir.path(), &room).unwrap_err().field.as_deref(),
        Some("objects[1].size")
    );
    assert!(!dir.path().join("room.json").exists());
}

fn frame(i: usize, camera: Pinhole) -> Frame {
    Frame {
        image: format!("images/{i:04}.png").into(),
        depth: Some(format!("depths/{i:04}.png").into()),
        instance: i
            .is_multiple_of(2)
            .then(|| format!("masks/{i:04}.png").into()),
        camera,
        camera_to_world: pose(0.3 * i as f64, -0.2, 0.1, [1.0, 2.0 - i as f64, 1.5]),
        light: (i == 1).then(|| "lamp_on".to_string()),
        extra: Default::default(),
    }
}

#[test]
fn capture_round_trip_with_per_frame_intrinsics_and_extras() {
    let dir = tempfile::tempdir().unwrap();
    let shared = Pinhole::new(64, 48, 60.0, 61.0, 32.0, 24.5);
    let odd =
        Pinhole::new(80, 60, 70.0, 70.0, 40.0, 30.0).with_distortion(0.01, -0.002, 0.0005, 0.0);
    let mut frames = vec![frame(0, shared), frame(1, odd), frame(2, shared)];
    frames[2].extra.insert("exposure".into(), json!(1.5));
    let mut extra = serde_json::Map::new();
    extra.insert(
        "lighting".into(),
        json!({"name": "capture_ceiling", "lights": [1, 2]}),
    );
    let capture = Capture {
        dir: dir.path().to_path_buf(),
        frames,
        depth_unit_scale_factor: 0.0005,
        device: CaptureDevice {
            auto_exposure: true,
            tracked_poses: false,
            depth_noise: Some(DepthNoise {
                at_0m: 0.004,
                per_m: 0.0025,
            }),
        },
        extra,
    };
    write_capture(dir.path(), &capture).unwrap();

    let text = std::fs::read_to_string(dir.path().join("transforms.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(
        v["fl_x"],
        json!(60.0),
        "top-level intrinsics come from the first frame"
    );
    assert!(v["frames"][0].get("fl_x").is_none() && v["frames"][1]["fl_x"] == json!(70.0));

    let back = read_capture(dir.path()).unwrap();
    assert_eq!(back.depth_unit_scale_factor, 0.0005);
    assert_eq!(back.device, capture.device);
    assert_eq!(v["auto_exposure"], json!(true));
    assert!(
        v.get("tracked_poses").is_none(),
        "false is the default, not written"
    );
    assert_eq!(back.extra, capture.extra);
    for (a, b) in back.frames.iter().zip(&capture.frames) {
        assert_pose_close(&a.camera_to_world, &b.camera_to_world);
        assert_eq!(
            (
                &a.image,
                &a.depth,
                &a.instance,
                a.camera,
                &a.light,
                &a.extra
            ),
            (
                &b.image,
                &b.depth,
                &b.instance,
                b.camera,
                &b.light,
                &b.extra
            )
        );
    }
    assert_eq!(
        back.resolve(&back.frames[0].image),
        dir.path().join("images/0000.png")
    );
}

#[test]
fn capture_without_camera_model_or_distortion_reads_with_defaults() {
    let dir = tempfile::tempdir().unwrap();
    let text = json!({"fl_x": 50, "fl_y": 50, "cx": 16, "cy": 12, "w": 32.0, "h": 24,
        "frames": [{"file_path": "a.png", "transform_matrix": Pose::IDENTITY.to_rows()}]});
    std::fs::write(dir.path().join("transforms.json"), text.to_string()).unwrap();
    let c = read_capture(dir.path()).unwrap();
    assert_eq!(c.depth_unit_scale_factor, 0.001);
    assert_eq!(
        c.frames[0].camera,
        Pinhole::new(32, 24, 50.0, 50.0, 16.0, 12.0)
    );
}

#[test]
fn a_photos_intrinsics_read_alone_or_from_a_transforms_top_level() {
    let dir = tempfile::tempdir().unwrap();
    let alone = dir.path().join("camera.json");
    let text = json!({"w": 64, "h": 48, "fl_x": 40, "fl_y": 41, "cx": 32, "cy": 24, "k1": 0.01});
    std::fs::write(&alone, text.to_string()).unwrap();
    let mut expected = Pinhole::new(64, 48, 40.0, 41.0, 32.0, 24.0);
    expected.k1 = 0.01;
    assert_eq!(read_intrinsics_file(&alone).unwrap(), expected);
    let transforms = dir.path().join("transforms.json");
    let text = json!({"camera_model": "OPENCV", "w": 64, "h": 48, "fl_x": 40, "fl_y": 41, "cx": 32,
        "cy": 24, "k1": 0.01, "frames": []});
    std::fs::write(&transforms, text.to_string()).unwrap();
    assert_eq!(read_intrinsics_file(&transforms).unwrap(), expected);
}

#[test]
fn arrangement_round_trip_keeps_extras_and_lighting() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("pano.json");
    let mut scored = ArrangedObject {
        id: 7,
        name: "lamp".into(),
        object_to_world: pose(1.0, 0.0, 0.0, [2.0, 1.0, 0.0]),
        extra: Default::default(),
    };
    scored.extra.insert("score".into(), json!(0.93));
    let mut extra = serde_json::Map::new();
    extra.insert("timings".into(), json!({"fit_s": 12.5}));
    let a = Arrangement {
        image: "pano.png".into(),
        camera_to_world: pose(-2.0, 0.0, 0.0, [1.0, 1.0, 1.6]),
        objects: vec![
            scored,
            ArrangedObject {
                id: 1,
                name: "bed".into(),
                object_to_world: Pose::IDENTITY,
                extra: Default::default(),
            },
        ],
        lighting: json!({"name": "warm"}),
        extra,
    };
    write_arrangement(&path, &a).unwrap();
    let back = read_arrangement(&path).unwrap();
    assert_eq!(
        (&back.image, &back.lighting, &back.extra),
        (&a.image, &a.lighting, &a.extra)
    );
    assert_pose_close(&back.camera_to_world, &a.camera_to_world);
    for (x, y) in back.objects.iter().zip(&a.objects) {
        assert_eq!((x.id, &x.name, &x.extra), (y.id, &y.name, &y.extra));
        assert_pose_close(&x.object_to_world, &y.object_to_world);
    }
    // No lighting: the field is left out and reads back as null.
    let bare = Arrangement {
        lighting: serde_json::Value::Null,
        ..a
    };
    write_arrangement(&path, &bare).unwrap();
    assert!(read_arrangement(&path).unwrap().lighting.is_null());
}

#[test]
fn colour_images_round_trip_exactly_at_byte_levels() {
    let dir = tempfile::tempdir().unwrap();
    let rgb = Image {
        width: 5,
        height: 3,
        data: (0..15)
            .map(|i| [i as f32 / 255.0, (100 + i) as f32 / 255.0, 1.0])
            .collect(),
    };
    write_rgb(dir.path().join("a.png"), &rgb).unwrap();
    let back = read_rgb(dir.path().join("a.png")).unwrap();
    assert!(back.conversions.is_empty());
    assert_eq!(back.image, rgb);
    let rgba_back = read_rgba(dir.path().join("a.png")).unwrap();
    assert_eq!(rgba_back.conversions, vec![Conversion::OpaqueAlphaAdded]);

    let rgba = Image {
        width: 2,
        height: 2,
        data: vec![
            [0.0, 0.2, 0.4, 0.0],
            [1.0, 1.0, 1.0, 1.0],
            [0.5, 0.5, 0.5, 0.5],
            [0.1, 0.9, 0.3, 1.0],
        ],
    };
    write_rgba(dir.path().join("b.png"), &rgba).unwrap();
    let back = read_rgba(dir.path().join("b.png")).unwrap();
    for (x, y) in back
        .image
        .data
        .iter()
        .flatten()
        .zip(rgba.data.iter().flatten())
    {
        assert!((x - y).abs() <= 0.5 / 255.0 + 1e-6);
    }
    assert_eq!(
        read_rgb(dir.path().join("b.png")).unwrap().conversions,
        vec![Conversion::AlphaDropped]
    );
    assert_eq!(read_image_size(dir.path().join("b.png")).unwrap(), (2, 2));
}

#[test]
fn depth_and_masks_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let depth = Image {
        width: 3,
        height: 2,
        data: vec![0.0, 1.234, 65.535, f32::INFINITY, 0.0004, 2.0],
    };
    write_depth(dir.path().join("d.png"), &depth, 0.001).unwrap();
    let back = read_depth(dir.path().join("d.png"), 0.001).unwrap();
    let expected = [0.0, 1.234, 65.535, 0.0, 0.001, 2.0];
    for (x, y) in back.data.iter().zip(expected) {
        assert!((x - y).abs() < 1e-6, "{x} vs {y}");
    }
    let err = write_depth(
        dir.path().join("e.png"),
        &Image {
            width: 2,
            height: 1,
            data: vec![1.0, -1.0],
        },
        0.001,
    )
    .unwrap_err();
    assert!(err.to_string().contains("pixel (1, 0)"), "{err}");

    for (name, ids, bits) in [
        ("m8.png", vec![0u16, 1, 255, 3], png::BitDepth::Eight),
        ("m16.png", vec![0, 256, 65535, 3], png::BitDepth::Sixteen),
    ] {
        let mask = Image {
            width: 2,
            height: 2,
            data: ids,
        };
        write_mask(dir.path().join(name), &mask).unwrap();
        assert_eq!(read_mask(dir.path().join(name)).unwrap(), mask);
        assert_eq!(png_header(&dir.path().join(name)).1, bits);
    }
}

/// Colour type and bit depth of a PNG file as stored.
fn png_header(path: &Path) -> (png::ColorType, png::BitDepth) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let reader = decoder.read_info().unwrap();
    (reader.info().color_type, reader.info().bit_depth)
}

/// Writes a PNG with the given layout through the `png` crate directly.
fn raw_png(
    path: &Path,
    w: u32,
    h: u32,
    color: png::ColorType,
    depth: png::BitDepth,
    palette: Option<&[u8]>,
    data: &[u8],
) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut e = png::Encoder::new(file, w, h);
    e.set_color(color);
    e.set_depth(depth);
    if let Some(p) = palette {
        e.set_palette(p.to_vec());
    }
    e.write_header().unwrap().write_image_data(data).unwrap();
}

#[test]
fn grayscale_palette_and_sixteen_bit_colour_are_converted_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let gray = dir.path().join("gray.png");
    raw_png(
        &gray,
        2,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Eight,
        None,
        &[0, 255],
    );
    let g = read_rgb(&gray).unwrap();
    assert_eq!(g.conversions, vec![Conversion::GrayToRgb]);
    assert_eq!(g.image.data, vec![[0.0; 3], [1.0; 3]]);

    let pal = dir.path().join("pal.png");
    raw_png(
        &pal,
        2,
        1,
        png::ColorType::Indexed,
        png::BitDepth::Eight,
        Some(&[255, 0, 0, 0, 0, 255]),
        &[1, 0],
    );
    let p = read_rgb(&pal).unwrap();
    assert_eq!(p.conversions, vec![Conversion::PaletteExpanded]);
    assert_eq!(p.image.data, vec![[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]]);

    let deep = dir.path().join("deep.png");
    raw_png(
        &deep,
        1,
        1,
        png::ColorType::Rgb,
        png::BitDepth::Sixteen,
        None,
        &[0xff, 0xff, 0x80, 0x00, 0x00, 0x00],
    );
    let d = read_rgb(&deep).unwrap();
    assert_eq!(d.conversions, vec![Conversion::SixteenBit]);
    assert!((d.image.data[0][1] - 32768.0 / 65535.0).abs() < 1e-7);

    let gray_depth = dir.path().join("gd.png");
    raw_png(
        &gray_depth,
        1,
        1,
        png::ColorType::Grayscale,
        png::BitDepth::Sixteen,
        None,
        &[0x01, 0x00],
    );
    assert_eq!(read_mask(&gray_depth).unwrap().data, vec![256]);
}

#[test]
fn jpeg_reads_as_rgb() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.jpg");
    let img = image::RgbImage::from_pixel(16, 8, image::Rgb([200, 100, 50]));
    img.save_with_format(&path, image::ImageFormat::Jpeg)
        .unwrap();
    let back = read_rgb(&path).unwrap();
    assert_eq!((back.image.width, back.image.height), (16, 8));
    let p = back.image.data[20];
    assert!(
        (p[0] - 200.0 / 255.0).abs() < 0.03 && (p[2] - 50.0 / 255.0).abs() < 0.03,
        "{p:?}"
    );
}

#[test]
fn size_mismatch_names_both_files() {
    let err = check_same_size(
        Path::new("rgb.png"),
        (320, 240),
        Path::new("depth.png"),
        (160, 120),
    )
    .unwrap_err();
    assert_eq!(err.path, Path::new("depth.png"));
    assert!(
        err.to_string().contains("rgb.png") && err.to_string().contains("160×120"),
        "{err}"
    );
    assert!(check_same_size(Path::new("a"), (1, 2), Path::new("b"), (1, 2)).is_ok());
}

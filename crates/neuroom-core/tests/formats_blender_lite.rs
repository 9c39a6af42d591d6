//! The externally rendered room `shared/data/blender-lite` (another tool wrote it) must read without
//! complaint: room.json, every capture, sample images/depths/masks, and every panorama with its arrangement.

use neuroom_core::camera::Equirect;
use neuroom_core::formats::{
    Room, check_same_size, read_arrangement, read_capture, read_depth, read_mask, read_rgb,
    read_rgba, read_room, write_capture, write_room,
};
use std::path::{Path, PathBuf};

/// The room folder; a test that needs it fails, naming it, when this checkout has no shared data
/// (those tests are ignored by default and run by `.ci/run` where it exists).
fn room_dir() -> PathBuf {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/blender-lite"
    ));
    assert!(
        dir.join("room.json").is_file(),
        "{} is absent: this test needs the shared data beside the checkout",
        dir.display()
    );
    dir
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_room_json_reads_with_its_objects_and_extras() {
    let dir = room_dir();
    let room = read_room(&dir).unwrap();
    assert_eq!(room.name, "kitchen");
    let names: Vec<_> = room
        .objects
        .iter()
        .map(|o| (o.id, o.name.as_str()))
        .collect();
    assert_eq!(names, vec![(1, "cabinet"), (2, "stool"), (3, "mixer")]);
    assert_eq!(
        room.object_by_name("mixer").unwrap().relations,
        vec!["on:cabinet"]
    );
    assert!(
        room.extra.contains_key("room_box"),
        "unknown fields are kept"
    );
    assert_eq!(room.objects_by_capture().len(), 3);
    let tmp = tempfile::tempdir().unwrap();
    write_room(tmp.path(), &room).unwrap();
    let again = read_room(tmp.path()).unwrap();
    assert_eq!(again.objects, room.objects);
    assert_eq!(again.extra, room.extra);
}

/// Every capture of the room with the number of frames the README promises.
fn captures(room: &Room) -> Vec<(PathBuf, usize, Option<u16>)> {
    let mut out = vec![(room.capture_dir(&room.background.capture), 60, None)];
    out.extend(
        room.objects
            .iter()
            .map(|o| (room.capture_dir(&o.capture), 80, Some(o.id))),
    );
    out
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_every_capture_reads_and_its_files_match_the_cameras() {
    let dir = room_dir();
    let room = read_room(&dir).unwrap();
    for (capture_dir, frames, id) in captures(&room) {
        let capture = read_capture(&capture_dir).unwrap();
        assert_eq!(capture.frames.len(), frames, "{}", capture_dir.display());
        assert_eq!(capture.depth_unit_scale_factor, 0.001);
        assert!(capture.extra.contains_key("lighting"));
        for frame in &capture.frames {
            assert!(capture.resolve(&frame.image).is_file());
            let c = frame.camera;
            assert_eq!((c.cx, c.cy), (c.width as f64 / 2.0, c.height as f64 / 2.0));
        }
        for frame in capture.frames.iter().step_by(frames / 3) {
            check_frame_files(&capture.dir, frame, capture.depth_unit_scale_factor, id);
        }
        let tmp = tempfile::tempdir().unwrap();
        write_capture(tmp.path(), &capture).unwrap();
        let again = read_capture(tmp.path()).unwrap();
        assert_eq!(again.extra, capture.extra);
        assert_eq!(again.frames.len(), capture.frames.len());
    }
}

/// Reads one frame's colour, depth and mask and checks sizes and value ranges.
fn check_frame_files(dir: &Path, frame: &neuroom_core::formats::Frame, unit: f64, id: Option<u16>) {
    let size = (frame.camera.width, frame.camera.height);
    let image_path = dir.join(&frame.image);
    let rgba = read_rgba(&image_path).unwrap();
    check_same_size(
        Path::new("transforms.json"),
        size,
        &image_path,
        (rgba.image.width, rgba.image.height),
    )
    .unwrap();
    let depth_path = dir.join(frame.depth.as_ref().unwrap());
    let depth = read_depth(&depth_path, unit).unwrap();
    check_same_size(&image_path, size, &depth_path, (depth.width, depth.height)).unwrap();
    assert!(depth.data.iter().all(|&d| (0.0..20.0).contains(&d)));
    assert!(depth.data.iter().any(|&d| d > 0.1));
    let mask_path = dir.join(frame.instance.as_ref().unwrap());
    let mask = read_mask(&mask_path).unwrap();
    check_same_size(&image_path, size, &mask_path, (mask.width, mask.height)).unwrap();
    match id {
        None => assert!(mask.data.iter().all(|&m| m == 0)),
        Some(id) => {
            assert!(mask.data.iter().all(|&m| m == 0 || m == id) && mask.data.contains(&id))
        }
    }
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_every_panorama_and_arrangement_reads() {
    let dir = room_dir();
    let room = read_room(&dir).unwrap();
    let pano_dir = dir.join("panoramas");
    let mut arrangements: Vec<_> = std::fs::read_dir(&pano_dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    arrangements.sort();
    assert_eq!(arrangements.len(), 4);
    for path in arrangements {
        let a = read_arrangement(&path).unwrap();
        assert_eq!(a.objects.len(), 3);
        for o in &a.objects {
            assert_eq!(room.object_by_id(o.id).unwrap().name, o.name);
        }
        assert!(a.lighting.get("name").is_some());
        let image_path = pano_dir.join(&a.image);
        let rgb = read_rgb(&image_path).unwrap();
        Equirect::new(rgb.image.width, rgb.image.height).unwrap();
        let stem = image_path.file_stem().unwrap().to_str().unwrap();
        let depth = read_depth(pano_dir.join(format!("{stem}.depth.png")), 0.001).unwrap();
        let mask = read_mask(pano_dir.join(format!("{stem}.mask.png"))).unwrap();
        assert_eq!(
            (depth.width, mask.width),
            (rgb.image.width, rgb.image.width)
        );
        assert!(
            depth.data.iter().all(|&d| d > 0.0 && d < 10.0),
            "the room is closed"
        );
        for id in 1..=3 {
            assert!(mask.data.contains(&id), "{stem}: object {id} visible");
        }
    }
}

//! `neuroom degrade --phone` on the tiny room of neuroom-core's tests: a room `inspect_room` accepts,
//! the same seed writing the same files, poses off by what a phone's tracking drifts, and the
//! panoramas and ground truth left as they were.

use std::path::{Path, PathBuf};

use neuroom::degrade::degrade_room;
use neuroom::formats::{self, read_capture};
use neuroom::train::TrainQuiet;

fn tiny_room() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny")
}

fn files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(files(&path));
        } else {
            out.push((
                path.strip_prefix(dir).unwrap().to_path_buf(),
                std::fs::read(&path).unwrap(),
            ));
        }
    }
    out.sort();
    out
}

#[test]
fn a_phone_degraded_room_is_a_room_with_the_same_truth() {
    let scratch = tempfile::tempdir().unwrap();
    let (a, b) = (scratch.path().join("a"), scratch.path().join("b"));
    let degraded = degrade_room(&tiny_room(), &a, 3, &mut |_, _| {}).unwrap();
    degrade_room(&tiny_room(), &b, 3, &mut |_, _| {}).unwrap();
    assert_eq!(files(&a), files(&b), "the same seed writes the same files");
    neuroom::inspect_room(&a).unwrap();

    let room = formats::read_room(tiny_room().join("room.json")).unwrap();
    let capture = |root: &Path| read_capture(root.join(&room.background.capture)).unwrap();
    let (exact, phone) = (capture(&tiny_room()), capture(&a));
    assert_eq!(phone.frames.len(), exact.frames.len());
    // The copy says what a phone does, so training corrects its frames.
    assert!(phone.device.auto_exposure && phone.device.tracked_poses);
    assert!(!exact.device.auto_exposure && !exact.device.tracked_poses);
    for (p, e) in phone.frames.iter().zip(&exact.frames) {
        let cm = (p.camera_to_world.translation - e.camera_to_world.translation).length() * 100.0;
        assert!((0.99..=2.01).contains(&cm), "{cm} cm");
    }
    let objects: usize = room
        .objects_by_capture()
        .iter()
        .map(|(c, _)| read_capture(tiny_room().join(c)).unwrap().frames.len())
        .sum();
    assert_eq!(degraded.frames, exact.frames.len() + objects);
    for (name, bytes) in files(&tiny_room().join("panoramas")) {
        assert_eq!(
            std::fs::read(a.join("panoramas").join(&name)).unwrap(),
            bytes,
            "{}",
            name.display()
        );
    }
    let again = degrade_room(&tiny_room(), &a, 3, &mut |_, _| {}).unwrap_err();
    assert!(
        again.to_string().contains("already holds a room"),
        "{again}"
    );
}

#[test]
fn a_room_naming_a_capture_outside_its_folder_is_refused_and_nothing_is_written() {
    let scratch = tempfile::tempdir().unwrap();
    let room = scratch.path().join("room");
    std::fs::create_dir(&room).unwrap();
    let text = std::fs::read_to_string(tiny_room().join("room.json")).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    json["background"]["capture"] = "../shared/background".into();
    std::fs::write(room.join("room.json"), json.to_string()).unwrap();
    let out = scratch.path().join("out");
    let err = degrade_room(&room, &out, 3, &mut |_, _| {}).unwrap_err();
    let message = format!("{err:#}");
    assert!(
        message.contains("room.json") && message.contains("outside the room folder"),
        "{message}"
    );
    assert!(!out.exists(), "nothing is written");
    assert!(!scratch.path().join("shared").exists());
}

/// A suite room names its background again under `in_room/` by a relative link: the copy keeps the
/// link, which then names the degraded background; a link out of the room is copied as its file.
#[cfg(unix)]
#[test]
fn links_inside_the_room_stay_links_and_links_out_of_it_are_copied() {
    use std::os::unix::fs::symlink;
    let scratch = tempfile::tempdir().unwrap();
    let room = scratch.path().join("room");
    neuroom_testing::copy_folder(&tiny_room(), &room);
    let background = formats::read_room(room.join("room.json"))
        .unwrap()
        .background
        .capture;
    std::fs::create_dir_all(room.join("in_room/captures")).unwrap();
    let inside = Path::new("../..").join(&background);
    symlink(&inside, room.join("in_room/captures/background")).unwrap();
    std::fs::write(scratch.path().join("notes.txt"), "outside").unwrap();
    symlink(scratch.path().join("notes.txt"), room.join("notes.txt")).unwrap();

    let out = scratch.path().join("out");
    degrade_room(&room, &out, 3, &mut |_, _| {}).unwrap();
    let link = out.join("in_room/captures/background");
    assert_eq!(std::fs::read_link(&link).unwrap(), inside);
    assert_eq!(
        std::fs::read(link.join("transforms.json")).unwrap(),
        std::fs::read(out.join(&background).join("transforms.json")).unwrap(),
        "the link names the degraded background"
    );
    assert!(
        !std::fs::symlink_metadata(out.join("notes.txt"))
            .unwrap()
            .is_symlink()
    );
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "outside"
    );
}

#[test]
fn training_a_phone_copy_writes_the_refined_poses_of_its_training_frames() {
    let scratch = tempfile::tempdir().unwrap();
    let copy = scratch.path().join("copy");
    degrade_room(&tiny_room(), &copy, 3, &mut |_, _| {}).unwrap();
    let options = neuroom::train::TrainOptions::steps_only(40, 40, 0, 2);
    let trained =
        neuroom::train::train_room(&copy, &scratch.path().join("models"), &options, &TrainQuiet)
            .unwrap();
    let models = neuroom::scene::load_models(&trained.dir).unwrap();
    let room = formats::read_room(copy.join("room.json")).unwrap();
    for (entry, refined) in models.manifest.models.iter().zip(&models.refined_poses) {
        let refined = refined
            .as_ref()
            .expect("a tracked capture's poses are refined");
        let capture_dir = match entry.ids.first() {
            Some(id) => &room.objects.iter().find(|o| o.id == *id).unwrap().capture,
            None => &room.background.capture,
        };
        let capture = read_capture(copy.join(capture_dir)).unwrap();
        let holdout = options.config().holdout;
        let training: Vec<usize> = (0..capture.frames.len())
            .filter(|i| i % holdout != 0)
            .collect();
        let indices: Vec<usize> = refined.frames.iter().map(|f| f.index).collect();
        assert_eq!(indices, training, "{}", entry.name);
        for f in &refined.frames {
            let given = &capture.frames[f.index];
            assert_eq!(f.image, given.image);
            let cm = (f.camera_to_world.translation - given.camera_to_world.translation).length()
                * 100.0;
            assert!(cm < 5.0, "{}: frame {} moved {cm} cm", entry.name, f.index);
        }
    }
}

//! Automatic object masks end to end: the tiny preset generated with its objects captured in the room,
//! its background model trained briefly, the masks written into a capture (which `inspect_room` then
//! accepts and reports) and scored against the true ones.

use std::path::Path;

use neuroom::masks::{WorldBox, bench_masks, write_capture_masks};
use neuroom::synth::{CapturePlacement, synthesize};
use neuroom::train::{TrainOptions, TrainQuiet, train_room};

/// Background steps: enough for the tiny room's floor and walls to be within a centimetre.
const BACKGROUND_STEPS: u64 = 600;

fn in_room_tiny(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf) {
    let room = dir.join("tiny");
    synthesize(
        "tiny",
        &room,
        0,
        None,
        &[],
        CapturePlacement::InRoom,
        &mut |_| {},
    )
    .unwrap();
    let options = TrainOptions {
        only: vec!["background".into()],
        ..TrainOptions::steps_only(0, BACKGROUND_STEPS, 0, 2)
    };
    let models = train_room(&room, &dir.join("models"), &options, &TrainQuiet)
        .unwrap()
        .dir;
    (room, models)
}

#[test]
fn automatic_masks_match_the_true_ones_and_are_written() {
    let scratch = tempfile::tempdir().unwrap();
    let (room_dir, models) = in_room_tiny(scratch.path());
    let room = neuroom::read_room(&room_dir).unwrap();

    let report = bench_masks(&room, &models, &mut |_| {}).unwrap();
    assert_eq!(report.objects.len(), room.objects.len());
    assert!(report.worst_iou >= MIN_IOU, "{report:?}");

    let name = &room.objects[0].name;
    let written = write_capture_masks(&room, &models, name, None).unwrap();
    assert!(
        written.coverage > 0.01 && written.coverage < 0.9,
        "{written:?}"
    );
    let capture = neuroom::formats::read_capture(&written.capture).unwrap();
    assert!(capture.frames.iter().all(|f| {
        f.instance
            .as_ref()
            .is_some_and(|m| m.to_string_lossy().starts_with("masks/auto-"))
    }));
    let inspected = neuroom::inspect_room(&room_dir).unwrap();
    let coverage = inspected
        .object_captures
        .iter()
        .find(|c| c.dir == written.capture)
        .unwrap()
        .mask_coverage;
    assert!(
        (coverage - written.coverage).abs() < 1e-9,
        "{coverage} against {written:?}"
    );

    // A box away from the object holds none of it.
    let corner = WorldBox::parse("0.05,0.05,0.05,0.3,0.3,0.3").unwrap();
    let empty = write_capture_masks(&room, &models, name, Some(corner)).unwrap();
    assert_eq!(empty.coverage, 0.0);
}

#[test]
fn masks_name_what_is_missing() {
    let scratch = tempfile::tempdir().unwrap();
    let room_dir = scratch.path().join("tiny");
    synthesize(
        "tiny",
        &room_dir,
        0,
        None,
        &[],
        CapturePlacement::InRoom,
        &mut |_| {},
    )
    .unwrap();
    let room = neuroom::read_room(&room_dir).unwrap();
    let error = write_capture_masks(&room, scratch.path(), "sofa", None).unwrap_err();
    assert!(
        format!("{error:#}").contains("no object `sofa`"),
        "{error:#}"
    );
    let error =
        write_capture_masks(&room, scratch.path(), &room.objects[0].name, None).unwrap_err();
    assert!(format!("{error:#}").contains("manifest.json"), "{error:#}");
}

/// The worst object's IoU the tiny room's masks reach with its briefly trained background.
const MIN_IOU: f64 = 0.95;

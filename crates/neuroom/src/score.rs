//! FORMAT.md's object metrics of a solved arrangement against its ground truth, shared by `locate`'s
//! benchmark and `export`'s report.

use glam::DVec3;
use neuroom_core::formats::{Arrangement, Room};
use neuroom_core::metrics::{ArrangementScore, GtObject, PredictedObject, evaluate_arrangement};

/// Scores `predicted` against `truth`. `describe(id)` gives each true object's model (instances of one model
/// are interchangeable in the matching) and box size; objects it knows nothing of are left out.
pub fn score_arrangement(
    truth: &Arrangement,
    predicted: &Arrangement,
    describe: impl Fn(u16) -> Option<(String, DVec3)>,
) -> ArrangementScore {
    let gt: Vec<GtObject> = truth
        .objects
        .iter()
        .filter_map(|o| {
            let (model, size) = describe(o.id)?;
            Some(GtObject {
                id: o.id,
                model,
                size,
                object_to_world: o.object_to_world,
            })
        })
        .collect();
    let pred: Vec<PredictedObject> = predicted
        .objects
        .iter()
        .map(|o| PredictedObject {
            id: o.id,
            object_to_world: o.object_to_world,
        })
        .collect();
    evaluate_arrangement(&gt, &pred)
}

/// Scores `predicted` against `truth` with the object sizes of `room` (room.json); instances of one
/// capture are interchangeable.
pub fn score_in_room(
    room: &Room,
    truth: &Arrangement,
    predicted: &Arrangement,
) -> ArrangementScore {
    score_arrangement(truth, predicted, |id| {
        let r = room.objects.iter().find(|r| r.id == id)?;
        Some((r.capture.to_string_lossy().into_owned(), r.size))
    })
}

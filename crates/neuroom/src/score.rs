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

/// One line per true object of `score`, named from `room` (room.json): its IoU, rotation and position
/// errors, or that it was missed. What a benchmark prints to show which objects a mean hides.
pub fn object_lines(room: &Room, score: &ArrangementScore) -> Vec<String> {
    score
        .objects
        .iter()
        .map(|o| {
            let name = room.object_by_id(o.id).map_or("?", |r| r.name.as_str());
            match (o.rotation_error_deg, o.position_error_cm) {
                (Some(rotation), Some(position)) => format!(
                    "{name} (id {}): IoU {:.1} %, rotation {rotation:.1}°, position {position:.1} cm",
                    o.id, o.iou_percent
                ),
                _ => format!("{name} (id {}): missed", o.id),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::formats::{BackgroundSpec, RoomObject};
    use neuroom_core::metrics::ObjectScore;
    use neuroom_core::pose::Pose;

    #[test]
    fn object_lines_name_each_true_object_and_say_which_were_missed() {
        let object = |id, name: &str| RoomObject {
            id,
            name: name.into(),
            category: name.into(),
            capture: format!("captures/{name}").into(),
            size: DVec3::ONE,
            capture_to_object: Pose::IDENTITY,
            relations: vec!["floor".into()],
        };
        let room = Room {
            root: "room".into(),
            name: "room".into(),
            background: BackgroundSpec {
                capture: "captures/background".into(),
            },
            objects: vec![object(1, "bed"), object(2, "lamp")],
            extra: Default::default(),
        };
        let row = |id, found: bool| ObjectScore {
            id,
            predicted_id: found.then_some(id),
            iou_percent: if found { 81.25 } else { 0.0 },
            rotation_error_deg: found.then_some(2.0),
            yaw_error_deg: found.then_some(2.0),
            position_error_cm: found.then_some(3.5),
        };
        let score = ArrangementScore {
            objects: vec![row(1, true), row(2, false)],
            mean_iou_percent: Some(40.6),
            mean_rotation_error_deg: Some(2.0),
            mean_yaw_error_deg: Some(2.0),
            mean_position_error_cm: Some(3.5),
            missed: 1,
            precision: 1.0,
            recall: 0.5,
        };
        assert_eq!(
            object_lines(&room, &score),
            [
                "bed (id 1): IoU 81.2 %, rotation 2.0°, position 3.5 cm",
                "lamp (id 2): missed"
            ]
        );
    }
}

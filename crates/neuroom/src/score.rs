//! docs/formats.md's object metrics of a solved arrangement against its ground truth, shared by `locate`'s
//! benchmark, `eval` and `export`'s report; and the shape symmetries of a room's objects, read from its
//! ground-truth meshes, for the rotation error up to symmetry beside ARE.

use std::collections::HashMap;

use anyhow::Context;
use glam::DVec3;
use neuroom_core::formats::{Arrangement, Room};
use neuroom_core::mesh::read_ply;
use neuroom_core::metrics::{
    ArrangementScore, GtObject, PredictedObject, Symmetry, evaluate_arrangement,
};
use neuroom_train::symmetry::shape_symmetry;

/// Scores `predicted` against `truth`. `describe(id)` gives each true object's model (instances of one model
/// are interchangeable in the matching), box size and shape symmetry; objects it knows nothing of are
/// left out.
pub fn score_arrangement(
    truth: &Arrangement,
    predicted: &Arrangement,
    describe: impl Fn(u16) -> Option<(String, DVec3, Symmetry)>,
) -> ArrangementScore {
    let gt: Vec<GtObject> = truth
        .objects
        .iter()
        .filter_map(|o| {
            let (model, size, symmetry) = describe(o.id)?;
            Some(GtObject {
                id: o.id,
                model,
                size,
                object_to_world: o.object_to_world,
                symmetry,
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

/// The shape symmetry of each object of a room, by id: read from its ground-truth mesh
/// (`meshes/<name>.ply`) where the room has one, none where it has not.
#[derive(Clone, Debug, Default)]
pub struct ShapeSymmetries(HashMap<u16, Symmetry>);

impl ShapeSymmetries {
    /// Reads one mesh per capture of `room` (instances share a shape: the first of them that has a
    /// mesh) and finds its symmetry. A mesh that cannot be read is an error naming it.
    pub fn of_room(room: &Room) -> anyhow::Result<Self> {
        let mut by_id = HashMap::new();
        for (_, members) in room.objects_by_capture() {
            let Some((o, path)) = members
                .iter()
                .map(|o| (o, room.truth_mesh_path(o)))
                .find(|(_, p)| p.is_file())
            else {
                continue;
            };
            let mesh = read_ply(&path)
                .with_context(|| format!("reading the shape of object `{}`", o.name))?;
            let symmetry = shape_symmetry(&mesh);
            by_id.extend(members.iter().map(|m| (m.id, symmetry)));
        }
        Ok(Self(by_id))
    }

    /// The symmetry of object `id` (none when unknown).
    pub fn of(&self, id: u16) -> Symmetry {
        self.0.get(&id).copied().unwrap_or_default()
    }
}

/// Scores `predicted` against `truth` with the object sizes of `room` (room.json) and their shape
/// `symmetries`; instances of one capture are interchangeable.
pub fn score_in_room(
    room: &Room,
    symmetries: &ShapeSymmetries,
    truth: &Arrangement,
    predicted: &Arrangement,
) -> ArrangementScore {
    score_arrangement(truth, predicted, |id| {
        let r = room.objects.iter().find(|r| r.id == id)?;
        Some((
            r.capture.to_string_lossy().into_owned(),
            r.size,
            symmetries.of(id),
        ))
    })
}

/// One line per true object of `score`, named from `room` (room.json): its IoU, rotation (and, where its
/// shape's symmetry lowers it, the rotation error up to that) and position errors, or that it was
/// missed. What a benchmark prints to show which objects a mean hides.
pub fn object_lines(room: &Room, score: &ArrangementScore) -> Vec<String> {
    score
        .objects
        .iter()
        .map(|o| {
            let name = room.object_by_id(o.id).map_or("?", |r| r.name.as_str());
            match (o.rotation_error_deg, o.position_error_cm) {
                (Some(rotation), Some(position)) => {
                    let folded = o
                        .rotation_error_up_to_symmetry_deg
                        .filter(|f| *f < rotation - 0.05)
                        .map_or(String::new(), |f| format!(" ({f:.1}° up to symmetry)"));
                    format!(
                        "{name} (id {}): IoU {:.1} %, rotation {rotation:.1}°{folded}, position \
                         {position:.1} cm",
                        o.id, o.iou_percent
                    )
                }
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

    fn room_at(root: &std::path::Path, objects: Vec<RoomObject>) -> Room {
        Room {
            root: root.into(),
            name: "room".into(),
            background: BackgroundSpec {
                capture: "captures/background".into(),
            },
            objects,
            extra: Default::default(),
        }
    }

    #[test]
    fn a_round_objects_heading_is_left_out_of_the_rotation_error_up_to_symmetry() {
        use neuroom_core::formats::ArrangedObject;
        use neuroom_core::mesh::{TriMesh, write_ply};
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("meshes")).unwrap();
        // A drum of 64 sides (the vase) and a long box (the table, alike under a half turn); the lamp
        // has no mesh.
        let mut drum = TriMesh::default();
        let ring = |z: f32| -> Vec<glam::Vec3> {
            (0..64)
                .map(|k| {
                    let a = std::f32::consts::TAU * k as f32 / 64.0;
                    glam::Vec3::new(0.1 * a.cos(), 0.1 * a.sin(), z)
                })
                .collect()
        };
        drum.positions.extend(ring(-0.15));
        drum.positions.extend(ring(0.15));
        drum.positions.extend([
            glam::Vec3::new(0.0, 0.0, -0.15),
            glam::Vec3::new(0.0, 0.0, 0.15),
        ]);
        for k in 0..64u32 {
            let j = (k + 1) % 64;
            drum.triangles.extend([
                [k, j, 64 + j],
                [k, 64 + j, 64 + k],
                [128, j, k],
                [129, 64 + k, 64 + j],
            ]);
        }
        write_ply(&dir.path().join("meshes/vase.ply"), &drum).unwrap();
        let table = TriMesh::cuboid(
            glam::Vec3::new(-0.6, -0.3, -0.2),
            glam::Vec3::new(0.6, 0.3, 0.2),
            2,
        );
        write_ply(&dir.path().join("meshes/table.ply"), &table).unwrap();
        let room = room_at(
            dir.path(),
            vec![object(1, "vase"), object(2, "table"), object(3, "lamp")],
        );
        let symmetries = ShapeSymmetries::of_room(&room).unwrap();
        assert_eq!(
            [1, 2, 3].map(|id| symmetries.of(id)),
            [Symmetry::Continuous, Symmetry::Turns(2), Symmetry::None]
        );
        let at = |id, yaw_deg: f64| ArrangedObject {
            id,
            name: String::new(),
            object_to_world: Pose::from_yaw_translation(
                yaw_deg.to_radians(),
                DVec3::new(f64::from(id), 0.0, 0.5),
            ),
            extra: Default::default(),
        };
        let arrangement = |objects| Arrangement {
            image: "p.png".into(),
            camera_to_world: Pose::IDENTITY,
            objects,
            lighting: serde_json::Value::Null,
            extra: Default::default(),
        };
        let truth = arrangement(vec![at(1, 0.0), at(2, 0.0), at(3, 0.0)]);
        let found = arrangement(vec![at(1, 100.0), at(2, 170.0), at(3, 170.0)]);
        let score = score_in_room(&room, &symmetries, &truth, &found);
        let plain: Vec<f64> = score
            .objects
            .iter()
            .map(|o| o.rotation_error_deg.unwrap())
            .collect();
        let folded: Vec<f64> = score
            .objects
            .iter()
            .map(|o| o.rotation_error_up_to_symmetry_deg.unwrap())
            .collect();
        for (got, want) in plain.iter().zip([100.0, 170.0, 170.0]) {
            assert!((got - want).abs() < 1e-6, "{plain:?}");
        }
        for (got, want) in folded.iter().zip([0.0, 10.0, 170.0]) {
            assert!((got - want).abs() < 1e-6, "{folded:?}");
        }
        assert!((score.mean_rotation_error_up_to_symmetry_deg.unwrap() - 60.0).abs() < 1e-6);
        let lines = object_lines(&room, &score);
        assert!(
            lines[0].contains("rotation 100.0° (0.0° up to symmetry)"),
            "{lines:?}"
        );
        assert!(lines[2].contains("rotation 170.0°, position"), "{lines:?}");
    }

    fn object(id: u16, name: &str) -> RoomObject {
        RoomObject {
            id,
            name: name.into(),
            category: name.into(),
            capture: format!("captures/{name}").into(),
            size: DVec3::ONE,
            capture_to_object: Pose::IDENTITY,
            relations: vec!["floor".into()],
        }
    }

    #[test]
    fn object_lines_name_each_true_object_and_say_which_were_missed() {
        let room = room_at("room".as_ref(), vec![object(1, "bed"), object(2, "lamp")]);
        let row = |id, found: bool| ObjectScore {
            id,
            predicted_id: found.then_some(id),
            iou_percent: if found { 81.25 } else { 0.0 },
            rotation_error_deg: found.then_some(2.0),
            rotation_error_up_to_symmetry_deg: found.then_some(2.0),
            yaw_error_deg: found.then_some(2.0),
            position_error_cm: found.then_some(3.5),
        };
        let score = ArrangementScore {
            objects: vec![row(1, true), row(2, false)],
            mean_iou_percent: Some(40.6),
            mean_rotation_error_deg: Some(2.0),
            mean_rotation_error_up_to_symmetry_deg: Some(2.0),
            mean_yaw_error_deg: Some(2.0),
            mean_position_error_cm: Some(3.5),
            placed_share: 0.5,
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

//! Several views of one arrangement (photos from a robot turning on the spot, or from several places)
//! make one arrangement: each view is located and searched on its own, then their objects are merged.
//! An object seen by several views is found several times, each time from its own pixels; the best
//! scored sighting stands for it. Objects are taken best first; one that repeats an object already
//! taken (its model, its centre within reach) or would stand inside one is left out, as is one more
//! than its model has instances.

use neuroom_core::obb::OrientedBox;
use neuroom_panorama::ObjectModel;

use crate::objects::{Found, SearchConfig, stands_inside};

/// Two sightings of one model are one object when their centres are closer than this fraction of the
/// model's largest horizontal extent…
const SAME_OBJECT_FRACTION: f64 = 0.5;

/// …or closer than this (metres), for small objects.
const SAME_OBJECT_MIN_DISTANCE: f64 = 0.25;

/// The objects of all `views` (each as [`crate::objects::find_objects`] returns them, with `models`
/// the list they index) as one list, best scored first, ids reassigned per model in that order.
pub fn merge_views(
    views: &[Vec<Found>],
    models: &[ObjectModel],
    config: &SearchConfig,
) -> Vec<Found> {
    let mut all: Vec<&Found> = views.iter().flatten().collect();
    all.sort_by(|a, b| b.score.total_cmp(&a.score));
    let mut taken: Vec<Found> = Vec::new();
    let mut boxes: Vec<OrientedBox> = Vec::new();
    for found in all {
        let model = &models[found.model];
        let pose = found.pose();
        let reach = (SAME_OBJECT_FRACTION * 2.0 * model.half.x.max(model.half.y) as f64)
            .max(SAME_OBJECT_MIN_DISTANCE);
        let repeats = taken.iter().any(|t| {
            t.model == found.model && t.pose().translation.distance(pose.translation) < reach
        });
        let instances = taken.iter().filter(|t| t.model == found.model).count();
        if repeats || instances >= model.ids.len() || stands_inside(&boxes, model, &pose, config) {
            continue;
        }
        boxes.push(model.box_at(&pose));
        taken.push(Found {
            id: model.ids[instances],
            ..found.clone()
        });
    }
    taken
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DVec3, Vec3};
    use neuroom_core::pose::Pose;
    use neuroom_panorama::Support;
    use neuroom_panorama::cloud::Cloud;

    fn model(ids: Vec<u16>, half: Vec3) -> ObjectModel {
        ObjectModel {
            ids,
            half,
            coarse: Cloud::default(),
            fine: Cloud::default(),
            support: Support::Floor,
            against_wall: false,
        }
    }

    fn found(model: usize, id: u16, at: DVec3, score: f64) -> Found {
        Found {
            model,
            id,
            object_to_world: Pose::from_yaw_translation(0.0, at).to_rows(),
            score,
            explained: 0,
        }
    }

    #[test]
    fn a_repeated_sighting_counts_once_and_identical_instances_stay_apart() {
        let models = vec![
            model(vec![1, 2], Vec3::new(0.3, 0.3, 0.4)),
            model(vec![3], Vec3::new(1.0, 0.8, 0.3)),
        ];
        let views = vec![
            vec![
                found(0, 1, DVec3::new(1.0, 1.0, 0.4), 50.0),
                found(1, 3, DVec3::new(3.0, 1.0, 0.3), 80.0),
            ],
            vec![
                // The same chair seen again, 10 cm off and scored lower.
                found(0, 1, DVec3::new(1.1, 1.0, 0.4), 40.0),
                // Its twin, elsewhere.
                found(0, 1, DVec3::new(1.0, 2.5, 0.4), 30.0),
                // A chair inside the bed: a wrong sighting.
                found(0, 2, DVec3::new(3.0, 1.1, 0.4), 35.0),
            ],
        ];
        let merged = merge_views(&views, &models, &SearchConfig::default());
        let summary: Vec<(u16, f64)> = merged.iter().map(|f| (f.id, f.score)).collect();
        assert_eq!(summary, vec![(3, 80.0), (1, 50.0), (2, 30.0)]);
    }
}

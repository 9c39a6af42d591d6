//! Random object poses that follow the room's rules: upright on the floor, upright with the back against
//! a wall, or on top of an instance of another model (`ObjectModel::placement`); every box inside the
//! room's free space, none overlapping another, none around the camera.

use glam::{DVec3, Vec3};
use neuroom_core::obb::OrientedBox;
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use neuroom_panorama::database::{DatabaseEntry, floor_below};
use neuroom_panorama::sphere::direction;
use neuroom_panorama::{ObjectModel, Support};
use rand::Rng;
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::compose::RoomSource;

/// The most models a label map can name (labels are bytes; 0 is the background).
pub const MAX_MODELS: usize = 254;

/// How objects are placed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PlaceConfig {
    /// Chance that a model appears in a panorama.
    pub presence: f64,
    /// Random poses tried per instance before it is left out.
    pub tries: usize,
    /// Least horizontal distance between the camera and an object's box (metres).
    pub camera_clearance: f64,
    /// Range of the height of a wall object's centre above the floor (metres).
    pub wall_height: [f64; 2],
    /// Floor positions are drawn this far beyond the database cameras' extent (metres).
    pub floor_margin: f64,
    /// Boxes are shrunk by this fraction before they are tested against each other and the room, so
    /// that objects may touch (a lamp on a nightstand, a picture on its wall).
    pub contact_tolerance: f64,
}

impl Default for PlaceConfig {
    fn default() -> Self {
        Self {
            presence: 0.8,
            tries: 40,
            camera_clearance: 0.4,
            wall_height: [0.9, 1.9],
            floor_margin: 0.6,
            contact_tolerance: 0.04,
        }
    }
}

/// Random poses (box centres) of random instances of `models` in the room seen from `entry`'s camera:
/// floor and wall models first, then the models that stand on them.
pub fn place_objects<F: Field>(
    room: RoomSource<F>,
    entry: &DatabaseEntry,
    models: &[ObjectModel],
    config: &PlaceConfig,
    rng: &mut Pcg64,
) -> Vec<(usize, Pose)> {
    let floor = floor_below(room.field, entry.position, entry.position.z - 10.0)
        .unwrap_or(entry.position.z - 1.5) as f64;
    let models = &models[..models.len().min(MAX_MODELS)];
    let order = models
        .iter()
        .enumerate()
        .filter(|(_, m)| !matches!(m.support, Support::On(_)))
        .chain(
            models
                .iter()
                .enumerate()
                .filter(|(_, m)| matches!(m.support, Support::On(_))),
        );
    let mut placed: Vec<(usize, Pose)> = Vec::new();
    for (m, model) in order {
        if !rng.random_bool(config.presence) {
            continue;
        }
        let count = rng.random_range(1..=model.ids.len().max(1));
        for _ in 0..count {
            let pose = (0..config.tries).find_map(|_| {
                let pose = random_pose(room, entry, floor, models, &placed, m, config, rng)?;
                let free = fits_room(room.field, model, &pose, config)
                    && !collides(models, &placed, model, &pose, config)
                    && clear_of_camera(entry, model, &pose, config);
                free.then_some(pose)
            });
            if let Some(pose) = pose {
                placed.push((m, pose));
            }
        }
    }
    placed
}

/// One pose of model `m` where its placement says it may stand (not yet checked against the room).
#[allow(clippy::too_many_arguments)]
fn random_pose<F: Field>(
    room: RoomSource<F>,
    entry: &DatabaseEntry,
    floor: f64,
    models: &[ObjectModel],
    placed: &[(usize, Pose)],
    m: usize,
    config: &PlaceConfig,
    rng: &mut Pcg64,
) -> Option<Pose> {
    let model = &models[m];
    let half = model.half.as_dvec3();
    let yaw = rng.random_range(0.0..std::f64::consts::TAU);
    match model.support {
        Support::Floor => {
            let (lo, hi) = floor_extent(room, config.floor_margin);
            let x = rng.random_range(lo.x..=hi.x);
            let y = rng.random_range(lo.y..=hi.y);
            let t = DVec3::new(x, y, floor + half.z);
            Some(Pose::from_yaw_translation(yaw, t))
        }
        Support::Wall => wall_pose(room, entry, floor, half, config, rng),
        Support::On(base) => {
            let supports: Vec<&Pose> = placed
                .iter()
                .filter(|(k, _)| *k == base)
                .map(|(_, p)| p)
                .collect();
            let support = supports.get(rng.random_range(0..supports.len().max(1)))?;
            let base_half = models.get(base)?.half.as_dvec3();
            let reach = (base_half - 0.5 * half).max(DVec3::ZERO);
            let local = DVec3::new(
                rng.random_range(-reach.x..=reach.x),
                rng.random_range(-reach.y..=reach.y),
                base_half.z + half.z,
            );
            let t = support.transform_point(local);
            Some(Pose::from_yaw_translation(yaw, t))
        }
    }
}

/// The horizontal extent of the database cameras, grown by `margin`.
fn floor_extent<F>(room: RoomSource<F>, margin: f64) -> (DVec3, DVec3) {
    let (lo, hi) = room.database.entries.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), e| (lo.min(e.position), hi.max(e.position)),
    );
    let grow = DVec3::new(margin, margin, 0.0);
    (lo.as_dvec3() - grow, hi.as_dvec3() + grow)
}

/// A pose with the back (−x face) against the wall the camera sees in a random direction at the
/// horizon, facing into the room, its centre at a random height.
fn wall_pose<F: Field>(
    room: RoomSource<F>,
    entry: &DatabaseEntry,
    floor: f64,
    half: DVec3,
    config: &PlaceConfig,
    rng: &mut Pcg64,
) -> Option<Pose> {
    let (w, h) = (room.database.width, room.database.height);
    let u = rng.random_range(0..w);
    let depth = entry.depth[(h / 2) * w + u];
    if depth <= 0.0 {
        return None;
    }
    let camera = entry.camera_to_world();
    let dir = camera.transform_vector(direction(u as f64 + 0.5, h as f64 / 2.0, w, h));
    let point = camera.translation + dir * depth as f64;
    let mut sdf = [0.0];
    let mut gradient = [Vec3::ZERO];
    room.field
        .sdf_gradient(&[point.as_vec3()], &mut sdf, &mut gradient);
    let n = gradient[0].as_dvec3();
    if n.z.abs() > 0.3 || n.length_squared() < 1e-12 {
        return None;
    }
    let mut n = DVec3::new(n.x, n.y, 0.0).normalize();
    if n.dot(camera.translation - point) < 0.0 {
        n = -n;
    }
    let height = rng.random_range(config.wall_height[0]..=config.wall_height[1]);
    let mut t = point + n * (half.x + 0.005);
    t.z = (floor + height).max(floor + half.z);
    Some(Pose::from_yaw_translation(n.y.atan2(n.x), t))
}

/// The box of `model` at `pose`, shrunk by the contact tolerance.
fn shrunk_box(model: &ObjectModel, pose: &Pose, config: &PlaceConfig) -> OrientedBox {
    let size = 2.0 * (1.0 - config.contact_tolerance) * model.half.as_dvec3();
    OrientedBox::new(*pose, size)
}

/// Whether the (shrunk) box lies in the room's free space: its corners, face centres and centre are
/// all outside the room's surfaces.
fn fits_room<F: Field>(field: &F, model: &ObjectModel, pose: &Pose, config: &PlaceConfig) -> bool {
    let b = shrunk_box(model, pose, config);
    let h = 0.5 * b.size;
    let mut points: Vec<Vec3> = b.corners().iter().map(|c| c.as_vec3()).collect();
    for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
        for sign in [-1.0, 1.0] {
            points.push(pose.transform_point(sign * axis * h).as_vec3());
        }
    }
    points.push(pose.translation.as_vec3());
    let mut sdf = vec![0.0; points.len()];
    field.sdf(&points, &mut sdf);
    sdf.iter().all(|s| *s > 0.0)
}

/// Whether `model` at `pose` overlaps an object already placed (boxes shrunk by the contact tolerance).
fn collides(
    models: &[ObjectModel],
    placed: &[(usize, Pose)],
    model: &ObjectModel,
    pose: &Pose,
    config: &PlaceConfig,
) -> bool {
    let candidate = shrunk_box(model, pose, config);
    placed.iter().any(|(k, p)| {
        let other = shrunk_box(&models[*k], p, config);
        candidate.intersection_volume(&other) > 1e-9
    })
}

/// Whether the box leaves the camera its clearance (horizontally, in the box's frame).
fn clear_of_camera(
    entry: &DatabaseEntry,
    model: &ObjectModel,
    pose: &Pose,
    config: &PlaceConfig,
) -> bool {
    let local = pose.inverse().transform_point(entry.position.as_dvec3());
    let half = model.half.as_dvec3();
    let outside = DVec3::new(
        (local.x.abs() - half.x).max(0.0),
        (local.y.abs() - half.y).max(0.0),
        0.0,
    );
    outside.length() > config.camera_clearance
}

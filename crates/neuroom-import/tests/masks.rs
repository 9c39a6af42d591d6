//! Automatic object masks against the known answer: an analytic room (a box seen from inside) with a
//! block standing on its floor, depth ray-cast exactly, the true mask where the block is hit first.

use glam::{DVec2, DVec3, Vec3};
use neuroom_core::camera::{CameraModel, Pinhole, look_at};
use neuroom_import::masks::{
    DepthFrame, MaskOptions, ObjectMasks, RoomSurface, WorldBox, mask_iou, object_masks,
};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const ROOM: DVec3 = DVec3::new(4.0, 3.5, 2.6);

/// The empty room's inside distance, shifted by `offset` (a model's error).
struct BoxRoom {
    offset: f32,
}

impl RoomSurface for BoxRoom {
    fn signed_distance(&self, points: &[Vec3], out: &mut [f32]) {
        let size = ROOM.as_vec3();
        for (p, d) in points.iter().zip(out) {
            *d = p.min(size - *p).min_element() + self.offset;
        }
    }
}

/// The block standing on the floor: a low cabinet.
fn block() -> (DVec3, DVec3) {
    (DVec3::new(1.6, 1.5, 0.0), DVec3::new(2.3, 1.9, 0.6))
}

/// Distance along a ray to where it leaves the room (the camera is inside).
fn room_exit(origin: DVec3, dir: DVec3) -> f64 {
    (0..3)
        .map(|a| {
            if dir[a] > 0.0 {
                (ROOM[a] - origin[a]) / dir[a]
            } else if dir[a] < 0.0 {
                -origin[a] / dir[a]
            } else {
                f64::INFINITY
            }
        })
        .fold(f64::INFINITY, f64::min)
}

/// Distance along a ray to where it enters the block, if it does.
fn block_entry(origin: DVec3, dir: DVec3) -> Option<f64> {
    let (lo, hi) = block();
    let (mut near, mut far) = (0.0f64, f64::INFINITY);
    for a in 0..3 {
        let (t0, t1) = ((lo[a] - origin[a]) / dir[a], (hi[a] - origin[a]) / dir[a]);
        near = near.max(t0.min(t1));
        far = far.min(t0.max(t1));
    }
    (near <= far).then_some(near)
}

/// Frames around the block, their depth (with Gaussian noise of `noise` metres) and true masks.
fn scan(views: usize, noise: f64, seed: u64) -> (Vec<DepthFrame>, Vec<Vec<bool>>) {
    let camera = Pinhole::new(96, 72, 80.0, 80.0, 48.0, 36.0);
    let (lo, hi) = block();
    let centre = (lo + hi) / 2.0;
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut frames = Vec::new();
    let mut truths = Vec::new();
    for v in 0..views {
        let angle = v as f64 / views as f64 * std::f64::consts::TAU;
        let eye = centre
            + DVec3::new(
                1.4 * angle.cos(),
                1.4 * angle.sin(),
                0.6 + 0.5 * (v % 3) as f64 / 2.0,
            );
        let pose = look_at(eye, centre);
        let mut depth = Vec::new();
        let mut truth = Vec::new();
        for y in 0..camera.height {
            for x in 0..camera.width {
                let pixel = DVec2::new(x as f64 + 0.5, y as f64 + 0.5);
                let local = camera.direction(pixel);
                let dir = pose.transform_vector(local);
                let room = room_exit(eye, dir);
                let object = block_entry(eye, dir).filter(|t| *t < room);
                let t = object.unwrap_or(room);
                let z = t * -local.z + noise * normal(&mut rng);
                depth.push(z as f32);
                truth.push(object.is_some());
            }
        }
        frames.push(DepthFrame {
            camera,
            camera_to_world: pose,
            depth,
        });
        truths.push(truth);
    }
    (frames, truths)
}

/// The masks of `frames` cut by the box room `offset` off its true surface.
fn masks_of(frames: &[DepthFrame], offset: f32, bounds: Option<WorldBox>) -> ObjectMasks {
    object_masks(frames, &BoxRoom { offset }, bounds, &MaskOptions::default()).unwrap()
}

fn normal(rng: &mut Pcg64) -> f64 {
    let (u, v): (f64, f64) = (rng.random_range(1e-12..1.0), rng.random());
    (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
}

#[test]
fn masks_match_the_truth_with_a_proposed_box() {
    let (frames, truth) = scan(24, 0.0, 1);
    let found = masks_of(&frames, 0.0, None);
    let iou = mask_iou(&found.masks, &truth);
    assert!(iou >= 0.95, "IoU {iou}");
    let (lo, hi) = block();
    assert!(
        found.bounds.contains(lo + 0.01) && found.bounds.contains(hi - 0.01),
        "{:?}",
        found.bounds
    );
    assert!(
        (found.bounds.max - found.bounds.min).max_element() < 1.2,
        "{:?}",
        found.bounds
    );
}

#[test]
fn masks_hold_under_depth_noise_and_a_model_error() {
    let (frames, truth) = scan(24, 0.005, 2);
    // The trained surface 8 mm off the true one everywhere.
    let found = masks_of(&frames, 0.008, None);
    let iou = mask_iou(&found.masks, &truth);
    assert!(iou >= 0.95, "IoU {iou}, tolerance {}", found.tolerance);
    assert!(
        found.tolerance > 0.015,
        "the tolerance follows the residuals: {}",
        found.tolerance
    );
}

#[test]
fn a_given_box_bounds_the_masks() {
    let (frames, truth) = scan(12, 0.0, 3);
    let (lo, hi) = block();
    let given = WorldBox {
        min: lo - 0.05,
        max: hi + 0.05,
    };
    let found = masks_of(&frames, 0.0, Some(given));
    assert_eq!(found.bounds, given);
    let iou = mask_iou(&found.masks, &truth);
    assert!(iou >= 0.95, "IoU {iou}");
    // A box beside the object holds none of it.
    let beside = WorldBox {
        min: DVec3::new(0.2, 0.2, 0.0),
        max: DVec3::new(0.8, 0.8, 1.0),
    };
    let empty = masks_of(&frames, 0.0, Some(beside));
    assert!(empty.masks.iter().all(|m| m.pixels.iter().all(|p| !p)));
}

#[test]
fn an_empty_room_has_no_object_to_propose() {
    let (mut frames, _) = scan(6, 0.0, 4);
    // Depth of the bare room: every ray to the walls.
    for frame in &mut frames {
        let camera = frame.camera;
        for (i, d) in frame.depth.iter_mut().enumerate() {
            let (x, y) = (i as u32 % camera.width, i as u32 / camera.width);
            let local = camera.direction(DVec2::new(x as f64 + 0.5, y as f64 + 0.5));
            let dir = frame.camera_to_world.transform_vector(local);
            *d = (room_exit(frame.camera_to_world.translation, dir) * -local.z) as f32;
        }
    }
    let error = object_masks(
        &frames,
        &BoxRoom { offset: 0.0 },
        None,
        &MaskOptions::default(),
    )
    .unwrap_err();
    assert!(
        error.to_string().contains("no object stands in front"),
        "{error}"
    );
}

#[test]
fn boxes_parse_from_two_corners() {
    let parsed = WorldBox::parse("2, 1, 0.8, 1,2,0").unwrap();
    assert_eq!(parsed.min, DVec3::new(1.0, 1.0, 0.0));
    assert_eq!(parsed.max, DVec3::new(2.0, 2.0, 0.8));
    assert!(
        WorldBox::parse("1,2,3")
            .unwrap_err()
            .contains("six numbers")
    );
    assert!(
        WorldBox::parse("0,0,0,1,1,0")
            .unwrap_err()
            .contains("empty")
    );
    assert!(WorldBox::parse("0,0,0,1,x,1").is_err());
}

//! Rooms the unit tests look at: the ray distances of a panorama taken inside a box room.

use glam::{DVec2, Vec3};
use neuroom_core::camera::{CameraModel, Equirect};

/// Ray distances of a `w × h` panorama taken at the origin of the camera frame inside the box room
/// `[low, high]` (which holds the origin).
pub fn box_room_depth(w: usize, h: usize, low: Vec3, high: Vec3) -> Vec<f32> {
    let camera = Equirect {
        width: w as u32,
        height: h as u32,
    };
    (0..w * h)
        .map(|p| {
            let pixel = DVec2::new((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
            let d = camera.direction(pixel).as_vec3();
            let wall = Vec3::select(d.cmpgt(Vec3::ZERO), high, low);
            (wall / d)
                .to_array()
                .into_iter()
                .filter(|t| t.is_finite() && *t > 0.0)
                .fold(100.0, f32::min)
        })
        .collect()
}

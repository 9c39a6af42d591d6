//! Camera placement for captures: look-at poses in the OpenGL camera frame of transforms.json,
//! object views spread over a sphere band around the origin, and background views standing in
//! the empty room looking across it.

use std::f64::consts::{PI, TAU};

use glam::DVec3;
use neuroom_core::Pose;
use neuroom_core::camera::look_at;
use rand::Rng;
use rand_pcg::Pcg64;

/// `count` cameras at `distance` from the origin looking at it, elevations spread uniformly in
/// area between `elevation_deg` bounds and azimuths by the golden angle, with a little jitter.
pub fn sphere_band(
    count: u32,
    distance: f64,
    elevation_deg: [f64; 2],
    rng: &mut Pcg64,
) -> Vec<Pose> {
    let (s0, s1) = (
        elevation_deg[0].to_radians().sin(),
        elevation_deg[1].to_radians().sin(),
    );
    let golden = PI * (3.0 - 5f64.sqrt());
    let phase = rng.random_range(0.0..TAU);
    (0..count)
        .map(|i| {
            let f = (i as f64 + rng.random_range(0.25..0.75)) / count as f64;
            let elevation = (s0 + (s1 - s0) * f).asin();
            let azimuth = phase + golden * i as f64;
            let eye = distance
                * DVec3::new(
                    elevation.cos() * azimuth.cos(),
                    elevation.cos() * azimuth.sin(),
                    elevation.sin(),
                );
            look_at(eye, DVec3::ZERO)
        })
        .collect()
}

/// `count` views inside a room `[0, W] × [0, D]`: eyes 0.8–1.8 m high and at least `margin` from
/// the walls, each looking at a random point at least 1.2 m away horizontally, pitched −35°…20°.
pub fn room_views(count: u32, size: DVec3, margin: f64, rng: &mut Pcg64) -> Vec<Pose> {
    (0..count)
        .map(|_| {
            let eye = DVec3::new(
                rng.random_range(margin..size.x - margin),
                rng.random_range(margin..size.y - margin),
                rng.random_range(0.8..1.8),
            );
            let target = loop {
                let t = DVec3::new(
                    rng.random_range(0.0..size.x),
                    rng.random_range(0.0..size.y),
                    eye.z,
                );
                if (t - eye).length() >= 1.2 {
                    break t;
                }
            };
            let horizontal = (target - eye).normalize();
            let pitch = rng.random_range(-35f64..20.0).to_radians();
            let dir = horizontal * pitch.cos() + DVec3::Z * pitch.sin();
            look_at(eye, eye + dir)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn band_stays_in_its_elevations() {
        let mut rng = Pcg64::seed_from_u64(1);
        for p in sphere_band(80, 2.0, [-15.0, 80.0], &mut rng) {
            let e = (p.translation.z / p.translation.length())
                .asin()
                .to_degrees();
            assert!((-15.0..=80.0).contains(&e) && (p.translation.length() - 2.0).abs() < 1e-9);
        }
    }
}

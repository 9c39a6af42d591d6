//! Surface normals from a depth image, for lighting augmentation and for the near-surface SDF targets.
//!
//! Each valid pixel is back-projected to its camera-frame point `P(u, v)`; the tangents are finite
//! differences to the neighbours, central where both neighbours are valid and on the same surface, one-sided
//! otherwise, and the normal is their cross product, turned to face the camera (`n · P < 0`). Two pixels lie
//! on the same surface when their z-depths differ by less than [`MAX_RELATIVE_STEP`] of the depth or
//! than [`MAX_SLOPE`] pixel footprints (`z / f`), whichever is larger, so silhouettes do not tilt normals
//! while steep but continuous surfaces keep theirs. Pixels without a usable neighbour pair get the normal facing straight
//! back along the ray.

use glam::{DVec2, DVec3};
use neuroom_core::camera::{CameraModel, Pinhole};

/// Largest relative z-depth step between neighbours taken to be on the same surface.
pub const MAX_RELATIVE_STEP: f64 = 0.03;

/// Largest z-depth step between neighbours on the same surface, in pixel footprints (a slope of ≈ 79°).
pub const MAX_SLOPE: f64 = 5.0;

/// Unit normals (camera frame, facing the camera) of the pixels where `valid` holds and `z > 0`; zero
/// elsewhere. `z` is the pinhole z-depth in metres, row-major.
pub fn normals_from_depth(camera: &Pinhole, z: &[f32], valid: &[bool]) -> Vec<[f32; 3]> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let ok = |i: usize| valid[i] && z[i] > 0.0;
    let point = |i: usize| {
        let px = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        camera.unproject(px, z[i] as f64)
    };
    let footprint = 1.0 / camera.fx.min(camera.fy);
    let same = |i: usize, j: usize| {
        let limit = z[i] as f64 * MAX_RELATIVE_STEP.max(MAX_SLOPE * footprint);
        ok(j) && ((z[i] - z[j]).abs() as f64) <= limit
    };
    let tangent = |i: usize, prev: Option<usize>, next: Option<usize>| -> Option<DVec3> {
        let p = prev.filter(|&j| same(i, j));
        let q = next.filter(|&j| same(i, j));
        match (p, q) {
            (Some(a), Some(b)) => Some(point(b) - point(a)),
            (None, Some(b)) => Some(point(b) - point(i)),
            (Some(a), None) => Some(point(i) - point(a)),
            (None, None) => None,
        }
    };
    (0..w * h)
        .map(|i| {
            if !ok(i) {
                return [0.0; 3];
            }
            let (u, v) = (i % w, i / w);
            let du = tangent(i, (u > 0).then(|| i - 1), (u + 1 < w).then(|| i + 1));
            let dv = tangent(i, (v > 0).then(|| i - w), (v + 1 < h).then(|| i + w));
            let p = point(i);
            let n = match (du, dv) {
                (Some(a), Some(b)) => a.cross(b).normalize_or_zero(),
                _ => DVec3::ZERO,
            };
            let n = if n == DVec3::ZERO { -p.normalize() } else { n };
            let n = if n.dot(p) > 0.0 { -n } else { n };
            n.as_vec3().to_array()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilted_plane_gives_its_normal_facing_the_camera() {
        let cam = Pinhole::new(40, 30, 35.0, 35.0, 20.0, 15.0);
        // Plane n · X = −2 with n tilted toward the camera (camera looks along −z).
        let n = DVec3::new(0.3, -0.2, 1.0).normalize();
        let z: Vec<f32> = (0..40 * 30)
            .map(|i| {
                let d = cam.direction(DVec2::new((i % 40) as f64 + 0.5, (i / 40) as f64 + 0.5));
                let t = -2.0 / n.dot(d);
                (-(d * t).z) as f32
            })
            .collect();
        let normals = normals_from_depth(&cam, &z, &vec![true; 40 * 30]);
        for got in normals {
            let got = DVec3::from(got.map(f64::from));
            assert!((got - n).length() < 1e-3, "{got} vs {n}");
        }
    }
}

//! The equirectangular projection of docs/formats.md at any resolution, with its Jacobian, for direct
//! alignment: continuous pixel coordinates of a camera-frame point and their derivatives.

use glam::{DMat3, DVec2, DVec3};

/// Unit camera-frame direction through continuous pixel coordinates `(x, y)` of a `width × height`
/// panorama.
pub fn direction(x: f64, y: f64, width: usize, height: usize) -> DVec3 {
    use std::f64::consts::PI;
    let lon = PI * (1.0 - 2.0 * x / width as f64);
    let lat = PI * (0.5 - y / height as f64);
    let (sl, cl) = lat.sin_cos();
    let (so, co) = lon.sin_cos();
    DVec3::new(cl * co, cl * so, sl)
}

/// Neighbours of pixel `i` of a `w × h` panorama (4-connected; columns wrap round, rows do not).
pub fn neighbours(i: usize, w: usize, h: usize) -> impl Iterator<Item = usize> {
    let (u, v) = (i % w, i / w);
    let left = v * w + (u + w - 1) % w;
    let right = v * w + (u + 1) % w;
    let up = (v > 0).then(|| i - w);
    let down = (v + 1 < h).then(|| i + w);
    [Some(left), Some(right), up, down].into_iter().flatten()
}

/// Continuous pixel coordinates of camera-frame point `p`, or `None` on the vertical axis (no longitude).
pub fn project(p: DVec3, width: usize, height: usize) -> Option<DVec2> {
    use std::f64::consts::PI;
    let rho2 = p.x * p.x + p.y * p.y;
    if rho2 < 1e-12 {
        return None;
    }
    let lon = p.y.atan2(p.x);
    let lat = p.z.atan2(rho2.sqrt());
    Some(DVec2::new(
        0.5 * width as f64 * (1.0 - lon / PI),
        height as f64 * (0.5 - lat / PI),
    ))
}

/// [`project`] and its Jacobian: rows `∂x/∂p` and `∂y/∂p` (as the rows of the returned matrix's
/// transpose: `jac.row(0)`, `jac.row(1)`; the third row is zero).
pub fn project_jacobian(p: DVec3, width: usize, height: usize) -> Option<(DVec2, DMat3)> {
    use std::f64::consts::PI;
    let pixel = project(p, width, height)?;
    let rho2 = p.x * p.x + p.y * p.y;
    let rho = rho2.sqrt();
    let r2 = rho2 + p.z * p.z;
    // lon = atan2(y, x); lat = atan2(z, ρ).
    let d_lon = DVec3::new(-p.y / rho2, p.x / rho2, 0.0);
    let d_lat = DVec3::new(-p.x * p.z / (r2 * rho), -p.y * p.z / (r2 * rho), rho / r2);
    let dx = d_lon * (-0.5 * width as f64 / PI);
    let dy = d_lat * (-(height as f64) / PI);
    Some((pixel, DMat3::from_cols(dx, dy, DVec3::ZERO).transpose()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::camera::{CameraModel, Equirect};

    #[test]
    fn projection_matches_the_core_camera_and_inverts_direction() {
        let cam = Equirect::new(64, 32).unwrap();
        for p in [DVec3::new(1.0, 0.3, -0.2), DVec3::new(-0.4, -2.0, 1.1)] {
            let ours = project(p, 64, 32).unwrap();
            let (theirs, _) = cam.project(p).unwrap();
            assert!(ours.abs_diff_eq(theirs, 1e-9));
            let d = direction(ours.x, ours.y, 64, 32);
            assert!(d.abs_diff_eq(p.normalize(), 1e-9));
        }
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let p = DVec3::new(0.7, -1.3, 0.4);
        let (_, jac) = project_jacobian(p, 128, 64).unwrap();
        let h = 1e-6;
        for a in 0..3 {
            let mut e = DVec3::ZERO;
            e[a] = h;
            let num =
                (project(p + e, 128, 64).unwrap() - project(p - e, 128, 64).unwrap()) / (2.0 * h);
            assert!((num.x - jac.row(0)[a]).abs() < 1e-5, "x/{a}");
            assert!((num.y - jac.row(1)[a]).abs() < 1e-5, "y/{a}");
        }
    }
}

//! Surface normals from a depth image, for lighting augmentation and for the near-surface SDF targets.
//!
//! Each valid pixel is back-projected to its camera-frame point `P(u, v)`; the normal is the cross
//! product of the tangents along the image's rows and columns, turned to face the camera (`n · P < 0`).
//! Pixels without usable tangents get the normal facing straight back along the ray.
//!
//! - **Exact depth** (a renderer's): the tangents are finite differences to the neighbours, central
//!   where both neighbours are valid and on the same surface, one-sided otherwise. Two pixels lie on
//!   the same surface when their z-depths differ by less than [`MAX_RELATIVE_STEP`] of the depth or
//!   than [`MAX_SLOPE`] pixel footprints (`z / f`), whichever is larger, so silhouettes do not tilt
//!   normals while steep but continuous surfaces keep theirs.
//! - **Noisy depth** (a capture that declares its [`DepthNoise`], a phone's LiDAR): a difference of
//!   neighbours turns the noise into the normal's direction (a phone's σ of 2 cm at 3 m against a
//!   pixel footprint of about 1 cm tilts normals by tens of degrees), so the depth is fitted by a
//!   plane in the image, `z ≈ c + a·Δu + b·Δv`, by least squares over the same-surface pixels of a
//!   window whose radius is the smallest that brings the fitted slope's error from the noise at that
//!   distance under [`NOISY_NORMAL_TOLERANCE_DEG`] (at most [`MAX_FIT_RADIUS`]); the tangents are
//!   those of the fitted plane. Exact depth keeps the neighbours: its normals are the same bits as
//!   before noisy depth was handled.

use glam::{DMat3, DVec2, DVec3};
use neuroom_core::camera::{CameraModel, Pinhole};
use neuroom_core::formats::transforms::DepthNoise;

/// Largest relative z-depth step between neighbours taken to be on the same surface.
pub const MAX_RELATIVE_STEP: f64 = 0.03;

/// Largest z-depth step between neighbours on the same surface, in pixel footprints (a slope of ≈ 79°).
pub const MAX_SLOPE: f64 = 5.0;

/// The error of a normal fitted to noisy depth that its window is sized for (one standard deviation,
/// degrees). At 5° the near-surface SDF target `(d − t) · |n · dir|` errs by under half a percent and
/// a colour relit by the normal by a few percent, both well under what the depth's own noise costs.
pub const NOISY_NORMAL_TOLERANCE_DEG: f64 = 5.0;

/// Largest window radius (pixels) of a plane fitted to noisy depth: a 17 × 17 window, a tenth of a
/// phone depth map's width, beyond which the fit would round the room's edges and an object's parts
/// more than the noise it averages costs.
pub const MAX_FIT_RADIUS: usize = 8;

/// Unit normals (camera frame, facing the camera) of the pixels where `valid` holds and `z > 0`; zero
/// elsewhere. `z` is the pinhole z-depth in metres, row-major; `noise` is the depth's declared noise
/// (`None`: exact depth, normals from the neighbours; otherwise from fitted planes, see the module).
pub fn normals_from_depth(
    camera: &Pinhole,
    z: &[f32],
    valid: &[bool],
    noise: Option<DepthNoise>,
) -> Vec<[f32; 3]> {
    match noise {
        None => neighbour_normals(camera, z, valid),
        Some(noise) => fitted_normals(camera, z, valid, noise),
    }
}

/// Normals from finite differences to the neighbours (exact depth).
fn neighbour_normals(camera: &Pinhole, z: &[f32], valid: &[bool]) -> Vec<[f32; 3]> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let ok = |i: usize| valid[i] && z[i] > 0.0;
    let point = |i: usize| pixel_point(camera, (i % w) as f64, (i / w) as f64, z[i] as f64);
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
            facing_camera(n, p)
        })
        .collect()
}

/// The camera-frame point at z-depth `depth` through the centre of pixel `(u, v)`.
fn pixel_point(camera: &Pinhole, u: f64, v: f64, depth: f64) -> DVec3 {
    camera.unproject(DVec2::new(u + 0.5, v + 0.5), depth)
}

/// `n` turned to face the camera from point `p`; straight back along the ray when `n` is zero.
fn facing_camera(n: DVec3, p: DVec3) -> [f32; 3] {
    let n = if n == DVec3::ZERO { -p.normalize() } else { n };
    let n = if n.dot(p) > 0.0 { -n } else { n };
    n.as_vec3().to_array()
}

/// Normals of planes fitted to noisy depth over windows sized by the noise (see the module).
fn fitted_normals(camera: &Pinhole, z: &[f32], valid: &[bool], noise: DepthNoise) -> Vec<[f32; 3]> {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let ok = |i: usize| valid[i] && z[i] > 0.0;
    let focal = camera.fx.min(camera.fy);
    let at = |u: f64, v: f64, depth: f64| pixel_point(camera, u, v, depth);
    (0..w * h)
        .map(|i| {
            if !ok(i) {
                return [0.0; 3];
            }
            let (u, v) = (i % w, i / w);
            let zi = z[i] as f64;
            let p = at(u as f64, v as f64, zi);
            let sigma = noise.sigma_at(p.length() as f32) as f64;
            let radius = fit_radius(sigma, zi, focal);
            // Same surface: within the neighbours' step limit per pixel of offset, plus the noise.
            let step = zi * MAX_RELATIVE_STEP.max(MAX_SLOPE / focal);
            let mut fit = PlaneFit::default();
            for v2 in v.saturating_sub(radius)..(v + radius + 1).min(h) {
                for u2 in u.saturating_sub(radius)..(u + radius + 1).min(w) {
                    let j = v2 * w + u2;
                    let (du, dv) = (u2 as f64 - u as f64, v2 as f64 - v as f64);
                    let limit = step * du.abs().max(dv.abs()) + 3.0 * sigma;
                    if ok(j) && (z[j] as f64 - zi).abs() <= limit {
                        fit.add(du, dv, z[j] as f64);
                    }
                }
            }
            let n = match fit.solve() {
                Some([c, a, b]) => {
                    let (uf, vf) = (u as f64, v as f64);
                    let du = at(uf + 1.0, vf, c + a) - at(uf - 1.0, vf, c - a);
                    let dv = at(uf, vf + 1.0, c + b) - at(uf, vf - 1.0, c - b);
                    du.cross(dv).normalize_or_zero()
                }
                None => DVec3::ZERO,
            };
            facing_camera(n, p)
        })
        .collect()
}

/// The smallest window radius whose plane fit brings the slope error from depth noise `sigma` at
/// z-depth `z` (metres) under [`NOISY_NORMAL_TOLERANCE_DEG`], for a camera of focal length `focal`
/// (pixels); at most [`MAX_FIT_RADIUS`]. The least-squares slope over a full `(2r + 1)²` window has
/// standard deviation `σ / √S`, `S = (2r + 1)² · r(r + 1) / 3`, in metres per pixel; a pixel spans
/// `z / f` across, so the normal tilts by about `σ f / (z √S)`.
fn fit_radius(sigma: f64, z: f64, focal: f64) -> usize {
    let tolerance = NOISY_NORMAL_TOLERANCE_DEG.to_radians().tan();
    let tilt = |r: usize| {
        let side = (2 * r + 1) as f64;
        let spread = side * side * (r * (r + 1)) as f64 / 3.0;
        sigma * focal / (z * spread.sqrt())
    };
    (1..=MAX_FIT_RADIUS)
        .find(|&r| tilt(r) <= tolerance)
        .unwrap_or(MAX_FIT_RADIUS)
}

/// Sums of a least-squares fit of `z ≈ c + a·Δu + b·Δv` over pixel offsets `(Δu, Δv)`.
#[derive(Default)]
struct PlaneFit {
    /// `Σ x xᵀ` over `x = (1, Δu, Δv)`.
    normal: [[f64; 3]; 3],
    /// `Σ x z`.
    rhs: [f64; 3],
}

impl PlaneFit {
    fn add(&mut self, du: f64, dv: f64, z: f64) {
        let x = [1.0, du, dv];
        for r in 0..3 {
            for c in 0..3 {
                self.normal[r][c] += x[r] * x[c];
            }
            self.rhs[r] += x[r] * z;
        }
    }

    /// `[c, a, b]`, or `None` when the offsets do not span a plane (fewer than three pixels, or all
    /// on one line).
    fn solve(&self) -> Option<[f64; 3]> {
        let m = DMat3::from_cols_array_2d(&self.normal);
        if m.determinant().abs() < 1e-9 {
            return None;
        }
        Some((m.inverse() * DVec3::from(self.rhs)).to_array())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Pcg32;

    /// The z-depths a camera sees of the plane `n · X = −offset` (the camera looks along −z).
    fn plane_depths(cam: &Pinhole, n: DVec3, offset: f64) -> Vec<f32> {
        let (w, h) = (cam.width as usize, cam.height as usize);
        (0..w * h)
            .map(|i| {
                let d = cam.direction(DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5));
                let t = -offset / n.dot(d);
                (-(d * t).z) as f32
            })
            .collect()
    }

    /// Mean angle (degrees) between `normals` and `n` over the pixels at least `margin` from the border.
    fn mean_error_deg(cam: &Pinhole, normals: &[[f32; 3]], n: DVec3, margin: usize) -> f64 {
        let (w, h) = (cam.width as usize, cam.height as usize);
        let inner: Vec<f64> = (0..w * h)
            .filter(|i| {
                (margin..w - margin).contains(&(i % w)) && (margin..h - margin).contains(&(i / w))
            })
            .map(|i| {
                let got = DVec3::from(normals[i].map(f64::from));
                got.dot(n).clamp(-1.0, 1.0).acos().to_degrees()
            })
            .collect();
        inner.iter().sum::<f64>() / inner.len() as f64
    }

    #[test]
    fn tilted_plane_gives_its_normal_facing_the_camera() {
        let cam = Pinhole::new(40, 30, 35.0, 35.0, 20.0, 15.0);
        let n = DVec3::new(0.3, -0.2, 1.0).normalize();
        let z = plane_depths(&cam, n, 2.0);
        let normals = normals_from_depth(&cam, &z, &vec![true; 40 * 30], None);
        for got in normals {
            let got = DVec3::from(got.map(f64::from));
            assert!((got - n).length() < 1e-3, "{got} vs {n}");
        }
        // A plane fitted to exact depth finds the same normal, to the curvature of z across its window.
        let fitted = normals_from_depth(
            &cam,
            &z,
            &vec![true; 40 * 30],
            Some(DepthNoise::PHONE_LIDAR),
        );
        assert!(mean_error_deg(&cam, &fitted, n, 0) < 0.5);
    }

    /// A wall 3 m away seen through a phone's depth noise: neighbours' differences turn the noise into
    /// the normals; planes fitted over windows sized by the noise keep them within a few degrees.
    #[test]
    fn noisy_depth_gives_normals_from_fitted_planes() {
        let cam = Pinhole::new(80, 60, 65.0, 65.0, 40.0, 30.0);
        let n = DVec3::new(0.2, 0.1, 1.0).normalize();
        let mut rng = Pcg32::new(3, 0);
        let noise = DepthNoise::PHONE_LIDAR;
        let z: Vec<f32> = plane_depths(&cam, n, 3.0)
            .into_iter()
            .map(|z| z + noise.sigma_at(z) * rng.next_normal())
            .collect();
        let valid = vec![true; z.len()];
        let neighbours = mean_error_deg(&cam, &normals_from_depth(&cam, &z, &valid, None), n, 8);
        let fitted = mean_error_deg(
            &cam,
            &normals_from_depth(&cam, &z, &valid, Some(noise)),
            n,
            8,
        );
        assert!(
            fitted < NOISY_NORMAL_TOLERANCE_DEG * 1.5,
            "fitted {fitted}°"
        );
        assert!(
            neighbours > 4.0 * fitted,
            "neighbours {neighbours}°, fitted {fitted}°"
        );
    }

    #[test]
    fn the_fit_window_grows_with_the_noise_against_the_pixel_footprint() {
        assert_eq!(fit_radius(0.0, 2.0, 260.0), 1);
        let near = fit_radius(0.01, 1.0, 260.0);
        let far = fit_radius(0.02, 3.0, 260.0);
        assert!(near > far, "{near} {far}");
        // Smaller pixels (a longer focal length) need a wider window for the same noise.
        let finer = fit_radius(0.01, 1.0, 520.0);
        assert!(finer > near, "{finer} {near}");
        assert_eq!(fit_radius(1.0, 1.0, 260.0), MAX_FIT_RADIUS);
    }
}

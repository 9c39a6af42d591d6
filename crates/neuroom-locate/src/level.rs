//! The camera's up direction from the panorama alone, so a camera held tilted can be located as a level
//! one. A room's vertical edges (wall corners, door and window frames, furniture legs and sides) lie on
//! great circles through the zenith: the plane through the camera and such an edge contains the up
//! direction. Every strong, straight image edge gives the normal of its plane and votes for the up
//! directions that plane contains; the vertical edges' votes pile up at the true up, texture and
//! horizontal edges spread theirs. The peak is refined by least squares over the planes that contain it
//! (the smallest eigenvector of their scatter). Edges near the poles, whose planes turn fastest with
//! noise, are left out.

use glam::{DMat3, DVec3};
use nalgebra::{Matrix3, SymmetricEigen};
use neuroom_core::image::RgbImage;
use neuroom_panorama::plane::{Plane, downsample_rgb};
use neuroom_panorama::sphere::direction;
use serde::{Deserialize, Serialize};

/// Settings of [`estimate_up`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LevelConfig {
    /// Width of the panorama the edges are found in.
    pub width: usize,
    /// Blur of the log-luminance before its gradients (pixels).
    pub sigma: f32,
    /// Least gradient of luma per pixel for an edge (root of the structure tensor's trace).
    pub min_gradient: f32,
    /// Blur of the structure tensor (pixels): the neighbourhood an edge's direction is taken over.
    pub window: f32,
    /// Least coherence of the structure tensor (0: no direction, 1: a straight edge).
    pub min_coherence: f64,
    /// Edges farther than this from the horizon (degrees) are left out.
    pub max_latitude_deg: f64,
    /// Largest tilt looked for (degrees).
    pub max_tilt_deg: f64,
    /// Grid step of the vote over tilts (degrees).
    pub vote_step_deg: f64,
    /// Least share of the votes the peak must hold, relative to a uniform spread along the lines
    /// (each plane votes once per grid row or column): below it, no direction stands out.
    pub min_peak_share: f64,
    /// An edge plane counts in the refinement when it contains the estimate within this angle
    /// (degrees).
    pub inlier_deg: f64,
    /// Least ratio of the second-smallest to the smallest eigenvalue: below it, the edges do not
    /// single out one direction (a room without vertical edges in view) and there is no estimate.
    pub min_eigen_ratio: f64,
    /// Tilts below this (degrees) are left alone: the estimate's own noise.
    pub min_tilt_deg: f64,
}

impl Default for LevelConfig {
    fn default() -> Self {
        Self {
            width: 512,
            sigma: 1.0,
            min_gradient: 0.02,
            window: 1.5,
            min_coherence: 0.8,
            max_latitude_deg: 60.0,
            max_tilt_deg: 15.0,
            vote_step_deg: 0.25,
            min_peak_share: 3.0,
            inlier_deg: 1.0,
            min_eigen_ratio: 4.0,
            min_tilt_deg: 2.0,
        }
    }
}

/// One edge pixel: the normal of the plane through the camera and its edge, and its weight.
struct EdgePlane {
    normal: DVec3,
    weight: f64,
}

/// The up direction in the panorama's camera frame (x forward, y left, z up), or `None` when the
/// panorama's edges do not tell it.
///
/// Every edge plane votes for the up directions it contains: with `up ∝ (a, b, 1)`, the line
/// `n_x a + n_y b + n_z = 0` over a grid of tilts up to [`LevelConfig::max_tilt_deg`]. The room's
/// vertical edges all pass through the true up, where their votes pile up; texture and horizontal
/// edges spread theirs. The peak is then refined by least squares over the planes that contain it
/// (within [`LevelConfig::inlier_deg`]).
pub fn estimate_up(image: &RgbImage, config: &LevelConfig) -> Option<DVec3> {
    let planes = edge_planes(image, config);
    let peak = vote(&planes, config)?;
    let mut up = peak;
    for _ in 0..3 {
        let limit = config.inlier_deg.to_radians().sin();
        let mut scatter = Matrix3::<f64>::zeros();
        for p in planes.iter().filter(|p| p.normal.dot(up).abs() < limit) {
            let n = nalgebra::Vector3::new(p.normal.x, p.normal.y, p.normal.z);
            scatter += p.weight * n * n.transpose();
        }
        let eigen = SymmetricEigen::new(scatter);
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| eigen.eigenvalues[a].total_cmp(&eigen.eigenvalues[b]));
        let (smallest, second) = (eigen.eigenvalues[order[0]], eigen.eigenvalues[order[1]]);
        if second.is_nan() || second <= config.min_eigen_ratio * smallest.max(1e-12) {
            return None;
        }
        let v = eigen.eigenvectors.column(order[0]);
        let candidate = DVec3::new(v[0], v[1], v[2]).normalize();
        up = if candidate.dot(up) < 0.0 {
            -candidate
        } else {
            candidate
        };
    }
    Some(up)
}

/// [`estimate_up`] where it shows a tilt of at least [`LevelConfig::min_tilt_deg`]: the up direction
/// a panorama is levelled to; `None` takes it as level.
pub fn tilted_up(image: &RgbImage, config: &LevelConfig) -> Option<DVec3> {
    estimate_up(image, config)
        .filter(|up| up.angle_between(DVec3::Z).to_degrees() >= config.min_tilt_deg)
}

/// The up direction with the most edge-plane weight through it, on a grid of tilts (`None` when the
/// peak holds less than [`LevelConfig::min_peak_share`] of the votes cast).
fn vote(planes: &[EdgePlane], config: &LevelConfig) -> Option<DVec3> {
    let reach = config.max_tilt_deg.to_radians().tan();
    let step = config.vote_step_deg.to_radians();
    let cells = (2.0 * reach / step).ceil() as usize + 1;
    let at = |k: usize| -reach + k as f64 * step;
    let mut votes = vec![0.0f64; cells * cells];
    let mut cast = 0.0;
    for p in planes {
        let n = p.normal;
        // Along the axis where the line is steeper, one cell per step of the other.
        if n.x.abs() >= n.y.abs() {
            for j in 0..cells {
                let a = -(n.y * at(j) + n.z) / n.x;
                let i = ((a + reach) / step).round();
                if (0.0..cells as f64).contains(&i) {
                    votes[j * cells + i as usize] += p.weight;
                    cast += p.weight;
                }
            }
        } else {
            for i in 0..cells {
                let b = -(n.x * at(i) + n.z) / n.y;
                let j = ((b + reach) / step).round();
                if (0.0..cells as f64).contains(&j) {
                    votes[j as usize * cells + i] += p.weight;
                    cast += p.weight;
                }
            }
        }
    }
    // The peak of the votes smoothed over 3 × 3 cells (a line crosses a cell's neighbours).
    let smoothed = |i: usize, j: usize| {
        let mut sum = 0.0;
        for jj in j.saturating_sub(1)..(j + 2).min(cells) {
            for ii in i.saturating_sub(1)..(i + 2).min(cells) {
                sum += votes[jj * cells + ii];
            }
        }
        sum
    };
    let (mut best, mut best_at) = (0.0, (0, 0));
    for j in 0..cells {
        for i in 0..cells {
            let s = smoothed(i, j);
            if s > best {
                (best, best_at) = (s, (i, j));
            }
        }
    }
    if cast <= 0.0 || best / 9.0 < config.min_peak_share * cast / (cells * cells) as f64 {
        return None;
    }
    Some(DVec3::new(at(best_at.0), at(best_at.1), 1.0).normalize())
}

/// The rotation `L` (camera frame → level frame) that turns `up` onto +z with the least turn: the level
/// frame keeps the camera's heading as nearly as a tilt allows.
pub fn leveling(up: DVec3) -> DMat3 {
    let up = up.normalize();
    let axis = up.cross(DVec3::Z);
    let sin = axis.length();
    if sin < 1e-12 {
        return DMat3::IDENTITY;
    }
    DMat3::from_axis_angle(axis / sin, sin.atan2(up.dot(DVec3::Z)))
}

/// The plane of every strong, straight edge of `image` within the latitude band. The edge's direction
/// is the structure tensor's (gradients averaged over [`LevelConfig::window`]), steadier than a single
/// pixel's gradient; only pixels where that tensor has one clear direction (coherence at least
/// [`LevelConfig::min_coherence`]: a line, not texture or noise) count.
fn edge_planes(image: &RgbImage, config: &LevelConfig) -> Vec<EdgePlane> {
    use std::f64::consts::PI;
    let (w, h) = (config.width, config.width / 2);
    let small = downsample_rgb(image, w, h);
    let (gx, gy) = scharr(&luma(&small).blur(config.sigma));
    let tensor = |f: &dyn Fn(usize) -> f32| {
        Plane {
            width: w,
            height: h,
            data: (0..w * h).map(f).collect(),
        }
        .blur(config.window)
    };
    let jxx = tensor(&|i| gx[i] * gx[i]);
    let jxy = tensor(&|i| gx[i] * gy[i]);
    let jyy = tensor(&|i| gy[i] * gy[i]);
    let max_lat = config.max_latitude_deg.to_radians();
    let mut planes = Vec::new();
    for v in 0..h {
        let lat = PI * (0.5 - (v as f64 + 0.5) / h as f64);
        if lat.abs() > max_lat {
            continue;
        }
        for u in 0..w {
            let i = v * w + u;
            let (a, b, c) = (jxx.data[i] as f64, jxy.data[i] as f64, jyy.data[i] as f64);
            let energy = a + c;
            if energy.sqrt() < config.min_gradient as f64 {
                continue;
            }
            let spread = ((a - c) * (a - c) + 4.0 * b * b).sqrt();
            let coherence = spread / energy.max(1e-12);
            if coherence < config.min_coherence {
                continue;
            }
            // The gradient's dominant direction is at ½·atan2(2b, a − c); the edge runs across it.
            let theta = 0.5 * (2.0 * b).atan2(a - c);
            let (ex, ey) = (-theta.sin(), theta.cos());
            let d = direction(u as f64 + 0.5, v as f64 + 0.5, w, h);
            // ∂d/∂x and ∂d/∂y from lon = π(1 − 2x/w), lat = π(1/2 − y/h).
            let lon = d.y.atan2(d.x);
            let (sl, cl) = lat.sin_cos();
            let (so, co) = lon.sin_cos();
            let d_dx = DVec3::new(-cl * so, cl * co, 0.0) * (-2.0 * PI / w as f64);
            let d_dy = DVec3::new(-sl * co, -sl * so, cl) * (-PI / h as f64);
            let tangent = d_dx * ex + d_dy * ey;
            let normal = d.cross(tangent).normalize_or_zero();
            if normal != DVec3::ZERO {
                planes.push(EdgePlane {
                    normal,
                    weight: energy.sqrt() * coherence * cl,
                });
            }
        }
    }
    planes
}

/// The sRGB-encoded luma of every pixel: perceptually even, so the noise of dark corners does not
/// make edges (as it would in log-luminance).
fn luma(image: &RgbImage) -> Plane {
    Plane {
        width: image.width as usize,
        height: image.height as usize,
        data: image
            .data
            .iter()
            .map(|c| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2])
            .collect(),
    }
}

/// Scharr derivatives along columns and rows (per pixel, normalised to a unit step): their direction
/// varies least with an edge's angle to the pixel grid, which a tilted vertical edge has.
fn scharr(plane: &Plane) -> (Vec<f32>, Vec<f32>) {
    let (w, h) = (plane.width, plane.height);
    let mut gx = vec![0.0; w * h];
    let mut gy = vec![0.0; w * h];
    for v in 0..h as isize {
        for u in 0..w as isize {
            let a = |du: isize, dv: isize| plane.at(u + du, v + dv);
            let i = v as usize * w + u as usize;
            gx[i] = (3.0 * (a(1, -1) - a(-1, -1) + a(1, 1) - a(-1, 1))
                + 10.0 * (a(1, 0) - a(-1, 0)))
                / 32.0;
            gy[i] = (3.0 * (a(-1, 1) - a(-1, -1) + a(1, 1) - a(1, -1))
                + 10.0 * (a(0, 1) - a(0, -1)))
                / 32.0;
        }
    }
    (gx, gy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::camera::{CameraModel, Equirect};
    use neuroom_core::camera_effects::rotate_panorama;

    /// A panorama of a box room (4 × 3 × 2.6 m, camera at 1.4 m) whose walls carry vertical and
    /// horizontal stripes and whose floor and ceiling are plain: the edges a room shows.
    fn box_room(width: u32) -> RgbImage {
        let camera = Equirect::new(width, width / 2).unwrap();
        let eye = DVec3::new(1.3, 1.1, 1.4);
        let (lo, hi) = (DVec3::ZERO, DVec3::new(4.0, 3.0, 2.6));
        let mut image = RgbImage::filled(width, width / 2, [0.0; 3]);
        for v in 0..width / 2 {
            for u in 0..width {
                let d = camera.direction(glam::DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
                let t = (0..3)
                    .map(|k| {
                        let bound = if d[k] > 0.0 { hi[k] } else { lo[k] };
                        if d[k].abs() < 1e-12 {
                            f64::INFINITY
                        } else {
                            (bound - eye[k]) / d[k]
                        }
                    })
                    .fold(f64::INFINITY, f64::min);
                let p = eye + d * t;
                let colour = if p.z < 1e-6 {
                    0.3
                } else if p.z > 2.6 - 1e-6 {
                    0.9
                } else {
                    let along = if p.x < 1e-6 || p.x > 4.0 - 1e-6 {
                        p.y
                    } else {
                        p.x
                    };
                    let stripe = (along / 0.4).floor() as i64 % 2 == 0;
                    let band = (p.z / 0.7).floor() as i64 % 2 == 0;
                    0.35 + 0.3 * f64::from(stripe) + 0.1 * f64::from(band)
                };
                image.set(u, v, [colour as f32; 3]);
            }
        }
        image
    }

    #[test]
    fn a_level_panorama_stays_level_and_a_tilted_one_is_found_within_a_few_tenths_of_a_degree() {
        let level = box_room(1024);
        let config = LevelConfig::default();
        let up = estimate_up(&level, &config).expect("edges enough");
        assert!(up.angle_between(DVec3::Z).to_degrees() < 0.2, "{up}");
        for (degrees, axis_deg) in [(10.0, 35.0), (6.0, -120.0), (3.0, 90.0)] {
            let (s, c) = f64::to_radians(axis_deg).sin_cos();
            let tilt = DMat3::from_axis_angle(DVec3::new(c, s, 0.0), f64::to_radians(degrees));
            let tilted = rotate_panorama(&level, &tilt).unwrap();
            // The world's up, in the tilted camera's frame.
            let want = tilt.transpose() * DVec3::Z;
            let up = estimate_up(&tilted, &config).expect("edges enough");
            let error = up.angle_between(want).to_degrees();
            assert!(error < 0.3, "{degrees}° about {axis_deg}°: {error}°");
            let l = leveling(up);
            assert!((l * up - DVec3::Z).length() < 1e-12);
        }
    }

    #[test]
    fn a_panorama_without_edges_has_no_up_direction() {
        let plain = RgbImage::filled(512, 256, [0.5; 3]);
        assert!(estimate_up(&plain, &LevelConfig::default()).is_none());
    }
}

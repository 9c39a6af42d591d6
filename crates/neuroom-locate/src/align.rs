//! Direct 6-DoF alignment of a query panorama to a keyframe of the empty room (colour + ray depth at a
//! known camera): the keyframe's pixels become world points, which are projected into the query at the
//! camera being solved, and the difference of illumination-robust features ([`FeatureMap`]) is minimised
//! by Gauss–Newton with Levenberg–Marquardt damping. A Cauchy weight per point discounts what the empty
//! room cannot explain (objects, highlights, changed shadows). Keyframe pixels without a surface or on
//! surfaces facing down (the ceiling) are left out, and the features are blurred around them by
//! normalised convolution, so neither makes edges. Coarse to fine over blur scales.
//!
//! The camera is updated on the right, `camera_to_world ← camera_to_world · exp(δ)`, `δ = (v, ω)` in the
//! camera frame, so a world point `X` seen at `p = Rᵀ(X − t)` moves to `p − v − ω × p`.

use glam::{DMat3, DVec2, DVec3};
use neuroom_core::image::RgbImage;
use neuroom_core::pose::Pose;
use neuroom_panorama::plane::Plane;
use neuroom_panorama::sphere::{direction, project_jacobian};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::features::{FeatureMap, row_weights};
use crate::sphere_image::SphereImage;

/// Settings of one alignment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct AlignConfig {
    /// Blur of each scale, coarse to fine (pixels at the working resolution).
    pub sigmas: Vec<f32>,
    /// Most Gauss–Newton steps per scale.
    pub iterations: usize,
    /// Cauchy scale as a multiple of the median residual.
    pub robust_factor: f64,
    /// Keep the camera's tilt: only position and heading are solved (4 degrees of freedom), for
    /// panoramas from levelled 360° cameras. The start pose's tilt is kept as it is.
    pub upright: bool,
    /// Keyframe pixels whose surface normal's z is below this (surfaces facing down: the ceiling) are
    /// left out, for their look depends most on the lights; −1 keeps them all.
    pub min_normal_z: f64,
    /// Align edge orientations ([`FeatureMap::orientation`] with this softness) instead of signed
    /// log-luminance gradients: blind to an edge's contrast and its sign, which another lighting changes.
    #[serde(default)]
    pub orientation: Option<f32>,
}

impl Default for AlignConfig {
    fn default() -> Self {
        Self {
            sigmas: vec![3.0, 1.5, 0.75],
            iterations: 20,
            robust_factor: 2.0,
            upright: true,
            min_normal_z: -0.7,
            orientation: None,
        }
    }
}

impl AlignConfig {
    /// The features this alignment compares, from signed gradients.
    fn features(&self, signed: FeatureMap) -> FeatureMap {
        match self.orientation {
            Some(softness) => signed.orientation(softness),
            None => signed,
        }
    }
}

/// A rendered view of the empty room: colour and ray depth at a known camera.
#[derive(Clone, Debug)]
pub struct Keyframe<'a> {
    /// Colour.
    pub rgb: &'a RgbImage,
    /// Ray distance per pixel (0 = none).
    pub depth: &'a [f32],
    /// Where it was rendered from.
    pub camera_to_world: Pose,
}

/// The result of an alignment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Alignment {
    /// The solved camera.
    pub camera_to_world: Pose,
    /// Latitude-weighted normalised correlation of the aligned features at the finest scale (1 = perfect).
    pub score: f64,
}

/// One keyframe point with its features at the current scale.
#[derive(Clone)]
struct Point {
    world: DVec3,
    feature: [f32; 2],
    weight: f64,
}

/// Aligns `query` (same size as the keyframe) to `keyframe`, starting at `init`. Keyframe points that
/// project where the query saw nothing (outside a photo's field of view) are left out.
pub fn align(
    keyframe: &Keyframe,
    query: &SphereImage,
    init: &Pose,
    config: &AlignConfig,
) -> Alignment {
    let mut pose = *init;
    let mut score = 0.0;
    for &sigma in &config.sigmas {
        let (points, q) = at_scale(keyframe, query, sigma, config);
        let points = seen_from(points, &q, &pose);
        pose = solve_scale(&points, &q, pose, config);
        score = correlation(&points, &q, &pose);
    }
    Alignment {
        camera_to_world: pose,
        score,
    }
}

/// The pose among `starts` whose features correlate best with the keyframe's at the finest blur of
/// `config`, no step taken: a search over poses that Gauss–Newton would not reach from where it
/// starts. The first of equal correlations wins; `None` when there are no starts or no blurs.
pub fn best_start(
    keyframe: &Keyframe,
    query: &SphereImage,
    starts: &[Pose],
    config: &AlignConfig,
) -> Option<Alignment> {
    let (points, q) = at_scale(keyframe, query, *config.sigmas.last()?, config);
    let scored: Vec<Alignment> = starts
        .par_iter()
        .map(|pose| {
            let score = if q.seen.is_some() {
                correlation(&seen_from(points.clone(), &q, pose), &q, pose)
            } else {
                correlation(&points, &q, pose)
            };
            Alignment {
                camera_to_world: *pose,
                score,
            }
        })
        .collect();
    scored
        .into_iter()
        .reduce(|best, a| if a.score > best.score { a } else { best })
}

/// The keyframe's trusted points and the query's features at blur `sigma`, as [`align`] compares
/// them.
fn at_scale(
    keyframe: &Keyframe,
    query: &SphereImage,
    sigma: f32,
    config: &AlignConfig,
) -> (Vec<Point>, QueryMap) {
    let valid = trusted_pixels(keyframe, config.min_normal_z);
    let kf = config.features(FeatureMap::masked(keyframe.rgb, &valid, sigma));
    let q = QueryMap::new(&config.features(query.features(sigma)), query.seen_plane());
    (keyframe_points(keyframe, &kf, &valid), q)
}

/// Query features and their image derivatives.
struct QueryMap {
    values: [Plane; 2],
    dx: [Plane; 2],
    dy: [Plane; 2],
    /// 1 well inside what the query saw, 0 elsewhere ([`SphereImage::seen_plane`]); `None`: all seen.
    seen: Option<Plane>,
}

impl QueryMap {
    fn new(f: &FeatureMap, seen: Option<Plane>) -> Self {
        let (dx0, dy0) = f.channels[0].gradients();
        let (dx1, dy1) = f.channels[1].gradients();
        Self {
            values: f.channels.clone(),
            dx: [dx0, dx1],
            dy: [dy0, dy1],
            seen,
        }
    }

    /// The query's features at continuous pixel coordinates minus those of `pt`.
    fn residual(&self, pt: &Point, x: f64, y: f64) -> [f64; 2] {
        std::array::from_fn(|c| (self.values[c].sample(x, y) - pt.feature[c]) as f64)
    }

    /// The pixel where the camera-frame point `p` projects, when the query saw there.
    fn seen_pixel(&self, p: DVec3) -> Option<DVec2> {
        neuroom_panorama::sphere::project(p, self.width(), self.height())
            .filter(|pix| self.sees(pix.x, pix.y))
    }

    /// Whether continuous pixel coordinates lie well inside what the query saw.
    fn sees(&self, x: f64, y: f64) -> bool {
        self.seen.as_ref().is_none_or(|s| s.sample(x, y) > 0.999)
    }

    fn width(&self) -> usize {
        self.values[0].width
    }

    fn height(&self) -> usize {
        self.values[0].height
    }
}

/// World point of every keyframe pixel (`None` where no surface).
fn world_points(keyframe: &Keyframe) -> Vec<Option<DVec3>> {
    let (w, h) = (keyframe.rgb.width as usize, keyframe.rgb.height as usize);
    let pose = keyframe.camera_to_world;
    (0..w * h)
        .map(|i| {
            let d = direction((i % w) as f64 + 0.5, (i / w) as f64 + 0.5, w, h);
            (keyframe.depth[i] > 0.0).then(|| pose.transform_point(d * keyframe.depth[i] as f64))
        })
        .collect()
}

/// Pixels whose surface is trusted: seen, and facing down no more than `min_normal_z` allows (the
/// ceiling: captures rarely see it, so the model knows it least, and its contrast with the walls
/// follows the lights, even in sign).
fn trusted_pixels(keyframe: &Keyframe, min_normal_z: f64) -> Vec<bool> {
    let (w, h) = (keyframe.rgb.width as usize, keyframe.rgb.height as usize);
    let points = world_points(keyframe);
    (0..w * h)
        .map(|i| {
            let Some(p) = points[i] else {
                return false;
            };
            let (u, v) = (i % w, i / w);
            if v == 0 || v + 1 >= h {
                return true;
            }
            let at = |uu: usize, vv: usize| points[vv * w + uu % w];
            let (Some(a), Some(b), Some(c), Some(d)) =
                (at(u + w - 1, v), at(u + 1, v), at(u, v - 1), at(u, v + 1))
            else {
                return true;
            };
            let normal = (b - a).cross(d - c).normalize_or_zero();
            let facing = if normal.dot(keyframe.camera_to_world.translation - p) < 0.0 {
                -normal
            } else {
                normal
            };
            facing.z > min_normal_z
        })
        .collect()
}

fn keyframe_points(keyframe: &Keyframe, features: &FeatureMap, valid: &[bool]) -> Vec<Point> {
    let (w, h) = (features.width(), features.height());
    let rows = row_weights(h);
    let pose = keyframe.camera_to_world;
    (0..w * h)
        .filter(|&i| valid[i])
        .map(|i| {
            let (u, v) = (i % w, i / w);
            let d = direction(u as f64 + 0.5, v as f64 + 0.5, w, h);
            Point {
                world: pose.transform_point(d * keyframe.depth[i] as f64),
                feature: [features.channels[0].data[i], features.channels[1].data[i]],
                weight: rows[v] as f64,
            }
        })
        .collect()
}

/// The points the query sees from `pose` (all of them for a panorama): a photo's alignment follows the
/// part of the keyframe in its field of view.
fn seen_from(mut points: Vec<Point>, q: &QueryMap, pose: &Pose) -> Vec<Point> {
    if q.seen.is_some() {
        let rt = pose.rotation.transpose();
        points.retain(|pt| q.seen_pixel(rt * (pt.world - pose.translation)).is_some());
    }
    points
}

/// Residuals of every point that projects where the query saw, with their Jacobians with respect to
/// `δ`.
fn linearize(
    points: &[Point],
    q: &QueryMap,
    pose: &Pose,
    mut visit: impl FnMut(&Point, [f64; 2], [[f64; 6]; 2]),
) {
    let rt = pose.rotation.transpose();
    for pt in points {
        let p = rt * (pt.world - pose.translation);
        let Some((pix, jp)) = project_jacobian(p, q.width(), q.height()) else {
            continue;
        };
        if !q.sees(pix.x, pix.y) {
            continue;
        }
        // ∂p/∂v = −I, ∂p/∂ω = [p]ₓ (p × ω).
        let skew = DMat3::from_cols(
            DVec3::new(0.0, p.z, -p.y),
            DVec3::new(-p.z, 0.0, p.x),
            DVec3::new(p.y, -p.x, 0.0),
        );
        let dpix_dv = -jp;
        let dpix_dw = jp * skew;
        let r = q.residual(pt, pix.x, pix.y);
        let mut jac = [[0.0; 6]; 2];
        for (c, row) in jac.iter_mut().enumerate() {
            let gx = q.dx[c].sample(pix.x, pix.y) as f64;
            let gy = q.dy[c].sample(pix.x, pix.y) as f64;
            for a in 0..3 {
                row[a] = gx * dpix_dv.row(0)[a] + gy * dpix_dv.row(1)[a];
                row[3 + a] = gx * dpix_dw.row(0)[a] + gy * dpix_dw.row(1)[a];
            }
        }
        visit(pt, r, jac);
    }
}

/// Robust (Cauchy) costs, at scale `c`, of a step from `pose` to `candidate`: over the points the
/// query sees from both poses, so that a point moving into or out of what the query saw (a photo's
/// edge, a light source taken out of a panorama) counts on neither side. Charging such a point a
/// fixed cost instead holds every alignment near where it starts as soon as the panorama has holes
/// with long borders; leaving it out of both sides gives a step no gain from it either, so an
/// alignment cannot lower its cost by looking away from its points.
fn step_costs(points: &[Point], q: &QueryMap, pose: &Pose, candidate: &Pose, c: f64) -> StepCosts {
    let cauchy = |e2: f64| (1.0 + e2 / (c * c)).ln();
    let mut costs = StepCosts {
        before: 0.0,
        after: 0.0,
    };
    for pt in points {
        let (Some(a), Some(b)) = (
            squared_residual(pt, q, pose),
            squared_residual(pt, q, candidate),
        ) else {
            continue;
        };
        costs.before += pt.weight * cauchy(a);
        costs.after += pt.weight * cauchy(b);
    }
    costs
}

/// The robust costs of one step of [`solve_scale`], before and after it.
struct StepCosts {
    before: f64,
    after: f64,
}

/// The squared residual of `pt` seen from `pose`, when the query saw where it projects.
fn squared_residual(pt: &Point, q: &QueryMap, pose: &Pose) -> Option<f64> {
    let pix = q.seen_pixel(pose.rotation.transpose() * (pt.world - pose.translation))?;
    Some(q.residual(pt, pix.x, pix.y).iter().map(|r| r * r).sum())
}

/// Median residual norm at `pose`: the robust scale.
fn median_residual(points: &[Point], q: &QueryMap, pose: &Pose) -> f64 {
    let mut norms = Vec::with_capacity(points.len());
    linearize(points, q, pose, |_, r, _| {
        norms.push((r[0] * r[0] + r[1] * r[1]).sqrt())
    });
    if norms.is_empty() {
        return 1.0;
    }
    let mid = norms.len() / 2;
    *norms.select_nth_unstable_by(mid, f64::total_cmp).1
}

fn solve_scale(points: &[Point], q: &QueryMap, init: Pose, config: &AlignConfig) -> Pose {
    let mut pose = init;
    let mut lambda = 1e-3;
    for _ in 0..config.iterations {
        let c = (config.robust_factor * median_residual(points, q, &pose)).max(1e-6);
        let mut hess = [[0.0f64; 6]; 6];
        let mut grad = [0.0f64; 6];
        linearize(points, q, &pose, |pt, r, jac| {
            let e2 = r[0] * r[0] + r[1] * r[1];
            let w = pt.weight / (1.0 + e2 / (c * c));
            for ch in 0..2 {
                for a in 0..6 {
                    grad[a] += w * jac[ch][a] * r[ch];
                    for b in 0..6 {
                        hess[a][b] += w * jac[ch][a] * jac[ch][b];
                    }
                }
            }
        });
        if config.upright {
            // ω_x, ω_y: rotations about the camera's horizontal axes.
            for a in [3, 4] {
                grad[a] = 0.0;
                hess[a] = [0.0; 6];
                for row in hess.iter_mut() {
                    row[a] = 0.0;
                }
                hess[a][a] = 1.0;
            }
        }
        let mut improved = false;
        for _ in 0..6 {
            let Some(delta) = solve_damped(&hess, &grad, lambda) else {
                break;
            };
            let candidate = apply(&pose, &delta);
            let costs = step_costs(points, q, &pose, &candidate, c);
            if costs.after < costs.before {
                pose = candidate;
                lambda = (lambda * 0.3).max(1e-6);
                improved = delta.iter().map(|x| x * x).sum::<f64>() > 1e-14;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    pose
}

/// `(H + λ diag H) δ = −g` by Gaussian elimination with partial pivoting.
fn solve_damped(hess: &[[f64; 6]; 6], grad: &[f64; 6], lambda: f64) -> Option<[f64; 6]> {
    let mut a = [[0.0f64; 7]; 6];
    for i in 0..6 {
        for j in 0..6 {
            a[i][j] = hess[i][j];
        }
        a[i][i] += lambda * hess[i][i].max(1e-12);
        a[i][6] = -grad[i];
    }
    for col in 0..6 {
        let pivot = (col..6).max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))?;
        if a[pivot][col].abs() < 1e-18 {
            return None;
        }
        a.swap(col, pivot);
        let pivot_row = a[col];
        for (row, r) in a.iter_mut().enumerate() {
            if row != col {
                let f = r[col] / pivot_row[col];
                for (x, p) in r[col..].iter_mut().zip(&pivot_row[col..]) {
                    *x -= f * p;
                }
            }
        }
    }
    Some(std::array::from_fn(|i| a[i][6] / a[i][i]))
}

/// `pose · exp(δ)` with `δ = (v, ω)` (rotation by Rodrigues' formula).
pub fn apply(pose: &Pose, delta: &[f64; 6]) -> Pose {
    let v = DVec3::new(delta[0], delta[1], delta[2]);
    let w = DVec3::new(delta[3], delta[4], delta[5]);
    let angle = w.length();
    let dr = if angle > 1e-12 {
        DMat3::from_axis_angle(w / angle, angle)
    } else {
        DMat3::IDENTITY
    };
    Pose::new(pose.rotation * dr, pose.translation + pose.rotation * v).orthonormalized()
}

/// Latitude-weighted normalised correlation between the keyframe features and the query features at
/// the points' projections (a point outside what the query saw meets a zero feature).
fn correlation(points: &[Point], q: &QueryMap, pose: &Pose) -> f64 {
    let rt = pose.rotation.transpose();
    let (mut ab, mut aa, mut bb) = (0.0f64, 0.0f64, 0.0f64);
    for pt in points {
        let Some(pix) = q.seen_pixel(rt * (pt.world - pose.translation)) else {
            aa += pt.weight * pt.feature.iter().map(|a| (*a as f64).powi(2)).sum::<f64>();
            continue;
        };
        for c in 0..2 {
            let a = pt.feature[c] as f64;
            let b = q.values[c].sample(pix.x, pix.y) as f64;
            ab += pt.weight * a * b;
            aa += pt.weight * a * a;
            bb += pt.weight * b * b;
        }
    }
    if aa <= 0.0 || bb <= 0.0 {
        return 0.0;
    }
    ab / (aa * bb).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobian_of_the_residual_matches_finite_differences() {
        let (w, h) = (64usize, 32usize);
        let img = RgbImage {
            width: w as u32,
            height: h as u32,
            data: (0..w * h)
                .map(|i| {
                    let (u, v) = ((i % w) as f32, (i / w) as f32);
                    let x = 0.5 + 0.4 * (0.3 * u).sin() * (0.2 * v).cos();
                    [x, x * 0.8, 0.5]
                })
                .collect(),
        };
        let q = QueryMap::new(&FeatureMap::new(&img, 1.5), None);
        let points = vec![Point {
            world: DVec3::new(1.3, 0.4, 0.3),
            feature: [0.0, 0.0],
            weight: 1.0,
        }];
        let pose = Pose::from_yaw_translation(0.2, DVec3::new(0.1, -0.1, 0.05));
        let mut analytic = [[0.0; 6]; 2];
        let mut r0 = [0.0; 2];
        linearize(&points, &q, &pose, |_, r, j| {
            analytic = j;
            r0 = r;
        });
        let h = 1e-3;
        let scale: [f64; 2] =
            std::array::from_fn(|c| analytic[c].iter().fold(0.0f64, |m, x| m.max(x.abs())));
        for a in 0..6 {
            let mut d = [0.0; 6];
            d[a] = h;
            let mut plus = [0.0; 2];
            linearize(&points, &q, &apply(&pose, &d), |_, r, _| plus = r);
            d[a] = -h;
            let mut minus = [0.0; 2];
            linearize(&points, &q, &apply(&pose, &d), |_, r, _| minus = r);
            for c in 0..2 {
                let num = (plus[c] - minus[c]) / (2.0 * h);
                // Central-difference image gradients against bilinear interpolation: a few per cent
                // of the largest derivative of the channel.
                let tol = 0.1 * scale[c] + 1e-4;
                assert!(
                    (num - analytic[c][a]).abs() < tol,
                    "ch {c} param {a}: {num} vs {}",
                    analytic[c][a]
                );
            }
        }
        assert!(r0.iter().all(|x| x.is_finite()));
    }

    /// A `w × h` panorama of a textured box room `[-2, 2] × [-1.5, 1.5] × [-1.2, 1.3]` taken at the
    /// origin by a camera turned by `rotation`, and the ray distance of each pixel.
    fn textured_box(w: usize, h: usize, rotation: DMat3) -> (RgbImage, Vec<f32>) {
        let (low, high) = (DVec3::new(-2.0, -1.5, -1.2), DVec3::new(2.0, 1.5, 1.3));
        let (data, depth) = (0..w * h)
            .map(|i| {
                let d = rotation * direction((i % w) as f64 + 0.5, (i / w) as f64 + 0.5, w, h);
                let wall = DVec3::select(d.cmpgt(DVec3::ZERO), high, low);
                let t = (wall / d)
                    .to_array()
                    .into_iter()
                    .filter(|t| t.is_finite() && *t > 0.0)
                    .fold(f64::INFINITY, f64::min);
                let p = d * t;
                let x =
                    0.5 + 0.2 * ((3.0 * p.x).sin() + (4.0 * p.y).sin() + (5.0 * p.z).sin()) / 3.0;
                ([x as f32, (0.9 * x) as f32, 0.4], t as f32)
            })
            .unzip();
        (
            RgbImage {
                width: w as u32,
                height: h as u32,
                data,
            },
            depth,
        )
    }

    #[test]
    fn best_start_picks_the_tilt_the_query_was_taken_at() {
        let (w, h) = (128, 64);
        let (rgb, depth) = textured_box(w, h, DMat3::IDENTITY);
        let keyframe = Keyframe {
            rgb: &rgb,
            depth: &depth,
            camera_to_world: Pose::IDENTITY,
        };
        let tilt =
            DMat3::from_rotation_x(3f64.to_radians()) * DMat3::from_rotation_y(-2f64.to_radians());
        let query = SphereImage::panorama(textured_box(w, h, tilt).0);
        let starts: Vec<Pose> = (-3..=3)
            .flat_map(|a| (-3..=3).map(move |b| (a, b)))
            .map(|(a, b): (i32, i32)| {
                let turn = DMat3::from_rotation_x(f64::from(a).to_radians())
                    * DMat3::from_rotation_y(f64::from(b).to_radians());
                Pose::new(turn, DVec3::ZERO)
            })
            .collect();
        let config = AlignConfig {
            upright: false,
            ..AlignConfig::default()
        };
        let best = best_start(&keyframe, &query, &starts, &config).unwrap();
        let error = glam::DQuat::from_mat3(&(best.camera_to_world.rotation.transpose() * tilt))
            .to_axis_angle()
            .1;
        assert!(
            error.to_degrees() < 0.5,
            "{:.2}° from the query's tilt",
            error.to_degrees()
        );
        assert!(best_start(&keyframe, &query, &[], &config).is_none());
    }

    #[test]
    fn damped_solve_inverts_a_diagonal_system() {
        let mut hess = [[0.0; 6]; 6];
        for (i, row) in hess.iter_mut().enumerate() {
            row[i] = (i + 1) as f64;
        }
        let grad = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let d = solve_damped(&hess, &grad, 0.0).unwrap();
        assert!(d.iter().all(|x| (x + 1.0).abs() < 1e-12));
    }
}

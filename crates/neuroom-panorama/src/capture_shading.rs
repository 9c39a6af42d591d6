//! The light an object was captured under, as it varies with the surface's orientation, taken out of
//! its model's colours.
//!
//! A model learns what its captures showed: the object's albedo times the light its capture gave each
//! face. A studio sky at sunset lights one side of a white bookcase warm and the other blue; a lamp
//! above a table lights its top and leaves its legs dim. Placed in a room, the object is lit by the
//! room's light instead, and those colours, fixed to the object's frame, turn with it. The captures'
//! light in the object's frame is fitted on the model's own coloured cloud, per colour channel, as
//! `log(linear colour) = a + b · n` over the surface normals `n` (robustly: parts whose paint differs
//! from the rest are what the fit must not follow), and divided out: what is left is the colour each
//! face would show under a light from every side alike, at the capture light's mean level and colour.
//! Nothing is fitted to a panorama here, so no object gains freedom to explain what another shows.

use glam::Vec3;
use neuroom_core::image::{linear_to_srgb, srgb_to_linear};
use neuroom_core::stats::upper_median_by;

use crate::cloud::Cloud;

/// Per colour channel, how the captures' light changes the log of the linear colour along a unit
/// normal (object frame), relative to its mean over the model's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CaptureShading {
    /// The gradient of log linear colour over the normal, per channel.
    pub slope: [Vec3; 3],
    /// The mean of `slope · n` over the fitted cloud, per channel: the correction keeps the mean level.
    pub offset: [f32; 3],
}

/// Linear colours below this are taken as this before their logarithm: black has no direction.
const DARKEST: f32 = 0.005;

/// Rounds of reweighting of the fit (the first is plain least squares).
const ROUNDS: usize = 4;

/// The least scale of the residuals (log units) the robust weights are taken at: below it, parts are
/// alike in colour and every point counts.
const LEAST_SCALE: f32 = 0.05;

/// The largest factor (and its inverse) the correction applies to a point's linear colour: a model's
/// colour on a face no capture saw well is extrapolated, not measured.
const LARGEST_FACTOR: f32 = 4.0;

impl CaptureShading {
    /// No change.
    pub const NONE: Self = Self {
        slope: [Vec3::ZERO; 3],
        offset: [0.0; 3],
    };

    /// Fitted on `cloud`'s colours and normals; [`Self::NONE`] for fewer than 16 points.
    pub fn fit(cloud: &Cloud) -> Self {
        Self::fit_shared(&[cloud])
    }

    /// One light fitted over several clouds captured under it, each cloud counting as much as any
    /// other whatever its number of points: a single object's paint may follow its normals (a table's
    /// top painted otherwise than its legs), several objects' paints do not follow the same ones, and
    /// the light they share is what is left. [`Self::NONE`] for fewer than 16 points in all.
    pub fn fit_shared(clouds: &[&Cloud]) -> Self {
        let normals: Vec<Vec3> = clouds
            .iter()
            .flat_map(|c| c.normals.iter().copied())
            .collect();
        if normals.len() < 16 {
            return Self::NONE;
        }
        let weights: Vec<f32> = clouds
            .iter()
            .flat_map(|c| std::iter::repeat_n(1.0 / c.normals.len() as f32, c.normals.len()))
            .collect();
        let mut slope = [Vec3::ZERO; 3];
        let mut offset = [0.0; 3];
        for k in 0..3 {
            let logs: Vec<f32> = clouds
                .iter()
                .flat_map(|c| c.colors.iter())
                .map(|c| srgb_to_linear(c[k]).max(DARKEST).ln())
                .collect();
            let (b, mean) = robust_plane(&normals, &logs, &weights);
            slope[k] = b;
            offset[k] = mean;
        }
        Self { slope, offset }
    }

    /// `cloud` with this light taken out of its colours.
    pub fn remove(&self, cloud: &Cloud) -> Cloud {
        let colors = cloud
            .colors
            .iter()
            .zip(&cloud.normals)
            .map(|(c, n)| {
                Vec3::from_array(std::array::from_fn(|k| {
                    let factor = (self.offset[k] - self.slope[k].dot(*n))
                        .exp()
                        .clamp(1.0 / LARGEST_FACTOR, LARGEST_FACTOR);
                    linear_to_srgb(srgb_to_linear(c[k]) * factor)
                }))
            })
            .collect();
        Cloud {
            colors,
            ..cloud.clone()
        }
    }
}

/// `y ≈ a + b · n`, fitted by iteratively reweighted least squares with Cauchy weights times the
/// points' own `base` weights; returns `b` and the weighted mean of `b · n` over the points (by the
/// final weights, which say what the fit followed).
fn robust_plane(normals: &[Vec3], y: &[f32], base: &[f32]) -> (Vec3, f32) {
    let mut weights = base.to_vec();
    let mut b = Vec3::ZERO;
    let mut a = 0.0f32;
    for round in 0..ROUNDS {
        if round > 0 {
            let residuals: Vec<f32> = normals
                .iter()
                .zip(y)
                .map(|(n, y)| (y - a - b.dot(*n)).abs())
                .collect();
            let median = upper_median_by(&mut residuals.clone(), f32::total_cmp).unwrap_or(0.0);
            let scale = (1.4826 * median).max(LEAST_SCALE);
            for ((w, r), b) in weights.iter_mut().zip(&residuals).zip(base) {
                *w = b / (1.0 + (r / scale).powi(2));
            }
        }
        let Some((a1, b1)) = weighted_plane(normals, y, &weights) else {
            return (Vec3::ZERO, 0.0);
        };
        (a, b) = (a1, b1);
    }
    let total: f32 = weights.iter().sum();
    let mean = normals
        .iter()
        .zip(&weights)
        .map(|(n, w)| w * b.dot(*n))
        .sum::<f32>()
        / total.max(f32::MIN_POSITIVE);
    (b, mean)
}

/// Weighted least squares of `y ≈ a + b · n` by its normal equations (f64); `None` when they are
/// singular (every normal alike).
fn weighted_plane(normals: &[Vec3], y: &[f32], w: &[f32]) -> Option<(f32, Vec3)> {
    let mut m = [[0.0f64; 4]; 4];
    let mut v = [0.0f64; 4];
    for ((n, y), w) in normals.iter().zip(y).zip(w) {
        let x = [1.0, n.x as f64, n.y as f64, n.z as f64];
        for i in 0..4 {
            v[i] += *w as f64 * x[i] * *y as f64;
            for j in 0..4 {
                m[i][j] += *w as f64 * x[i] * x[j];
            }
        }
    }
    let s = solve4(m, v)?;
    Some((
        s[0] as f32,
        Vec3::new(s[1] as f32, s[2] as f32, s[3] as f32),
    ))
}

/// Solves the 4 × 4 system `m s = v` by Gaussian elimination with partial pivoting.
fn solve4(mut m: [[f64; 4]; 4], mut v: [f64; 4]) -> Option<[f64; 4]> {
    let scale = (0..4).map(|i| m[i][i].abs()).fold(0.0, f64::max);
    for c in 0..4 {
        let p = (c..4).max_by(|&i, &j| m[i][c].abs().total_cmp(&m[j][c].abs()))?;
        if m[p][c].abs() <= 1e-9 * scale.max(f64::MIN_POSITIVE) {
            return None;
        }
        m.swap(c, p);
        v.swap(c, p);
        let pivot = m[c];
        for r in c + 1..4 {
            let f = m[r][c] / pivot[c];
            for (x, p) in m[r][c..].iter_mut().zip(&pivot[c..]) {
                *x -= f * p;
            }
            v[r] -= f * v[c];
        }
    }
    let mut s = [0.0; 4];
    for c in (0..4).rev() {
        let tail: f64 = (c + 1..4).map(|k| m[c][k] * s[k]).sum();
        s[c] = (v[c] - tail) / m[c][c];
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points over a unit sphere's surface, with their outward normals.
    fn sphere(n: usize) -> Vec<Vec3> {
        let golden = std::f32::consts::PI * (3.0 - 5.0f32.sqrt());
        (0..n)
            .map(|i| {
                let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
                let r = (1.0 - z * z).sqrt();
                let t = golden * i as f32;
                Vec3::new(r * t.cos(), r * t.sin(), z)
            })
            .collect()
    }

    /// A sphere whose point `i` with normal `n` has the albedo `albedo(i, n)` (linear), lit per
    /// channel by `light(n)`.
    fn lit_sphere(albedo: impl Fn(usize, Vec3) -> Vec3, light: impl Fn(Vec3) -> Vec3) -> Cloud {
        let normals = sphere(2000);
        let colors = normals
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let lin = albedo(i, *n) * light(*n);
                Vec3::from_array(std::array::from_fn(|k| linear_to_srgb(lin[k])))
            })
            .collect();
        Cloud {
            points: normals.clone(),
            normals,
            colors,
            spacing: 0.01,
        }
    }

    /// `albedo`, but every seventh point `painted`.
    fn every_seventh(albedo: Vec3, painted: Vec3) -> impl Fn(usize, Vec3) -> Vec3 {
        move |i, _| if i % 7 == 0 { painted } else { albedo }
    }

    #[test]
    fn a_warm_side_and_a_blue_side_become_one_colour() {
        // A white object under a low sun from +x (warm) and a blue sky from −x, as a sunset HDRI.
        let light = |n: Vec3| {
            let f = (0.8 * n.x).exp();
            Vec3::new(0.5 * f, 0.45 * f.powf(0.6), 0.4 / f.powf(0.5))
        };
        let cloud = lit_sphere(
            every_seventh(Vec3::splat(0.8), Vec3::new(0.05, 0.3, 0.05)),
            light,
        );
        let neutral = CaptureShading::fit(&cloud).remove(&cloud);
        let spread = |c: &Cloud, k: usize| {
            let v: Vec<f32> = (0..c.colors.len())
                .filter(|i| i % 7 != 0)
                .map(|i| c.colors[i][k])
                .collect();
            let lo = v.iter().copied().fold(f32::MAX, f32::min);
            let hi = v.iter().copied().fold(f32::MIN, f32::max);
            hi - lo
        };
        for k in 0..3 {
            assert!(spread(&cloud, k) > 0.1, "channel {k} varies in the capture");
            assert!(
                spread(&neutral, k) < 0.02,
                "channel {k}: {} left",
                spread(&neutral, k)
            );
        }
        // The painted seventh is not followed: it keeps its own colour, relative to the rest.
        let (paint, white) = (neutral.colors[0], neutral.colors[1]);
        assert!(paint.y > paint.x + 0.2 && white.x > paint.x + 0.3);
    }

    #[test]
    fn objects_sharing_a_light_tell_it_from_their_paint() {
        // Under one light from +x, one object's top is painted red, another's front (+y) blue: each
        // object's own fit takes its paint for light, the shared fit much less so.
        let light = |n: Vec3| Vec3::splat((0.7 * n.x).exp());
        let painted = |paint: Vec3, faces: fn(Vec3) -> bool| {
            lit_sphere(
                |_, n| if faces(n) { paint } else { Vec3::splat(0.5) },
                light,
            )
        };
        let top = painted(Vec3::new(0.6, 0.1, 0.1), |n| n.z > 0.3);
        let front = painted(Vec3::new(0.1, 0.1, 0.6), |n| n.y > 0.3);
        let truth = Vec3::new(0.7, 0.0, 0.0);
        let error = |s: &CaptureShading| (0..3).map(|k| (s.slope[k] - truth).length()).sum::<f32>();
        let shared = error(&CaptureShading::fit_shared(&[&top, &front]));
        let alone = error(&CaptureShading::fit(&top)).min(error(&CaptureShading::fit(&front)));
        assert!(shared < 0.7 * alone, "shared {shared}, alone {alone}");
    }

    #[test]
    fn an_evenly_lit_object_keeps_its_colours() {
        let cloud = lit_sphere(
            every_seventh(Vec3::new(0.6, 0.3, 0.1), Vec3::new(0.1, 0.1, 0.5)),
            |_| Vec3::ONE,
        );
        let shading = CaptureShading::fit(&cloud);
        let same = shading.remove(&cloud);
        for (a, b) in cloud.colors.iter().zip(&same.colors) {
            assert!((*a - *b).abs().max_element() < 1e-3, "{a} → {b}");
        }
    }

    #[test]
    fn too_few_points_or_one_normal_change_nothing() {
        let flat = Cloud {
            points: vec![Vec3::ZERO; 40],
            normals: vec![Vec3::Z; 40],
            colors: vec![Vec3::new(0.2, 0.5, 0.9); 40],
            spacing: 0.01,
        };
        assert_eq!(CaptureShading::fit(&flat), CaptureShading::NONE);
        assert_eq!(CaptureShading::fit(&Cloud::default()), CaptureShading::NONE);
    }
}

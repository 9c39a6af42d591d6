//! A light at a point of the room: a bulb, a lamp, a spot seen from the side it lights. Its irradiance
//! falls with the square of the distance and with the cosine of the angle to the surface's normal, so
//! the light it throws on an object depends on where the object stands in 3D, not on what lies around
//! it in the panorama (the wall behind a bedside lamp's bed is lit less than the bed). The query's
//! linear colour over the empty room's (already re-shaded by the normal gain) is taken per channel as
//! `ambient + strength · φ(x, n)`, `φ = max(0, n · (L − x)) / (|L − x| · max(|L − x|, d₀)²)`: the
//! position `L` by a search over the room's extent, the two gains per channel by non-negative least
//! squares, robustly (objects in front of the room, shadows and the lamp's own glow are outliers).
//! Where no point light explains the room better than one gain, the strength comes out near zero and
//! the light is one gain everywhere.

use glam::Vec3;
use neuroom_core::image::{RgbImage, srgb_to_linear};
use rayon::prelude::*;

use crate::local_light::{robust_scale, under_gain};
use crate::shading::surface_points;
use crate::sphere_image::ClipLevel;

/// A point light relative to the captures' light: per channel, a gain everywhere plus the light of a
/// point at `position` (camera frame, metres).
#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    /// Where the light is (camera frame, metres).
    pub position: Vec3,
    /// Per channel, the gain of the light that reaches every surface alike.
    pub ambient: [f32; 3],
    /// Per channel, the gain the point adds to a surface 1 m away facing it.
    pub strength: [f32; 3],
    /// The direction the light faces when it emits like a surface (a window, a ceiling panel, a
    /// lamp's shade against a wall: its radiance falls with the cosine to this direction), the normal
    /// of the room's surface nearest it; `None` for a bulb, which lights every way alike.
    pub facing: Option<Vec3>,
}

/// Nearest distance at which the point's irradiance is taken as it is: nearer, it stays that of this
/// distance (a bulb's shade and size), so that a surface next to the light does not take it to infinity.
const NEAR_DISTANCE: f32 = 0.25;

/// Candidates per axis of the room's extent in the search of the light's position; the best is then
/// refined by halving steps down to [`FINEST_STEP`]: a grid fine enough that the best cell's basin holds
/// the light, coarse enough to be searched in a fraction of a second.
const GRID: usize = 10;

/// The step (metres) at which the refinement of the light's position stops: the size of a bulb.
const FINEST_STEP: f32 = 0.01;

/// Reweighting rounds of the robust fit.
const ROUNDS: usize = 3;

impl PointLight {
    /// A light that is one gain `g` everywhere.
    pub fn uniform(g: [f32; 3]) -> Self {
        Self {
            position: Vec3::ZERO,
            ambient: g,
            strength: [0.0; 3],
            facing: None,
        }
    }

    /// The gain per channel at surface point `point` with unit normal `normal` (both camera frame).
    pub fn gain(&self, point: Vec3, normal: Vec3) -> [f32; 3] {
        let phi = irradiance(self.position, self.facing, point, normal);
        std::array::from_fn(|k| self.ambient[k] + self.strength[k] * phi)
    }

    /// `image` (sRGB) under this light, its surfaces at ray distances `depth` with normals `normals`
    /// (camera frame); a pixel without a surface takes the ambient gain.
    pub fn apply(&self, image: &RgbImage, depth: &[f32], normals: &[Option<Vec3>]) -> RgbImage {
        let points = surface_points(depth, image.width as usize, image.height as usize);
        RgbImage {
            width: image.width,
            height: image.height,
            data: (image.data.iter().enumerate())
                .map(|(p, c)| {
                    let g = match (points[p], normals[p]) {
                        (Some(x), Some(n)) => self.gain(x, n),
                        _ => self.ambient,
                    };
                    under_gain(*c, g)
                })
                .collect(),
        }
    }

    /// The point light that best takes the room's empty view onto the query over the pixels of
    /// `room`. A pixel's say grows with its level over its level plus `dark_level`, as in the light
    /// field.
    pub fn fit(room: &RoomPixels, dark_level: f32) -> Self {
        let samples = Samples::new(room, dark_level);
        if samples.len() < 16 {
            return Self::uniform([1.0; 3]);
        }
        let bulb = samples.fit(Emitter::Bulb, dark_level);
        let surface = samples.fit(Emitter::Surface, dark_level);
        // The two compared by one robust loss, at the smaller of their residuals' scales.
        let scale = bulb.scale.min(surface.scale);
        if samples.robust_loss(&surface.errors, scale) < samples.robust_loss(&bulb.errors, scale) {
            surface.light
        } else {
            bulb.light
        }
    }
}

/// What a point light is fitted to: a query and the empty room seen from the same camera.
#[derive(Clone, Copy, Debug)]
pub struct RoomPixels<'a> {
    /// The query (sRGB).
    pub query: &'a RgbImage,
    /// The empty room (sRGB).
    pub empty: &'a RgbImage,
    /// The empty room's ray distances (0: no surface).
    pub depth: &'a [f32],
    /// The empty room's unit surface normals (camera frame).
    pub normals: &'a [Option<Vec3>],
    /// The pixels the camera saw (all when `None`).
    pub seen: Option<&'a [bool]>,
    /// Where the query burns out ([`ClipLevel::of`] the query): clipped pixels say nothing of
    /// the light.
    pub clip: ClipLevel,
}

/// How a point light emits.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Emitter {
    /// Every way alike.
    Bulb,
    /// Like a surface facing away from the room's surface nearest it (a window, a panel).
    Surface,
}

/// A light fitted robustly, with its residuals.
struct RobustFit {
    light: PointLight,
    /// Per sample, the relative colour error.
    errors: Vec<f32>,
    /// The Cauchy weights' scale of the last round.
    scale: f32,
}

/// The point's irradiance factor `φ` at `point` with normal `normal` from a light at `light` facing
/// `facing` (every way alike when `None`).
fn irradiance(light: Vec3, facing: Option<Vec3>, point: Vec3, normal: Vec3) -> f32 {
    let v = light - point;
    let d = v.length();
    if d <= 0.0 {
        return 0.0;
    }
    let near = d.max(NEAR_DISTANCE);
    let emitted = facing.map_or(1.0, |m| (-m.dot(v) / d).max(0.0));
    emitted * normal.dot(v).max(0.0) / (d * near * near)
}

/// One pixel of the room a point light is fitted over.
struct Sample {
    /// Surface point and normal (camera frame).
    point: Vec3,
    normal: Vec3,
    /// Linear colours of the query and the empty room.
    query: [f32; 3],
    empty: [f32; 3],
}

/// The room's pixels a point light is fitted over, how much each says, and the room's extent.
struct Samples {
    samples: Vec<Sample>,
    /// Per sample, its say before robust weighting: its level's and its solid angle's.
    trust: Vec<f32>,
    /// The extent of the room's points.
    low: Vec3,
    /// The search grid's cell (metres, per axis).
    cell: Vec3,
}

/// Pixels per sample along each axis: a quarter of the panorama's pixels say as much of a light that
/// varies smoothly as all of them.
const STRIDE: usize = 2;

impl Samples {
    fn new(room: &RoomPixels, dark_level: f32) -> Self {
        let RoomPixels {
            query,
            empty,
            depth,
            normals,
            seen,
            clip,
        } = *room;
        let (w, h) = (query.width as usize, query.height as usize);
        let points = surface_points(depth, w, h);
        let (mut samples, mut trust) = (Vec::new(), Vec::new());
        for v in (0..h).step_by(STRIDE) {
            let lat = std::f32::consts::PI * (0.5 - (v as f32 + 0.5) / h as f32);
            for u in (0..w).step_by(STRIDE) {
                let p = v * w + u;
                let (Some(point), Some(normal)) = (points[p], normals[p]) else {
                    continue;
                };
                if seen.is_some_and(|s| !s[p])
                    || clip.clips(&query.data[p])
                    || ClipLevel::WHITE.clips(&empty.data[p])
                {
                    continue;
                }
                let e = empty.data[p].map(srgb_to_linear);
                let level = e.iter().sum::<f32>() / 3.0;
                samples.push(Sample {
                    point,
                    normal,
                    query: query.data[p].map(srgb_to_linear),
                    empty: e,
                });
                trust.push(level / (level + dark_level) * lat.cos());
            }
        }
        let low = samples.iter().fold(Vec3::INFINITY, |l, s| l.min(s.point));
        let high = samples
            .iter()
            .fold(Vec3::NEG_INFINITY, |l, s| l.max(s.point));
        Samples {
            samples,
            trust,
            low,
            cell: (high - low) / GRID as f32,
        }
    }

    fn len(&self) -> usize {
        self.samples.len()
    }

    /// The light emitting as `emitter` fitted robustly: searched, then refined over [`ROUNDS`] rounds
    /// of Cauchy weights of the residuals.
    fn fit(&self, emitter: Emitter, dark_level: f32) -> RobustFit {
        let mut light = self.search(emitter, &self.trust, dark_level);
        let mut errors = self.errors(&light, dark_level);
        // Set in the first round: a fit has samples, so their deviations have a scale.
        let mut scale = f32::INFINITY;
        for _ in 0..ROUNDS {
            let Some(s) = robust_scale(errors.clone()) else {
                break;
            };
            scale = s;
            let weights: Vec<f32> = (self.trust.iter().zip(&errors))
                .map(|(t, e)| t / (1.0 + (e / scale).powi(2)))
                .collect();
            light = self.refine(light.position, self.cell, emitter, &weights, dark_level);
            errors = self.errors(&light, dark_level);
        }
        RobustFit {
            light,
            errors,
            scale,
        }
    }

    /// `Σ trust · ln(1 + (error / scale)²)`: the Cauchy loss of `errors`.
    fn robust_loss(&self, errors: &[f32], scale: f32) -> f64 {
        (self.trust.iter().zip(errors))
            .map(|(t, e)| *t as f64 * (1.0 + (e / scale).powi(2) as f64).ln())
            .sum()
    }

    /// The best light emitting as `emitter` on the grid over the room's extent, refined.
    fn search(&self, emitter: Emitter, weights: &[f32], dark_level: f32) -> PointLight {
        let candidates: Vec<Vec3> = (0..GRID * GRID * GRID)
            .map(|i| {
                let idx = Vec3::new(
                    (i % GRID) as f32,
                    (i / GRID % GRID) as f32,
                    (i / (GRID * GRID)) as f32,
                );
                self.low + (idx + 0.5) * self.cell
            })
            .collect();
        let costs: Vec<f32> = candidates
            .par_iter()
            .map(|l| self.solve(*l, emitter, weights, dark_level).1)
            .collect();
        let best = (0..candidates.len())
            .min_by(|&a, &b| costs[a].total_cmp(&costs[b]).then(a.cmp(&b)))
            .unwrap_or(0);
        self.refine(
            candidates[best],
            self.cell * 0.5,
            emitter,
            weights,
            dark_level,
        )
    }

    /// The light from `start` by a pattern search along the axes, the steps halved from `step` down to
    /// [`FINEST_STEP`].
    fn refine(
        &self,
        start: Vec3,
        step: Vec3,
        emitter: Emitter,
        weights: &[f32],
        dark_level: f32,
    ) -> PointLight {
        let (mut light, mut cost) = self.solve(start, emitter, weights, dark_level);
        let mut step = step;
        while step.max_element() >= FINEST_STEP {
            let moves = [
                Vec3::X,
                Vec3::NEG_X,
                Vec3::Y,
                Vec3::NEG_Y,
                Vec3::Z,
                Vec3::NEG_Z,
            ];
            let tried: Vec<(PointLight, f32)> = moves
                .par_iter()
                .map(|m| self.solve(light.position + *m * step, emitter, weights, dark_level))
                .collect();
            match tried
                .into_iter()
                .filter(|(_, c)| *c < cost)
                .min_by(|a, b| a.1.total_cmp(&b.1))
            {
                Some((l, c)) => (light, cost) = (l, c),
                None => step *= 0.5,
            }
        }
        light
    }

    /// The best gains for a light at `position` emitting as `emitter`, and their weighted cost: per
    /// channel the non-negative least squares of `query − empty · (a + b φ)`, each pixel weighted by
    /// its weight over its level (so that the squares are about those of sRGB differences).
    fn solve(
        &self,
        position: Vec3,
        emitter: Emitter,
        weights: &[f32],
        dark_level: f32,
    ) -> (PointLight, f32) {
        let facing = match emitter {
            Emitter::Bulb => None,
            Emitter::Surface => self.nearest_normal(position),
        };
        self.solve_facing(position, facing, weights, dark_level)
    }

    /// The normal of the room's surface nearest `position`.
    fn nearest_normal(&self, position: Vec3) -> Option<Vec3> {
        (self.samples.iter())
            .min_by(|a, b| {
                (a.point.distance_squared(position)).total_cmp(&b.point.distance_squared(position))
            })
            .map(|s| s.normal)
    }

    /// [`Samples::solve`] for a light facing `facing`.
    fn solve_facing(
        &self,
        position: Vec3,
        facing: Option<Vec3>,
        weights: &[f32],
        dark_level: f32,
    ) -> (PointLight, f32) {
        let mut sums = [Sums::default(); 3];
        for (sample, weight) in self.samples.iter().zip(weights) {
            let phi = irradiance(position, facing, sample.point, sample.normal) as f64;
            for (k, s) in sums.iter_mut().enumerate() {
                let (q, e) = (sample.query[k] as f64, sample.empty[k] as f64);
                s.add(*weight as f64 / (q + dark_level as f64), q, e, phi);
            }
        }
        let mut light = PointLight {
            position,
            ambient: [0.0; 3],
            strength: [0.0; 3],
            facing,
        };
        let mut cost = 0.0;
        for (k, s) in sums.iter().enumerate() {
            let (a, b) = s.solve();
            light.ambient[k] = a as f32;
            light.strength[k] = b as f32;
            cost += s.cost(a, b);
        }
        (light, cost as f32)
    }

    /// Per sample, the mean relative colour error of `light`.
    fn errors(&self, light: &PointLight, dark_level: f32) -> Vec<f32> {
        (self.samples.iter())
            .map(|s| {
                let g = light.gain(s.point, s.normal);
                (0..3)
                    .map(|k| (s.query[k] - s.empty[k] * g[k]).abs() / (s.query[k] + dark_level))
                    .sum::<f32>()
                    / 3.0
            })
            .collect()
    }
}

/// The weighted sums of one channel's least squares `q ≈ e (a + b φ)`.
#[derive(Clone, Copy, Default)]
struct Sums {
    ee: f64,
    ee_phi: f64,
    ee_phi2: f64,
    qe: f64,
    qe_phi: f64,
    qq: f64,
}

impl Sums {
    fn add(&mut self, w: f64, q: f64, e: f64, phi: f64) {
        let (ee, qe) = (w * e * e, w * q * e);
        self.ee += ee;
        self.ee_phi += ee * phi;
        self.ee_phi2 += ee * phi * phi;
        self.qe += qe;
        self.qe_phi += qe * phi;
        self.qq += w * q * q;
    }

    /// The non-negative `(a, b)` of least cost.
    fn solve(&self) -> (f64, f64) {
        let only_a = || ((self.qe / self.ee.max(1e-30)).max(0.0), 0.0);
        let det = self.ee * self.ee_phi2 - self.ee_phi * self.ee_phi;
        if det <= 1e-12 * self.ee * self.ee_phi2 || det <= 0.0 {
            return only_a();
        }
        let a = (self.qe * self.ee_phi2 - self.ee_phi * self.qe_phi) / det;
        let b = (self.ee * self.qe_phi - self.ee_phi * self.qe) / det;
        if b < 0.0 {
            return only_a();
        }
        if a < 0.0 {
            let (a_only, b_only) = (only_a(), (0.0, (self.qe_phi / self.ee_phi2).max(0.0)));
            let cost = |(a, b): (f64, f64)| self.cost(a, b);
            return if cost(b_only) < cost(a_only) {
                b_only
            } else {
                a_only
            };
        }
        (a, b)
    }

    /// The weighted squared error of `(a, b)`.
    fn cost(&self, a: f64, b: f64) -> f64 {
        self.qq - 2.0 * (a * self.qe + b * self.qe_phi)
            + a * a * self.ee
            + 2.0 * a * b * self.ee_phi
            + b * b * self.ee_phi2
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shading::panorama_normals;
    use neuroom_core::image::linear_to_srgb;

    /// Ray distances of a box room `[-2, 3] × [-1.5, 2] × [-1.2, 1.5]` seen from the origin.
    fn box_depth(w: usize, h: usize) -> Vec<f32> {
        let (low, high) = (Vec3::new(-2.0, -1.5, -1.2), Vec3::new(3.0, 2.0, 1.5));
        crate::test_rooms::box_room_depth(w, h, low, high)
    }

    /// A textured box room, and the same under `light` with a dark object in front of one wall.
    fn lit_room(w: usize, h: usize, light: &PointLight) -> (RgbImage, RgbImage, Vec<f32>) {
        let depth = box_depth(w, h);
        let normals = panorama_normals(&depth, w, h);
        let texture = |p: usize| {
            let t = 0.3 + 0.2 * (((p % w) / 4 + (p / w) / 3) % 3) as f32 / 2.0;
            [t, 0.9 * t, 0.8 * t]
        };
        let empty = RgbImage {
            width: w as u32,
            height: h as u32,
            data: (0..w * h).map(texture).collect(),
        };
        let lit = light.apply(&empty, &depth, &normals);
        let mut query = lit.clone();
        for (p, c) in query.data.iter_mut().enumerate() {
            let (u, v) = (p % w, p / w);
            if (100..120).contains(&u) && (60..80).contains(&v) {
                *c = [0.05, 0.3, 0.05];
            }
        }
        (query, empty, depth)
    }

    /// The point light fitted to [`lit_room`] under `truth`.
    fn fitted_to_lit_room(w: usize, h: usize, truth: &PointLight) -> PointLight {
        let (query, empty, depth) = lit_room(w, h, truth);
        let normals = panorama_normals(&depth, w, h);
        let room = RoomPixels {
            query: &query,
            empty: &empty,
            depth: &depth,
            normals: &normals,
            seen: None,
            clip: ClipLevel::of(&query.data),
        };
        PointLight::fit(&room, 0.01)
    }

    #[test]
    fn a_bulb_is_found_where_it_hangs() {
        let (w, h) = (256, 128);
        let truth = PointLight {
            position: Vec3::new(1.8, 1.2, 0.3),
            ambient: [0.2, 0.15, 0.1],
            strength: [1.5, 1.0, 0.4],
            facing: None,
        };
        let fit = fitted_to_lit_room(w, h, &truth);
        assert!(
            fit.position.distance(truth.position) < 0.05,
            "{:?} against {:?}",
            fit.position,
            truth.position
        );
        for k in 0..3 {
            assert!(
                (fit.ambient[k] / truth.ambient[k] - 1.0).abs() < 0.05,
                "{fit:?}"
            );
            assert!(
                (fit.strength[k] / truth.strength[k] - 1.0).abs() < 0.05,
                "{fit:?}"
            );
        }
    }

    #[test]
    fn a_window_is_found_on_its_wall_facing_into_the_room() {
        let (w, h) = (256, 128);
        let truth = PointLight {
            position: Vec3::new(2.95, 0.5, 0.4),
            ambient: [0.3; 3],
            strength: [2.0, 2.0, 2.4],
            facing: Some(Vec3::NEG_X),
        };
        let fit = fitted_to_lit_room(w, h, &truth);
        assert!(
            fit.facing.is_some_and(|m| m.dot(Vec3::NEG_X) > 0.99),
            "{fit:?}"
        );
        assert!(fit.position.distance(truth.position) < 0.1, "{fit:?}");
        // What stands before the window turned away from it is lit by the ambient light alone.
        let back = fit.gain(Vec3::new(2.0, 0.5, 0.0), Vec3::NEG_X);
        assert!((back[0] / truth.ambient[0] - 1.0).abs() < 0.05, "{back:?}");
    }

    #[test]
    fn one_gain_everywhere_is_a_light_without_a_point() {
        let (w, h) = (256, 128);
        let fit = fitted_to_lit_room(w, h, &PointLight::uniform([1.4, 1.1, 0.9]));
        for k in 0..3 {
            assert!(fit.strength[k] < 0.01, "{fit:?}");
        }
        let (x, n) = (Vec3::new(2.9, 0.0, 0.0), Vec3::NEG_X);
        let g = fit.gain(x, n);
        for (k, want) in [1.4, 1.1, 0.9].iter().enumerate() {
            assert!((g[k] / want - 1.0).abs() < 0.02, "{g:?}");
        }
    }

    #[test]
    fn a_point_lights_what_faces_it_by_the_inverse_square() {
        let light = PointLight {
            position: Vec3::new(0.0, 0.0, 2.0),
            ambient: [0.0; 3],
            strength: [1.0; 3],
            facing: None,
        };
        let up = Vec3::Z;
        assert!((light.gain(Vec3::ZERO, up)[0] - 0.25).abs() < 1e-6);
        assert!((light.gain(Vec3::new(0.0, 0.0, 1.0), up)[0] - 1.0).abs() < 1e-6);
        // Nearer than the bulb's size it stays that of the bulb's size; behind a face, nothing.
        let near = light.gain(Vec3::new(0.0, 0.0, 1.9), up)[0];
        assert!((near - 0.1 / (0.1 * NEAR_DISTANCE * NEAR_DISTANCE)).abs() < 1e-3);
        assert_eq!(light.gain(Vec3::ZERO, -up)[0], 0.0);
        assert!(linear_to_srgb(light.gain(Vec3::ZERO, up)[0]) > 0.0);
    }
}

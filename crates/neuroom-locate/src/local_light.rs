//! The light of the panorama as it varies over the room. A lamp lights one corner, a spot one patch of
//! wall, a window one side of the room: the query differs from the empty room (rendered under its
//! captures' light, re-shaded by [`crate::shading`] for what depends on the surface normal alone) by a
//! factor per colour channel that changes smoothly over each surface. That factor, the ratio of the
//! query's linear colour to the empty room's, is estimated per pixel by a normalised Gaussian
//! convolution of the log ratios over the room's pixels, robustly (objects standing in front of the
//! room, light sources and shadows are outliers, re-weighted away over a few rounds), and where few
//! pixels support it falls back to a broader estimate. It relights the empty room, so that the room
//! explains the query everywhere but where objects stand, and the objects, which take the light of the
//! place they stand in. An object hypothesis is judged under the field estimated without its own pixels
//! ([`LightField::gains_without`]): robust weights cannot tell a pool of light from an object as large
//! as the Gaussian, whose pixels then make most of their own neighbourhood, but leaving the hypothesis's
//! pixels out asks what the room around it says of the light there, for the room and the object alike.

use glam::Vec3;
use neuroom_core::image::{RgbImage, linear_to_srgb, srgb_to_linear};
use serde::{Deserialize, Serialize};

use crate::cell_smooth::{CellSmoother, CellSums};
use crate::point_light::{PointLight, RoomPixels};
use crate::shading::{NormalGain, fit_room_shading, panorama_normals};
use crate::sphere_image::ClipLevel;

/// The query's light relative to the captures' at every pixel: a gain per colour channel that depends
/// on the surface's normal ([`crate::shading`]: the light's colour, level and direction, as the whole
/// room shows it), times a smooth field over the panorama ([`LightField`]: what lights one place more
/// than another). The empty room is relit by it; an object takes, at each of its pixels, the field
/// there and the normal gain of its own surface.
#[derive(Clone, Debug, PartialEq)]
pub struct RoomLight {
    /// The gain by the surface normal (camera frame).
    pub shading: NormalGain,
    /// A light at a point of the room on top of it ([`crate::point_light`]; `None` when not fitted).
    pub point: Option<PointLight>,
    /// The smooth field on top of both.
    pub field: LightField,
}

impl RoomLight {
    /// The light of `query` relative to the empty room `empty` seen from the same camera (ray distances
    /// `depth`), over the pixels the camera saw (`seen`, all when `None`). With `by_normal` false the
    /// normal gain is one gain per channel.
    pub fn fit(
        query: &RgbImage,
        empty: &RgbImage,
        depth: &[f32],
        seen: Option<&[bool]>,
        by_normal: bool,
        config: &LocalLightConfig,
    ) -> Self {
        let (w, h) = (empty.width as usize, empty.height as usize);
        let normals = panorama_normals(depth, w, h);
        let seen_depth: Vec<f32> = (0..w * h)
            .map(|p| {
                if seen.is_none_or(|s| s[p]) {
                    depth[p]
                } else {
                    0.0
                }
            })
            .collect();
        let shading = if by_normal {
            fit_room_shading(query, empty, &seen_depth)
        } else {
            NormalGain::constant(
                crate::evidence::room_gains_of(query, empty, &seen_depth).map(f64::from),
            )
        };
        let mut shaded = shading.apply(empty, &normals);
        let clip = ClipLevel::of(&query.data);
        let point = config.point_light.then(|| {
            let room = RoomPixels {
                query,
                empty: &shaded,
                depth,
                normals: &normals,
                seen,
                clip,
            };
            let point = PointLight::fit(&room, config.dark_level);
            shaded = point.apply(&shaded, depth, &normals);
            point
        });
        let field = fit_light_field(query, clip, &shaded, depth, seen, config);
        Self {
            shading,
            point,
            field,
        }
    }

    /// The empty room `empty` (ray distances `depth`, surface normals `normals`, camera frame) under
    /// this light.
    pub fn relight_room(
        &self,
        empty: &RgbImage,
        depth: &[f32],
        normals: &[Option<Vec3>],
    ) -> RgbImage {
        let shaded = self.shading.apply(empty, normals);
        match &self.point {
            Some(point) => self.field.apply(&point.apply(&shaded, depth, normals)),
            None => self.field.apply(&shaded),
        }
    }

    /// The sRGB colour `c` of an object's surface at `point` (asked for only when a point light is
    /// fitted) with unit normal `normal` (both camera frame) where the field's gain is `field_gain` ([`LightField::gain`], or
    /// [`LightField::gains_without`] the object's pixels), under this light (in linear light, clipped
    /// at white).
    pub fn relight_object(
        &self,
        field_gain: [f32; 3],
        c: [f32; 3],
        point: impl FnOnce() -> Vec3,
        normal: Vec3,
    ) -> [f32; 3] {
        let s = self.shading.at(Some(normal));
        let p = match &self.point {
            Some(light) => light.gain(point(), normal),
            None => [1.0; 3],
        };
        under_gain(
            c,
            std::array::from_fn(|k| s[k] as f32 * p[k] * field_gain[k]),
        )
    }
}

/// Settings of the light field's estimation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocalLightConfig {
    /// Standard deviation of the Gaussian over which the light is taken as one (degrees of longitude):
    /// a lamp's pool of light or a spot spans tens of degrees, an object seen across the room a few;
    /// the robust weights keep an object's own pixels out of the light around it.
    pub sigma_deg: f32,
    /// Reweighting rounds of the robust estimate.
    pub rounds: usize,
    /// Linear-light level below which a pixel's ratio counts less (its weight is its level over its
    /// level plus this): noise in the darkest pixels says little of the light.
    pub dark_level: f32,
    /// Whether a light at a point of the room ([`crate::point_light`]) is fitted under the field: a
    /// bulb or a lamp lights an object by where it stands, not by the wall behind it. Off by default:
    /// an isotropic point mimics a window's light from inside the room and lights the faces of the
    /// objects by the window that the window does not (docs/experiment-log.md).
    #[serde(default)]
    pub point_light: bool,
}

impl Default for LocalLightConfig {
    fn default() -> Self {
        Self {
            sigma_deg: 6.0,
            rounds: 3,
            dark_level: 0.01,
            point_light: false,
        }
    }
}

/// How much broader the fallback Gaussian is than [`LocalLightConfig::sigma_deg`], and the weight of
/// its support against the narrow one's: where a pixel's neighbourhood holds little of the room (a
/// large object in front of it), the light of a wider neighbourhood is taken.
const FALLBACK_SCALE: f32 = 4.0;
const FALLBACK_WEIGHT: f32 = 0.05;

/// The query's light relative to the empty room's, per pixel and channel (linear gains), and what it
/// was estimated from, so that it can be estimated again without some of its pixels
/// ([`LightField::gains_without`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LightField {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Per pixel, the linear gain per channel.
    pub gains: Vec<[f32; 3]>,
    smoother: CellSmoother,
    sums: CellSums,
    /// Per pixel, the log ratio of the query to the empty room, and the weight it had in the field.
    log_ratio: Vec<[f32; 3]>,
    weight: Vec<f32>,
}

impl LightField {
    /// The gain at pixel `p`.
    pub fn gain(&self, p: usize) -> [f32; 3] {
        self.gains[p]
    }

    /// The gains at `pixels` of the field estimated as it was but without those pixels: the light
    /// the room around them shows. An object hypothesis is judged under it, so that a large object,
    /// whose own pixels fill the Gaussian around them, is not taken for a change of light.
    pub fn gains_without(&self, pixels: &[u32]) -> Vec<[f32; 3]> {
        (self.smoother)
            .without(&self.sums, &self.log_ratio, &self.weight, pixels)
            .into_iter()
            .map(|l| l.map(f32::exp))
            .collect()
    }

    /// The sRGB colour `c` under the gain of pixel `p` (in linear light, clipped at white).
    pub fn relight(&self, p: usize, c: [f32; 3]) -> [f32; 3] {
        under_gain(c, self.gains[p])
    }

    /// `image` with every pixel under its gain.
    pub fn apply(&self, image: &RgbImage) -> RgbImage {
        RgbImage {
            width: image.width,
            height: image.height,
            data: (image.data.iter().enumerate())
                .map(|(p, c)| self.relight(p, *c))
                .collect(),
        }
    }
}

/// The sRGB colour `c` under the linear gains `g` (clipped at white).
pub fn under_gain(c: [f32; 3], g: [f32; 3]) -> [f32; 3] {
    linear_under_gain(c.map(srgb_to_linear), g)
}

/// [`under_gain`] of a colour given in linear light (`linear`), as sRGB.
pub fn linear_under_gain(linear: [f32; 3], g: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|k| linear_to_srgb((linear[k] * g[k]).min(1.0)))
}

/// The light field mapping `empty` onto `query` (both `width × height` panoramas, sRGB) over the pixels
/// with a room surface (`depth > 0`) that the camera saw (`seen`, all when `None`) and that do not
/// burn out in the query (`clip`, [`ClipLevel::of`] the query).
pub fn fit_light_field(
    query: &RgbImage,
    clip: ClipLevel,
    empty: &RgbImage,
    depth: &[f32],
    seen: Option<&[bool]>,
    config: &LocalLightConfig,
) -> LightField {
    let (w, h) = (query.width as usize, query.height as usize);
    let valid: Vec<bool> = (0..w * h)
        .map(|p| {
            depth[p] > 0.0
                && seen.is_none_or(|s| s[p])
                && !clip.clips(&query.data[p])
                && !ClipLevel::WHITE.clips(&empty.data[p])
        })
        .collect();
    let linear = |c: [f32; 3]| c.map(|x| srgb_to_linear(x).max(TINY));
    let log_ratio: Vec<[f32; 3]> = (0..w * h)
        .map(|p| {
            let (q, e) = (linear(query.data[p]), linear(empty.data[p]));
            std::array::from_fn(|k| (q[k] / e[k]).ln())
        })
        .collect();
    // How much each pixel's ratio says: none outside the room, less in the dark.
    let trust: Vec<f32> = (0..w * h)
        .map(|p| {
            if !valid[p] {
                return 0.0;
            }
            let level = linear(empty.data[p]).iter().sum::<f32>() / 3.0;
            level / (level + config.dark_level)
        })
        .collect();
    let sigma = config.sigma_deg * w as f32 / 360.0;
    let smoother = CellSmoother::new(w, h, sigma, FALLBACK_SCALE, FALLBACK_WEIGHT);
    let field_of = |weight: &[f32]| {
        let sums = smoother.sums(&log_ratio, weight);
        let means = smoother.means(&sums);
        let field: Vec<[f32; 3]> = (0..w * h).map(|p| smoother.at(&means, p)).collect();
        (sums, field)
    };
    let mut weight = trust.clone();
    let (mut sums, mut field) = field_of(&weight);
    for _ in 0..config.rounds {
        let deviation: Vec<f32> = (0..w * h)
            .map(|p| {
                (0..3)
                    .map(|k| (log_ratio[p][k] - field[p][k]).abs())
                    .sum::<f32>()
                    / 3.0
            })
            .collect();
        let valid_deviation = (deviation.iter().zip(&valid))
            .filter(|(_, v)| **v)
            .map(|(d, _)| *d)
            .collect();
        let Some(scale) = robust_scale(valid_deviation) else {
            break;
        };
        weight = (0..w * h)
            .map(|p| trust[p] / (1.0 + (deviation[p] / scale).powi(2)))
            .collect();
        (sums, field) = field_of(&weight);
    }
    LightField {
        width: w,
        height: h,
        gains: field.iter().map(|l| l.map(f32::exp)).collect(),
        smoother,
        sums,
        log_ratio,
        weight,
    }
}

/// Smallest linear value a colour channel is taken at (a black pixel has no finite log).
const TINY: f32 = 1e-4;

/// Smallest scale of the robust weights (log ratio, or relative colour error): a few per cent, the
/// noise of a camera's and a JPEG's colours, so that a light fitted exactly does not make every other
/// pixel an outlier.
const LEAST_SCALE: f32 = 0.05;

/// 2.5 × the median of the deviations `d`, at least [`LEAST_SCALE`]: the Cauchy weight's scale of the
/// light's robust fits; `None` when there are none.
pub(crate) fn robust_scale(mut d: Vec<f32>) -> Option<f32> {
    if d.is_empty() {
        return None;
    }
    let mid = d.len() / 2;
    let median = *d.select_nth_unstable_by(mid, f32::total_cmp).1;
    Some((2.5 * median).max(LEAST_SCALE))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `w × h` panorama whose colour at each pixel is `colour(u, v)`.
    fn image(w: usize, h: usize, colour: impl Fn(usize, usize) -> [f32; 3]) -> RgbImage {
        RgbImage {
            width: w as u32,
            height: h as u32,
            data: (0..w * h).map(|p| colour(p % w, p / w)).collect(),
        }
    }

    /// [`fit_light_field`] of `query` onto `empty` with the query's own clip level and the default
    /// settings.
    fn fitted_field(
        query: &RgbImage,
        empty: &RgbImage,
        depth: &[f32],
        seen: Option<&[bool]>,
    ) -> LightField {
        let clip = ClipLevel::of(&query.data);
        fit_light_field(
            query,
            clip,
            empty,
            depth,
            seen,
            &LocalLightConfig::default(),
        )
    }

    /// A textured room under a light that is brighter and warmer around column 40 than elsewhere, with
    /// a dark object standing in the bright patch.
    fn spot_scene(w: usize, h: usize) -> (RgbImage, RgbImage, impl Fn(usize, usize) -> [f32; 3]) {
        let texture = |u: usize, v: usize| {
            let t = 0.35 + 0.15 * (((u / 3 + v / 5) % 4) as f32 / 3.0);
            [t, 0.9 * t, 0.8 * t]
        };
        let light = move |u: usize, _v: usize| {
            let d = (u as f32 - 40.0) / 20.0;
            let bright = 1.0 + 2.0 * (-0.5 * d * d).exp();
            [bright * 1.2, bright, bright * 0.8]
        };
        let empty = image(w, h, texture);
        let object = |u: usize, v: usize| (36..44).contains(&u) && (14..22).contains(&v);
        let query = image(w, h, |u, v| {
            if object(u, v) {
                return [0.05, 0.3, 0.05];
            }
            let (t, l) = (texture(u, v), light(u, v));
            std::array::from_fn(|k| linear_to_srgb((srgb_to_linear(t[k]) * l[k]).min(1.0)))
        });
        (query, empty, light)
    }

    #[test]
    fn a_pool_of_light_is_recovered_around_an_object_standing_in_it() {
        let (w, h) = (128, 64);
        let (query, empty, light) = spot_scene(w, h);
        let depth = vec![3.0; w * h];
        let field = fitted_field(&query, &empty, &depth, None);
        for (u, v) in [(40, 18), (40, 40), (10, 30), (70, 10)] {
            let (got, truth) = (field.gain(v * w + u), light(u, v));
            for k in 0..3 {
                let rel = (got[k] / truth[k] - 1.0).abs();
                assert!(
                    rel < 0.15,
                    "pixel ({u}, {v}) channel {k}: {got:?} vs {truth:?}"
                );
            }
        }
        // The relit room explains the query away from the object, and not on it.
        let relit = field.apply(&empty);
        let err = |u: usize, v: usize| {
            let p = v * w + u;
            (0..3)
                .map(|k| (relit.data[p][k] - query.data[p][k]).abs())
                .sum::<f32>()
                / 3.0
        };
        assert!(err(30, 18) < 0.03 && err(50, 30) < 0.03);
        assert!(err(40, 18) > 0.2);
    }

    #[test]
    fn a_large_object_is_judged_under_the_light_around_it() {
        // A uniform room under a warm light, and a green object four Gaussians wide in front of it:
        // the field takes part of the object's colour for light, the field without its pixels does not.
        let (w, h) = (256, 128);
        let empty = image(w, h, |_, _| [0.5; 3]);
        let light = [1.6f32, 1.2, 0.8];
        let object = |u: usize, v: usize| (100..160).contains(&u) && (40..100).contains(&v);
        let query = image(w, h, |u, v| {
            if object(u, v) {
                [0.2, 0.6, 0.2]
            } else {
                std::array::from_fn(|k| linear_to_srgb(srgb_to_linear(0.5) * light[k]))
            }
        });
        let depth = vec![3.0; w * h];
        let field = fitted_field(&query, &empty, &depth, None);
        let pixels: Vec<u32> = (0..w * h)
            .filter(|p| object(p % w, p / w))
            .map(|p| p as u32)
            .collect();
        let centre = pixels
            .iter()
            .position(|&p| p as usize == 70 * w + 130)
            .unwrap();
        let off = |g: [f32; 3]| {
            (0..3)
                .map(|k| (g[k] / light[k] - 1.0).abs())
                .fold(0.0, f32::max)
        };
        assert!(
            off(field.gain(70 * w + 130)) > 0.2,
            "{:?}",
            field.gain(70 * w + 130)
        );
        let around = field.gains_without(&pixels);
        assert!(off(around[centre]) < 0.05, "{:?}", around[centre]);
        assert!(around.iter().all(|g| off(*g) < 0.1));
    }

    #[test]
    fn pixels_without_a_surface_or_unseen_keep_the_light_around_them() {
        let (w, h) = (64, 32);
        let empty = image(w, h, |_, _| [0.4; 3]);
        let query = image(w, h, |_, _| [linear_to_srgb(2.0 * srgb_to_linear(0.4)); 3]);
        let depth: Vec<f32> = (0..w * h)
            .map(|p| if p % w < 10 { 0.0 } else { 2.0 })
            .collect();
        let seen: Vec<bool> = (0..w * h).map(|p| p % w < 50).collect();
        let field = fitted_field(&query, &empty, &depth, Some(&seen));
        for p in [5, 30, 60, 32 * 20 + 5] {
            for g in field.gain(p) {
                assert!((g - 2.0).abs() < 0.05, "pixel {p}: {g}");
            }
        }
    }

    #[test]
    fn an_object_nearer_a_fitted_bulb_is_lit_more_than_the_wall_behind_it() {
        // A room with a floor 1.2 m below the camera and walls 3 m away, lit by a bulb 1 m above
        // the floor: the relit room matches the query, and a surface between the bulb and the wall
        // takes more light than the wall behind it.
        let (w, h) = (256, 128);
        let (low, high) = (Vec3::new(-3.0, -3.0, -1.2), Vec3::new(3.0, 3.0, 1.6));
        let depth = crate::test_rooms::box_room_depth(w, h, low, high);
        let normals = panorama_normals(&depth, w, h);
        let empty = image(w, h, |u, v| [0.3 + 0.1 * ((u / 5 + v / 7) % 2) as f32; 3]);
        let bulb = PointLight {
            position: Vec3::new(2.0, 0.5, -0.2),
            ambient: [0.3; 3],
            strength: [1.2; 3],
            facing: None,
        };
        let query = bulb.apply(&empty, &depth, &normals);
        let config = LocalLightConfig {
            point_light: true,
            ..LocalLightConfig::default()
        };
        let light = RoomLight::fit(&query, &empty, &depth, None, false, &config);
        let relit = light.relight_room(&empty, &depth, &normals);
        let mean_error = (relit.data.iter().zip(&query.data))
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).abs()).sum::<f32>() / 3.0)
            .sum::<f32>()
            / (w * h) as f32;
        assert!(mean_error < 0.01, "{mean_error}");
        let p = (h / 2) * w; // the centre column, on the horizon: the wall at x = 3
        let (normal, grey) = (Vec3::NEG_X, [0.4; 3]);
        let wall = light.relight_object(
            light.field.gain(p),
            grey,
            || Vec3::new(3.0, 0.0, 0.0),
            normal,
        );
        let nearer = light.relight_object(
            light.field.gain(p),
            grey,
            || Vec3::new(2.6, 0.0, 0.0),
            normal,
        );
        assert!(nearer[0] > wall[0] + 0.02, "{nearer:?} against {wall:?}");
    }
}

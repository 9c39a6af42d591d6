//! Where the panorama shows something the empty room does not: the per-pixel difference between the
//! input and the empty room rendered at the found camera, after a robust per-channel gain (changed light
//! colour and exposure), thresholded against its own spread, cleaned by opening, split into connected
//! regions; light sources and the ceiling are left out. A [`Detector`] turns a view into detections;
//! [`ResidualDetector`] is this classical one, and a learned detector plugs in through the same trait
//! (it may also name the model of each detection).

use glam::{DVec2, Vec3};
use neuroom_core::camera::{CameraModel, Equirect};
use neuroom_core::image::{RgbImage, relit, srgb_to_linear};
use neuroom_panorama::Detection;
use neuroom_panorama::region::components;
use neuroom_panorama::sphere::neighbours;
use serde::{Deserialize, Serialize};

use crate::local_light::RoomLight;
use crate::shading::panorama_normals;
use crate::sphere_image::ClipLevel;

/// The input panorama and the empty room, both at the working resolution, at the found camera.
#[derive(Clone, Debug)]
pub struct SearchView {
    /// Input panorama, downsampled.
    pub query: RgbImage,
    /// Empty room rendered at the camera.
    pub empty: RgbImage,
    /// Ray distance of the empty room per pixel (0 = none).
    pub empty_depth: Vec<f32>,
    /// Pixels the camera saw ([`crate::SphereImage::seen`]); `None` for a panorama, which saw them all.
    /// Nothing is looked for, or held against an object, where the camera saw nothing.
    pub seen: Option<Vec<bool>>,
    /// The query's light relative to the captures' as it varies over the panorama, which `empty`
    /// already shows and objects take where they stand ([`crate::local_light`]); `None`: one light
    /// everywhere.
    pub light: Option<RoomLight>,
}

impl SearchView {
    /// Columns.
    pub fn width(&self) -> usize {
        self.query.width as usize
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.query.height as usize
    }

    /// Whether the camera saw pixel `p`.
    pub fn sees(&self, p: usize) -> bool {
        self.seen.as_ref().is_none_or(|s| s[p])
    }

    /// The unit ray of pixel `p`'s centre (camera frame).
    pub fn direction(&self, p: usize) -> Vec3 {
        let camera = Equirect {
            width: self.query.width,
            height: self.query.height,
        };
        let (u, v) = (p % self.width(), p / self.width());
        let pixel = DVec2::new(u as f64 + 0.5, v as f64 + 0.5);
        camera.direction(pixel).as_vec3()
    }
}

/// Finds object regions in a view.
pub trait Detector {
    /// Detections, in any order; they may overlap.
    fn detect(&self, view: &SearchView) -> Vec<Detection>;
}

/// Thresholds of [`ResidualDetector`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ResidualDetector {
    /// A pixel is object evidence when its residual exceeds this many times the median residual…
    pub factor: f32,
    /// …and this absolute floor (mean absolute sRGB difference).
    pub floor: f32,
    /// Smallest region kept (pixels).
    pub min_pixels: usize,
    /// Pixels brighter than this share of the panorama's limit ([`ClipLevel`]) in every channel are
    /// light sources, not objects.
    pub light_source: f32,
    /// Surfaces whose normal's vertical component is below this (the ceiling, which no object stands
    /// on and which other lamps light very differently) give no evidence.
    pub ceiling_normal_z: f32,
}

impl Default for ResidualDetector {
    fn default() -> Self {
        Self {
            factor: 3.0,
            floor: 0.06,
            min_pixels: 12,
            light_source: 0.97,
            ceiling_normal_z: -0.8,
        }
    }
}

impl Detector for ResidualDetector {
    fn detect(&self, view: &SearchView) -> Vec<Detection> {
        let residual = residual(view);
        let mut sorted: Vec<f32> = (residual.iter().enumerate())
            .filter(|(p, _)| view.sees(*p))
            .map(|(_, r)| *r)
            .collect();
        if sorted.is_empty() {
            return Vec::new();
        }
        let mid = sorted.len() / 2;
        let median = *sorted.select_nth_unstable_by(mid, f32::total_cmp).1;
        let threshold = (self.factor * median).max(self.floor);
        let (w, h) = (view.width(), view.height());
        let normals = panorama_normals(&view.empty_depth, w, h);
        let level = ClipLevel::of(&view.query.data);
        let raw: Vec<bool> = residual
            .iter()
            .zip(&view.query.data)
            .zip(&normals)
            .map(|((r, q), n)| {
                let light = (q.iter().zip(&level.limit)).all(|(c, l)| *c > self.light_source * l);
                let ceiling = n.is_some_and(|n| n.z < self.ceiling_normal_z);
                *r > threshold && !light && !ceiling
            })
            .collect();
        let cleaned = dilate(&erode(&raw, w, h), w, h);
        components(&cleaned, w, h)
            .into_iter()
            .filter(|c| c.len() >= self.min_pixels)
            .map(|pixels| Detection {
                pixels,
                model: None,
            })
            .collect()
    }
}

/// Per-channel gain from the empty room to the query: the median ratio of linear values over seen
/// pixels with a depth (a changed light colour or exposure).
pub fn room_gains(view: &SearchView) -> [f32; 3] {
    let depth: Vec<f32> = (view.empty_depth.iter().enumerate())
        .map(|(p, d)| if view.sees(p) { *d } else { 0.0 })
        .collect();
    room_gains_of(&view.query, &view.empty, &depth)
}

/// [`room_gains`] of `query` against `empty` over the pixels with a depth.
pub fn room_gains_of(query: &RgbImage, empty: &RgbImage, depth: &[f32]) -> [f32; 3] {
    std::array::from_fn(|c| {
        let mut ratios: Vec<f32> = query
            .data
            .iter()
            .zip(&empty.data)
            .zip(depth)
            .filter(|(_, d)| **d > 0.0)
            .map(|((q, e), _)| (srgb_to_linear(q[c]) + 1e-3) / (srgb_to_linear(e[c]) + 1e-3))
            .collect();
        if ratios.is_empty() {
            return 1.0;
        }
        let mid = ratios.len() / 2;
        *ratios.select_nth_unstable_by(mid, f32::total_cmp).1
    })
}

/// The empty room's colour per pixel as the query's light shows it under one gain per channel
/// ([`room_gains`], [`relit`]).
pub fn relit_room(view: &SearchView) -> Vec<[f32; 3]> {
    let gains = room_gains(view);
    view.empty.data.iter().map(|e| relit(*e, gains)).collect()
}

/// Mean absolute difference of two sRGB colours.
pub fn colour_error(a: [f32; 3], b: [f32; 3]) -> f32 {
    (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0
}

/// Mean absolute sRGB difference per pixel between the query and the relit empty room; 0 where the
/// empty room has no surface or the camera saw nothing (nothing is known there).
pub fn residual(view: &SearchView) -> Vec<f32> {
    relit_room(view)
        .iter()
        .zip(&view.query.data)
        .zip(&view.empty_depth)
        .enumerate()
        .map(|(p, ((r, q), d))| {
            if *d > 0.0 && view.sees(p) {
                colour_error(*q, *r)
            } else {
                0.0
            }
        })
        .collect()
}

/// A pixel stays set when it and its 4 neighbours are set.
pub fn erode(mask: &[bool], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .map(|i| mask[i] && neighbours(i, w, h).all(|j| mask[j]))
        .collect()
}

/// A pixel is set when it or one of its 4 neighbours is set.
pub fn dilate(mask: &[bool], w: usize, h: usize) -> Vec<bool> {
    (0..w * h)
        .map(|i| mask[i] || neighbours(i, w, h).any(|j| mask[j]))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ops::Range;

    /// A `w × h` image of one grey level.
    fn grey(w: usize, h: usize, level: f32) -> RgbImage {
        RgbImage {
            width: w as u32,
            height: h as u32,
            data: vec![[level; 3]; w * h],
        }
    }

    /// Sets the block `rows × cols` of `image` to `c`.
    fn paint(image: &mut RgbImage, rows: Range<usize>, cols: Range<usize>, c: [f32; 3]) {
        let w = image.width as usize;
        for v in rows {
            for u in cols.clone() {
                image.data[v * w + u] = c;
            }
        }
    }

    #[test]
    fn a_dark_object_on_a_grey_wall_is_detected_under_a_changed_exposure() {
        let (w, h) = (32usize, 16usize);
        let empty = grey(w, h, 0.6);
        let mut query = empty.map(|c| c.map(|x| x * 0.8));
        paint(&mut query, 6..11, 10..16, [0.1, 0.2, 0.05]);
        let mut view = SearchView {
            query,
            empty,
            empty_depth: vec![2.0; w * h],
            seen: None,
            light: None,
        };
        let found = ResidualDetector::default().detect(&view);
        assert_eq!(found.len(), 1);
        // Opening removes the one-pixel rim of the 6 × 5 block, dilation restores most of it.
        assert!(found[0].pixels.len() >= 20 && found[0].pixels.len() <= 30);
        // A photo whose field of view (the left half) misses the object finds nothing.
        view.seen = Some((0..w * h).map(|p| p % w < w / 2 - 4).collect());
        assert!(ResidualDetector::default().detect(&view).is_empty());
    }

    #[test]
    fn light_sources_and_the_ceiling_give_no_evidence() {
        // A sphere of radius 2 around the camera: its top rows face down like a ceiling.
        let (w, h) = (32usize, 16usize);
        let empty = grey(w, h, 0.5);
        let mut query = empty.clone();
        paint(&mut query, 0..3, 2..8, [0.1, 0.1, 0.1]);
        paint(&mut query, 6..11, 2..8, [1.0, 1.0, 1.0]);
        paint(&mut query, 6..11, 20..26, [0.1, 0.2, 0.05]);
        let view = SearchView {
            query,
            empty,
            empty_depth: vec![2.0; w * h],
            seen: None,
            light: None,
        };
        let found = ResidualDetector::default().detect(&view);
        assert_eq!(found.len(), 1, "{found:?}");
        assert!(
            found[0]
                .pixels
                .iter()
                .all(|p| (20..26).contains(&(p % w as u32)))
        );
    }
}

//! `neuroom bench locate --photos N`: locate from photos instead of panoramas. Each test panorama of a
//! room is cut into `N` level photos at evenly spaced headings (exact intrinsics and poses, the same
//! room and lights), and each photo is located on its own and scored against the objects it shows;
//! with `--merge`, each panorama's photos are also merged as views of one arrangement and scored
//! against all its objects.

use std::f64::consts::TAU;
use std::path::Path;
use std::time::Instant;

use glam::DMat3;
use neuroom_core::camera::Pinhole;
use neuroom_core::formats::{ArrangedObject, Arrangement, read_mask, read_rgb};
use neuroom_core::pose::Pose;
use neuroom_locate::merge::merge_views;
use neuroom_locate::objects::Found;
use neuroom_locate::sphere_image::{photo_from_panorama, photo_sees};
use neuroom_panorama::sphere::direction;
use serde::{Deserialize, Serialize};

use crate::locate::{
    LocateConfig, LocateContext, LocateMean, Located, PanoramaScore, QueryImage, locate_image,
    mean_scores, test_panoramas,
};
use crate::score::{ShapeSymmetries, score_in_room};

/// How photos are cut from each test panorama.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PhotoCut {
    /// Photos per panorama, at headings `(k + ½) · 360° / n` from the panorama's centre column.
    pub per_panorama: usize,
    /// Horizontal field of view (degrees).
    pub horizontal_fov_deg: f64,
    /// Photo size (pixels).
    pub width: u32,
    /// Photo height (pixels).
    pub height: u32,
    /// An object counts as shown when at least this fraction of it (of its panorama pixels, weighted
    /// by solid angle) lies in the photo; objects shown less are neither asked for nor held against
    /// the result.
    pub shown_fraction: f64,
    /// Also merge each panorama's photos as views of one arrangement and score them against all its
    /// objects.
    pub merge: bool,
}

impl Default for PhotoCut {
    fn default() -> Self {
        Self {
            per_panorama: 4,
            horizontal_fov_deg: 90.0,
            width: 320,
            height: 240,
            shown_fraction: 0.5,
            merge: false,
        }
    }
}

impl PhotoCut {
    /// The photos' intrinsics: square pixels, principal point at the centre.
    pub fn camera(&self) -> Pinhole {
        let f = 0.5 * self.width as f64 / (0.5 * self.horizontal_fov_deg.to_radians()).tan();
        Pinhole::new(
            self.width,
            self.height,
            f,
            f,
            0.5 * self.width as f64,
            0.5 * self.height as f64,
        )
    }

    /// Heading of photo `k` (radians).
    fn heading(&self, k: usize) -> f64 {
        (k as f64 + 0.5) * TAU / self.per_panorama.max(1) as f64
    }
}

/// What [`bench_locate_photos`] measured.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhotoBench {
    /// One score per photo, and their mean.
    pub photos: (Vec<PanoramaScore>, LocateMean),
    /// With [`PhotoCut::merge`]: one score per panorama of its photos merged, and their mean.
    pub merged: Option<(Vec<PanoramaScore>, LocateMean)>,
}

/// Locates photos cut from every test panorama of `room` ([`PhotoCut`]) and scores each: its camera
/// (as a panorama frame, against the panorama's turned by the photo's heading) and the objects it
/// shows; with [`PhotoCut::merge`], also each panorama's photos merged as views of one arrangement.
/// `each` sees every score as it is measured.
pub fn bench_locate_photos(
    room: &Path,
    models: &Path,
    config: &LocateConfig,
    cut: &PhotoCut,
    each: &mut dyn FnMut(&PanoramaScore),
) -> anyhow::Result<PhotoBench> {
    let ctx = LocateContext::load(room, models, config)?;
    let symmetries = ShapeSymmetries::of_room(&ctx.room)?;
    let camera = cut.camera();
    let mut scores = Vec::new();
    let mut merged = Vec::new();
    for (png, truth) in test_panoramas(room)? {
        let panorama = read_rgb(&png)?.image;
        let mask_path = png.with_extension("mask.png");
        let mask = read_mask(&mask_path)?;
        anyhow::ensure!(
            (mask.width, mask.height) == (panorama.width, panorama.height),
            "{}: not the size of its panorama",
            mask_path.display()
        );
        let stem = png
            .file_stem()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut views: Vec<PanoramaScore> = Vec::new();
        for k in 0..cut.per_panorama {
            let heading = cut.heading(k);
            let name = format!("{stem}@{:.0}deg", heading.to_degrees());
            let start = Instant::now();
            let query = QueryImage::Photo {
                rgb: photo_from_panorama(&panorama, &camera, heading),
                camera,
            };
            let (found, located, _) = locate_image(&ctx, &query, &name, config, &mut |_| {})?;
            let seconds = start.elapsed().as_secs_f64();
            let shown = shown_fractions(&mask.data, mask.width as usize, &camera, heading);
            let (truth_shown, found_shown) = shown_only(&truth, &found, &shown, cut.shown_fraction);
            let true_camera = Pose::new(
                truth.camera_to_world.rotation * DMat3::from_rotation_z(heading),
                truth.camera_to_world.translation,
            );
            let at = located.camera.pose();
            let score = PanoramaScore {
                panorama: name,
                camera_position_error_cm: 100.0 * at.translation.distance(true_camera.translation),
                camera_rotation_error_deg: neuroom_core::metrics::rotation_error_deg(
                    true_camera.rotation,
                    at.rotation,
                ),
                objects: score_in_room(&ctx.room, &symmetries, &truth_shown, &found_shown),
                initial: None,
                seconds,
                objective: None,
                camera_objective: None,
                located,
            };
            each(&score);
            views.push(score);
        }
        if cut.merge {
            let score = merged_score(&ctx, &symmetries, &truth, &stem, &views, config);
            each(&score);
            merged.push(score);
        }
        scores.extend(views);
    }
    Ok(PhotoBench {
        photos: {
            let mean = mean_scores(&scores);
            (scores, mean)
        },
        merged: cut.merge.then(|| {
            let mean = mean_scores(&merged);
            (merged, mean)
        }),
    })
}

/// The photos of one panorama (`views`, scored) merged as views of one arrangement and scored against
/// all of `truth`; the camera is the first photo's, the seconds are the photos' sum.
fn merged_score(
    ctx: &LocateContext,
    symmetries: &ShapeSymmetries,
    truth: &Arrangement,
    stem: &str,
    views: &[PanoramaScore],
    config: &LocateConfig,
) -> PanoramaScore {
    let found: Vec<Vec<Found>> = views.iter().map(|v| v.located.found.clone()).collect();
    let merged = merge_views(&found, &ctx.objects, &config.search);
    let mut arrangement = truth.clone();
    arrangement.objects = merged
        .iter()
        .map(|f| ArrangedObject {
            id: f.id,
            name: String::new(),
            object_to_world: f.pose(),
            extra: Default::default(),
        })
        .collect();
    let first = &views[0];
    PanoramaScore {
        panorama: format!("{stem}@merged"),
        objects: score_in_room(&ctx.room, symmetries, truth, &arrangement),
        seconds: views.iter().map(|v| v.seconds).sum(),
        located: Located {
            detections: views.iter().map(|v| v.located.detections).sum(),
            found: merged,
            ..first.located.clone()
        },
        ..first.clone()
    }
}

/// Per object id (in increasing order), the fraction of its panorama pixels (weighted by solid angle) that the photo turned
/// by `heading` shows.
fn shown_fractions(mask: &[u16], width: usize, camera: &Pinhole, heading: f64) -> Vec<(u16, f64)> {
    let height = mask.len() / width;
    let mut sums: Vec<(u16, f64, f64)> = Vec::new();
    for (i, &id) in mask.iter().enumerate().filter(|(_, id)| **id != 0) {
        let d = direction(
            (i % width) as f64 + 0.5,
            (i / width) as f64 + 0.5,
            width,
            height,
        );
        let weight = (1.0 - d.z * d.z).sqrt();
        let slot = match sums.iter().position(|s| s.0 == id) {
            Some(slot) => slot,
            None => {
                sums.push((id, 0.0, 0.0));
                sums.len() - 1
            }
        };
        sums[slot].1 += weight;
        if photo_sees(camera, heading, d) {
            sums[slot].2 += weight;
        }
    }
    sums.sort_by_key(|s| s.0);
    sums.into_iter()
        .map(|(id, total, inside)| (id, inside / total.max(1e-12)))
        .collect()
}

/// The truth restricted to the objects the photo shows (at least `least` of them), and the found
/// arrangement without the objects it shows only in part (they are neither asked for nor wrong).
fn shown_only(
    truth: &Arrangement,
    found: &Arrangement,
    shown: &[(u16, f64)],
    least: f64,
) -> (Arrangement, Arrangement) {
    let fraction = |id: u16| shown.iter().find(|s| s.0 == id).map_or(0.0, |s| s.1);
    let mut truth = truth.clone();
    truth.objects.retain(|o| fraction(o.id) >= least);
    let mut found = found.clone();
    found
        .objects
        .retain(|o| fraction(o.id) >= least || fraction(o.id) == 0.0);
    (truth, found)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn objects_are_shown_by_the_photos_that_face_them() {
        let cut = PhotoCut::default();
        let camera = cut.camera();
        // Two objects in a 64 × 32 panorama: one at the centre column (+x), one behind (−x).
        let (w, h) = (64usize, 32usize);
        let mut mask = vec![0u16; w * h];
        for v in 14..18 {
            for u in 30..34 {
                mask[v * w + u] = 1;
            }
            for u in [0, 1, 62, 63] {
                mask[v * w + u] = 2;
            }
        }
        let facing = shown_fractions(&mask, w, &camera, 0.0);
        assert_eq!(facing, vec![(1, 1.0), (2, 0.0)]);
        let behind = shown_fractions(&mask, w, &camera, std::f64::consts::PI);
        assert_eq!(behind, vec![(1, 0.0), (2, 1.0)]);
        assert!((camera.fx - 160.0).abs() < 1e-9);
    }
}

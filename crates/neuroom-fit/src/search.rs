//! Render-and-compare search before the gradient stage: the photometric gradient of a posed field only
//! reaches pixels the object already covers, so an object whose initial pose misses its own image by more
//! than about its size never finds it. For each object in turn, a grid of horizontal offsets and then a
//! fan of yaws around its current pose are rendered through the whole scene on a fixed set of pixels
//! around the object, and the hypothesis whose render best explains them is kept. Two rounds, the second
//! at half the spacing, make a coarse-to-fine coordinate descent.
//!
//! Hypotheses that push an object's surface through a wall are not considered: where the object's
//! colours match the panorama poorly, hiding it behind a wall would otherwise look best.
//!
//! The comparison is invariant to a per-channel affine change of colour (the residual after the best
//! positive scale and shift per channel), so a change of lighting does not favour one hypothesis.

use crate::codes::FitField;
use crate::relations::RoomBox;
use crate::sampling::{PixelSampler, object_mask};
use crate::surface::SurfacePoints;
use glam::{Mat3, Vec3};
use neuroom_core::camera::{CameraModel, Equirect};
use neuroom_core::image::RgbImage;
use neuroom_core::rotation6d::{rotation_from_6d_f32, rotation_to_6d_f32};
use neuroom_core::{Pose, Ray};
use neuroom_render::{Renderer, Scene};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// The grid of the search.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseSearchConfig {
    /// Spacing of the horizontal offsets in the first round (metres).
    pub step_m: f32,
    /// Offsets per side along each horizontal axis (2: a 5 × 5 grid).
    pub steps: usize,
    /// Spacing of the yaws in the first round (degrees).
    pub yaw_step_deg: f32,
    /// Yaws per side (2: five yaws).
    pub yaw_steps: usize,
    /// Pixels rendered per hypothesis.
    pub rays: usize,
    /// Rounds over all objects; each halves the spacings.
    pub rounds: usize,
}

impl Default for PoseSearchConfig {
    fn default() -> Self {
        Self {
            step_m: 0.1,
            steps: 2,
            yaw_step_deg: 10.0,
            yaw_steps: 2,
            rays: 256,
            rounds: 2,
        }
    }
}

/// Residual of `rendered` against `target` after the best per-channel `a · r + b` with `a ≥ 0`.
pub fn affine_residual(rendered: &[[f32; 3]], target: &[[f32; 3]]) -> f32 {
    let n = rendered.len().max(1) as f32;
    (0..3)
        .map(|c| {
            let mr = rendered.iter().map(|p| p[c]).sum::<f32>() / n;
            let mt = target.iter().map(|p| p[c]).sum::<f32>() / n;
            let (mut srr, mut stt, mut srt) = (0.0f32, 0.0f32, 0.0f32);
            for (r, t) in rendered.iter().zip(target) {
                let (dr, dt) = (r[c] - mr, t[c] - mt);
                srr += dr * dr;
                stt += dt * dt;
                srt += dr * dt;
            }
            if srt > 0.0 && srr > 0.0 {
                (stt - srt * srt / srr).max(0.0)
            } else {
                stt
            }
        })
        .sum::<f32>()
        / n
}

/// Pixels around object `k` (its box widened by the search radius), with their rays and targets.
struct Probe {
    rays: Vec<Ray>,
    targets: Vec<[f32; 3]>,
}

#[allow(clippy::too_many_arguments)]
fn probe_pixels<F>(
    scene: &Scene<F>,
    k: usize,
    radius: f32,
    camera: &Equirect,
    camera_to_world: &Pose,
    panorama: &RgbImage,
    rays: usize,
    rng: &mut impl Rng,
) -> Probe {
    let mut widened = scene.objects[k].clone();
    widened.half_extents += Vec3::new(radius, radius, 0.0);
    let mask = object_mask(camera, camera_to_world, &[widened], 0.0);
    let mut pixels = Vec::new();
    PixelSampler::new(camera, &mask).draw(rays, 0, rng, &mut pixels);
    let w = camera.width();
    Probe {
        rays: pixels
            .iter()
            .map(|&p| camera.pixel_ray(camera_to_world, p % w, p / w))
            .collect(),
        targets: pixels.iter().map(|&p| panorama.data[p as usize]).collect(),
    }
}

/// The hypotheses of one round around `(t, r)`: offsets on the grid, then yaws (applied after the best
/// offset is known, see [`search_poses`]).
fn offsets(step: f32, steps: usize) -> Vec<Vec3> {
    let s = steps as i32;
    (-s..=s)
        .flat_map(|i| (-s..=s).map(move |j| Vec3::new(i as f32 * step, j as f32 * step, 0.0)))
        .collect()
}

/// How far (metres) surface points may reach through the room's walls in a hypothesis (or as far as
/// they do at the current pose, if further).
const WALL_TOLERANCE: f32 = 0.02;

/// How far (metres) the surface points, placed at `(t, r)`, reach through the walls of `room` at most.
fn wall_depth(surface: &SurfacePoints, t: Vec3, r: Mat3, room: &RoomBox) -> f32 {
    surface.points.iter().fold(0.0f32, |depth, p| {
        let x = r * *p + t;
        (0..2).fold(depth, |d, a| {
            d.max(room.min[a] - x[a]).max(x[a] - room.max[a])
        })
    })
}

/// Scores the scene with object `k` at each candidate `(translation, rotation)`; keeps the best (the
/// current pose, first, wins ties) and returns its residual.
fn keep_best<F: FitField>(
    scene: &mut Scene<F>,
    renderer: &mut Renderer<F>,
    k: usize,
    probe: &Probe,
    candidates: &[(Vec3, Mat3)],
) -> f32 {
    let mut best = (f32::INFINITY, 0);
    let mut colours = Vec::with_capacity(probe.rays.len());
    for (h, &(t, r)) in candidates.iter().enumerate() {
        scene.objects[k].translation = t;
        scene.objects[k].rotation6d = rotation_to_6d_f32(r);
        colours.clear();
        colours.extend(renderer.render(scene, &probe.rays).iter().map(|o| o.rgb));
        let loss = affine_residual(&colours, &probe.targets);
        if loss < best.0 {
            best = (loss, h);
        }
    }
    let (t, r) = candidates[best.1];
    scene.objects[k].translation = t;
    scene.objects[k].rotation6d = rotation_to_6d_f32(r);
    best.0
}

/// Runs the search on every object of `scene` in place (see the module doc).
#[allow(clippy::too_many_arguments)]
pub fn search_poses<F: FitField>(
    scene: &mut Scene<F>,
    renderer: &mut Renderer<F>,
    surfaces: &[SurfacePoints],
    room: &RoomBox,
    camera: &Equirect,
    camera_to_world: &Pose,
    panorama: &RgbImage,
    config: &PoseSearchConfig,
    rng: &mut impl Rng,
) {
    for round in 0..config.rounds {
        let scale = 0.5f32.powi(round as i32);
        let (step, yaw_step) = (config.step_m * scale, config.yaw_step_deg * scale);
        for (k, surface) in surfaces.iter().enumerate().take(scene.objects.len()) {
            let radius = step * config.steps as f32;
            let probe = probe_pixels(
                scene,
                k,
                radius,
                camera,
                camera_to_world,
                panorama,
                config.rays,
                rng,
            );
            if probe.rays.is_empty() {
                continue;
            }
            let (t0, r0) = (
                scene.objects[k].translation,
                rotation_from_6d_f32(scene.objects[k].rotation6d),
            );
            let mut shifted: Vec<(Vec3, Mat3)> = offsets(step, config.steps)
                .iter()
                .map(|d| (t0 + *d, r0))
                .collect();
            let limit = wall_depth(surface, t0, r0, room).max(WALL_TOLERANCE);
            let allowed = |&(t, r): &(Vec3, Mat3)| wall_depth(surface, t, r, room) <= limit;
            shifted.retain(|c| c.0 == t0 || allowed(c));
            shifted.sort_by_key(|(t, _)| t.distance(t0) > 0.0);
            keep_best(scene, renderer, k, &probe, &shifted);
            let t1 = scene.objects[k].translation;
            let y = config.yaw_steps as i32;
            let mut turned: Vec<(Vec3, Mat3)> = (-y..=y)
                .map(|i| {
                    let yaw = (i as f32 * yaw_step).to_radians();
                    (t1, Mat3::from_rotation_z(yaw) * r0)
                })
                .collect();
            turned.retain(|c| c.1 == r0 || allowed(c));
            turned.sort_by_key(|(_, r)| *r != r0);
            keep_best(scene, renderer, k, &probe, &turned);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_affine_residual_ignores_a_change_of_exposure_but_not_of_pattern() {
        let target: Vec<[f32; 3]> = (0..16)
            .map(|i| [i as f32 / 16.0, 0.5, (i % 4) as f32 / 4.0])
            .collect();
        let brighter: Vec<[f32; 3]> = target
            .iter()
            .map(|p| [0.5 * p[0] + 0.2, p[1], 0.8 * p[2] + 0.1])
            .collect();
        assert!(affine_residual(&brighter, &target) < 1e-6);
        let shuffled: Vec<[f32; 3]> = target.iter().rev().copied().collect();
        assert!(affine_residual(&shuffled, &target) > 0.05);
    }

    #[test]
    fn the_grid_is_centred_and_square() {
        let g = offsets(0.1, 2);
        assert_eq!(g.len(), 25);
        assert!(g.contains(&Vec3::ZERO));
        assert!(
            g.iter()
                .all(|d| d.x.abs() <= 0.2 + 1e-6 && d.y.abs() <= 0.2 + 1e-6)
        );
    }
}

//! Object finding and initial poses by render-and-compare of pose hypotheses against the detections.
//!
//! Hypotheses per model follow where the model may stand: on the floor (a grid of positions whose box
//! centre projects into a detection × a ring of headings), against a wall (the empty room's surface
//! behind a detected pixel, facing along its normal), or on top of an object already placed. Each is
//! projected ([`crate::cloud::splat`]) and scored, pixel by pixel, by how much better its colours (after
//! a per-channel gain: the light changed) explain the panorama than the empty room's colours do. The best hypothesis over all models is taken, refined
//! by coordinate descent, its pixels marked explained, and the search goes on until no hypothesis
//! explains enough: objects absent from the panorama are not invented. Identical instances (one model,
//! several ids) are placed one after another at distinct poses.

use glam::{DVec3, Vec3};
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use neuroom_render::Scene;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::cloud::{Cloud, Silhouette, ZBuffer, splat};
use crate::evidence::{Detection, View, dilate, residual};
use crate::sphere::direction;

/// Where a model may stand.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Placement {
    /// Upright on the floor.
    Floor,
    /// Upright with its back (−x face) against a wall.
    Wall,
    /// Upright on top of an instance of another model (index into the model list).
    On(usize),
}

/// One searchable model.
#[derive(Clone, Debug)]
pub struct ObjectModel {
    /// Instance ids (several for identical objects).
    pub ids: Vec<u16>,
    /// Half extents of its box (metres).
    pub half: Vec3,
    /// Coarse surface cloud, for the search.
    pub coarse: Cloud,
    /// Finer surface cloud, for refinement.
    pub fine: Cloud,
    /// Where it may stand.
    pub placement: Placement,
    /// Whether its back (−x face) stands against a wall: hypotheses are discounted by the back's
    /// distance from the room's surface.
    pub against_wall: bool,
}

/// Search settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SearchConfig {
    /// Floor grid spacing (metres).
    pub grid: f32,
    /// Headings tried per position.
    pub headings: usize,
    /// Hypotheses kept per model after non-maximum suppression.
    pub keep: usize,
    /// Least distance between kept hypotheses of one model (metres).
    pub suppression: f32,
    /// Largest per-channel gain between an object's learnt colours and the panorama (and its inverse).
    pub max_gain: f64,
    /// Colour error assumed for the empty room where it has no surface (mean absolute sRGB).
    pub unknown_error: f32,
    /// Detections are grown by this many pixels before box centres are tested against them.
    pub allowed_margin: usize,
    /// Room misfit (metres, see `room_misfit`) at which a hypothesis's score is divided by e.
    pub wall_distance: f32,
    /// Least score of a placed object (sum of colour-error gains, sRGB units × pixels).
    pub min_score: f64,
    /// Least pixels a placed object must explain better than the empty room.
    pub min_pixels: usize,
    /// Least fraction of its visible pixels it must explain better than the empty room.
    pub min_precision: f64,
    /// Depth tolerance of the empty room's occlusion (metres).
    pub occlusion_tolerance: f32,
}

impl Default for SearchConfig {
    fn default() -> Self {
        Self {
            grid: 0.15,
            headings: 12,
            keep: 12,
            suppression: 0.3,
            max_gain: 2.5,
            unknown_error: 0.05,
            allowed_margin: 2,
            wall_distance: 0.15,
            min_score: 1.0,
            min_pixels: 25,
            min_precision: 0.5,
            occlusion_tolerance: 0.1,
        }
    }
}

/// A placed object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Found {
    /// Index into the model list.
    pub model: usize,
    /// The instance id given to it.
    pub id: u16,
    /// Initial `object_to_world`.
    pub object_to_world: [[f64; 4]; 4],
    /// Its score (see [`SearchConfig::min_score`]).
    pub score: f64,
    /// Pixels it explains better than the empty room.
    pub explained: usize,
}

#[derive(Clone, Debug)]
struct Hypothesis {
    model: usize,
    pose: Pose,
}

/// What the search compares against.
struct Target<'a, F> {
    view: &'a View,
    /// The empty room's field (wall distances).
    room: &'a F,
    camera: Pose,
    allowed: Vec<Vec<bool>>,
    tolerance: f32,
    /// Colour error of the empty room per pixel ([`crate::evidence::residual`]; a constant where it
    /// has no surface).
    room_error: Vec<f32>,
}

impl<'a, F: Field> Target<'a, F> {
    fn new(input: &SearchInput<'a, F>, config: &SearchConfig) -> Self {
        let SearchInput {
            empty,
            view,
            camera_to_world,
            detections,
            models,
        } = *input;
        let models = models.len();
        let n = view.width() * view.height();
        let mut allowed = vec![vec![false; n]; models];
        for d in detections {
            for &p in &d.pixels {
                for (m, a) in allowed.iter_mut().enumerate() {
                    if d.model.is_none_or(|k| k == m) {
                        a[p as usize] = true;
                    }
                }
            }
        }
        Self {
            view,
            room: &empty.models[empty.background.model].field,
            camera: camera_to_world,
            allowed: allowed
                .iter()
                .map(|a| dilate_n(a, view.width(), view.height(), config.allowed_margin))
                .collect(),
            tolerance: config.occlusion_tolerance,
            room_error: residual(view)
                .iter()
                .zip(&view.empty_depth)
                .map(|(r, d)| if *d > 0.0 { *r } else { config.unknown_error })
                .collect(),
        }
    }
}

/// What the object search looks at: the panorama at the found camera, the empty room, the detections and
/// the models to find.
pub struct SearchInput<'a, F> {
    /// The room without objects (a scene of the background alone, for floor heights and wall normals).
    pub empty: &'a Scene<F>,
    /// The panorama and the empty room at the working resolution.
    pub view: &'a View,
    /// The found camera.
    pub camera_to_world: Pose,
    /// Where objects are seen.
    pub detections: &'a [Detection],
    /// The models searched.
    pub models: &'a [ObjectModel],
}

impl<F> Clone for SearchInput<'_, F> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<F> Copy for SearchInput<'_, F> {}

/// The score of model `m` at `pose` with nothing explained yet: (score, pixels it explains better than
/// the empty room, their fraction of its visible pixels), as the search ranks hypotheses.
pub fn pose_score<F: Field>(
    input: &SearchInput<F>,
    m: usize,
    pose: &Pose,
    config: &SearchConfig,
) -> (f64, usize, f64) {
    let target = Target::new(input, config);
    let explained = vec![false; target.room_error.len()];
    let mut buf = ZBuffer::default();
    let model = &input.models[m];
    hypothesis_score(&target, &explained, model, false, pose, &mut buf, config)
}

/// Finds the objects of `input` and their initial poses.
pub fn find_objects<F: Field>(input: &SearchInput<F>, config: &SearchConfig) -> Vec<Found> {
    let target = Target::new(input, config);
    let (empty, models) = (input.empty, input.models);
    let floor = floor_height(empty, &input.camera_to_world);
    let mut pool: Vec<Hypothesis> = Vec::new();
    for (m, model) in models.iter().enumerate() {
        let hyps = match model.placement {
            Placement::Floor => floor_hypotheses(&target, m, model, floor, config),
            Placement::Wall => wall_hypotheses(&target, m, model),
            Placement::On(_) => Vec::new(),
        };
        pool.extend(prune(&target, models, hyps, config));
    }
    greedy(&target, models, pool, config)
}

/// Height of the floor under the camera.
fn floor_height<F: Field>(empty: &Scene<F>, camera: &Pose) -> f32 {
    let field = &empty.models[empty.background.model].field;
    let start = camera.translation.as_vec3();
    crate::database::floor_below(field, start, empty.background.bounds_min.z)
        .unwrap_or(empty.background.bounds_min.z)
}

fn world_point<F>(target: &Target<F>, pixel: usize) -> Option<DVec3> {
    let (w, h) = (target.view.width(), target.view.height());
    let depth = target.view.empty_depth[pixel];
    (depth > 0.0).then(|| {
        let d = direction((pixel % w) as f64 + 0.5, (pixel / w) as f64 + 0.5, w, h);
        target.camera.transform_point(d * depth as f64)
    })
}

/// Whether the box centre of `pose` projects into a pixel where model `m` may be.
fn centre_allowed<F>(target: &Target<F>, m: usize, pose: &Pose) -> bool {
    let (w, h) = (target.view.width(), target.view.height());
    let p = target.camera.inverse().transform_point(pose.translation);
    crate::sphere::project(p, w, h).is_some_and(|pix| {
        let (u, v) = (pix.x as usize % w, (pix.y as usize).min(h - 1));
        target.allowed[m][v * w + u]
    })
}

fn floor_hypotheses<F>(
    target: &Target<F>,
    m: usize,
    model: &ObjectModel,
    floor: f32,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    let (lo, hi) = floor_extent(target);
    let z = floor + model.half.z;
    let nx = ((hi.x - lo.x) / config.grid).ceil() as usize + 1;
    let ny = ((hi.y - lo.y) / config.grid).ceil() as usize + 1;
    let mut out = Vec::new();
    for i in 0..nx {
        for j in 0..ny {
            let t = DVec3::new(
                (lo.x + i as f32 * config.grid) as f64,
                (lo.y + j as f32 * config.grid) as f64,
                z as f64,
            );
            let probe = Pose::new(glam::DMat3::IDENTITY, t);
            if !centre_allowed(target, m, &probe) {
                continue;
            }
            for k in 0..config.headings {
                let yaw = std::f64::consts::TAU * k as f64 / config.headings as f64;
                out.push(Hypothesis {
                    model: m,
                    pose: Pose::from_yaw_translation(yaw, t),
                });
            }
        }
    }
    out
}

/// The horizontal extent of the empty room seen in the view.
fn floor_extent<F>(target: &Target<F>) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for i in 0..target.view.empty_depth.len() {
        if let Some(p) = world_point(target, i) {
            lo = lo.min(p.as_vec3());
            hi = hi.max(p.as_vec3());
        }
    }
    (lo, hi)
}

fn wall_hypotheses<F: Field>(target: &Target<F>, m: usize, model: &ObjectModel) -> Vec<Hypothesis> {
    let field = target.room;
    let w = target.view.width();
    let mut out = Vec::new();
    for (i, _) in target.allowed[m]
        .iter()
        .enumerate()
        .filter(|(i, a)| **a && (i % w).is_multiple_of(2) && (i / w).is_multiple_of(2))
    {
        let Some(p) = world_point(target, i) else {
            continue;
        };
        let mut sdf = [0.0];
        let mut grad = [Vec3::ZERO];
        field.sdf_gradient(&[p.as_vec3()], &mut sdf, &mut grad);
        let n = grad[0].normalize_or_zero();
        if n.z.abs() > 0.3 || n == Vec3::ZERO {
            continue;
        }
        let n = Vec3::new(n.x, n.y, 0.0).normalize();
        let centre = p + (n * model.half.x).as_dvec3();
        out.push(Hypothesis {
            model: m,
            pose: Pose::from_yaw_translation(n.y.atan2(n.x) as f64, centre),
        });
    }
    out
}

/// Scores hypotheses against the whole detection (nothing explained yet) and keeps the best few of each
/// model at distinct positions.
fn prune<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    hyps: Vec<Hypothesis>,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    let explained = vec![false; target.room_error.len()];
    let mut scored: Vec<(f64, Hypothesis)> = hyps
        .into_par_iter()
        .map_init(ZBuffer::default, |buf, h| {
            let s = hypothesis_score(
                target,
                &explained,
                &models[h.model],
                true,
                &h.pose,
                buf,
                config,
            );
            (s.0, h)
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut kept: Vec<Hypothesis> = Vec::new();
    for (s, h) in scored {
        if kept.len() >= config.keep || s <= 0.0 {
            break;
        }
        let far = kept
            .iter()
            .all(|k| k.pose.translation.distance(h.pose.translation) > config.suppression as f64);
        if far {
            kept.push(h);
        }
    }
    kept
}

fn silhouette<F>(target: &Target<F>, cloud: &Cloud, pose: &Pose, buf: &mut ZBuffer) -> Silhouette {
    splat(
        cloud,
        pose,
        &target.camera,
        target.view.width(),
        target.view.height(),
        &target.view.empty_depth,
        target.tolerance,
        buf,
    )
}

/// (score, pixels it explains better than the empty room, fraction of its visible pixels that it
/// explains better) of a silhouette, given the pixels already explained. The score is the sum over its
/// visible unexplained pixels of the empty room's colour error minus the object's (its colours scaled by
/// a per-channel gain fitted to those pixels: the light changed).
fn score<F>(
    target: &Target<F>,
    explained: &[bool],
    sil: &Silhouette,
    config: &SearchConfig,
) -> (f64, usize, f64) {
    let (mut qc, mut cc) = ([0.0f64; 3], [0.0f64; 3]);
    let mut visible = 0usize;
    for (&p, c) in sil.pixels.iter().zip(&sil.colors) {
        if explained[p as usize] {
            continue;
        }
        visible += 1;
        let q = target.view.query.data[p as usize];
        for k in 0..3 {
            qc[k] += (q[k] * c[k]) as f64;
            cc[k] += (c[k] * c[k]) as f64;
        }
    }
    if visible == 0 {
        return (0.0, 0, 0.0);
    }
    let gain: [f64; 3] = std::array::from_fn(|k| {
        (qc[k] / cc[k].max(1e-9)).clamp(1.0 / config.max_gain, config.max_gain)
    });
    let (mut total, mut wins) = (0.0f64, 0usize);
    for (&p, c) in sil.pixels.iter().zip(&sil.colors) {
        let p = p as usize;
        if explained[p] {
            continue;
        }
        let q = target.view.query.data[p];
        let e_obj = (0..3)
            .map(|k| (q[k] as f64 - gain[k] * c[k] as f64).abs())
            .sum::<f64>()
            / 3.0;
        let d = target.room_error[p] as f64 - e_obj;
        total += d;
        if d > 0.0 {
            wins += 1;
        }
    }
    (total, wins, wins as f64 / visible as f64)
}

/// Takes the best hypothesis over all models while one explains enough, refining and committing each.
fn greedy<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    mut pool: Vec<Hypothesis>,
    config: &SearchConfig,
) -> Vec<Found> {
    let mut explained = vec![false; target.room_error.len()];
    let mut used = vec![0usize; models.len()];
    let mut found: Vec<Found> = Vec::new();
    loop {
        pool.retain(|h| used[h.model] < models[h.model].ids.len());
        let best = pool
            .par_iter()
            .enumerate()
            .map_init(ZBuffer::default, |buf, (k, h)| {
                let model = &models[h.model];
                (
                    k,
                    hypothesis_score(target, &explained, model, true, &h.pose, buf, config),
                )
            })
            .filter(|(_, s)| accepted(s, config))
            .max_by(|a, b| a.1.0.total_cmp(&b.1.0));
        let Some((k, _)) = best else { break };
        let h = pool.swap_remove(k);
        let model = &models[h.model];
        let (pose, (s, tp, precision)) = refine(target, &explained, model, &h.pose, config);
        if !accepted(&(s, tp, precision), config) {
            continue;
        }
        let mut buf = ZBuffer::default();
        for p in silhouette(target, &model.fine, &pose, &mut buf).pixels {
            explained[p as usize] = true;
        }
        let id = model.ids[used[h.model]];
        used[h.model] += 1;
        found.push(Found {
            model: h.model,
            id,
            object_to_world: pose.to_rows(),
            score: s,
            explained: tp,
        });
        pool.retain(|o| {
            o.model != h.model
                || o.pose.translation.distance(pose.translation) > config.suppression as f64
        });
        pool.extend(support_hypotheses(target, models, h.model, &pose, config));
    }
    found
}

/// [`score`] of `model` at `pose` (coarse or fine cloud), discounted by its [`room_misfit`].
#[allow(clippy::too_many_arguments)]
fn hypothesis_score<F: Field>(
    target: &Target<F>,
    explained: &[bool],
    model: &ObjectModel,
    coarse: bool,
    pose: &Pose,
    buf: &mut ZBuffer,
    config: &SearchConfig,
) -> (f64, usize, f64) {
    let cloud = if coarse { &model.coarse } else { &model.fine };
    let sil = silhouette(target, cloud, pose, buf);
    let mut s = score(target, explained, &sil, config);
    if s.0 > 0.0 {
        s.0 *= (-(room_misfit(target.room, model, pose) / config.wall_distance) as f64).exp();
    }
    s
}

/// How far `model` at `pose` is from standing as the room allows (metres): the depth by which its box
/// corners enter the room's surfaces (beyond a small tolerance), plus, when it stands against a wall, the
/// distance of its back from the wall.
fn room_misfit<F: Field>(room: &F, model: &ObjectModel, pose: &Pose) -> f32 {
    let h = model.half.as_dvec3();
    let mut points: Vec<Vec3> = (0..8)
        .map(|k| {
            let sign = |b: usize| if k & b != 0 { 1.0 } else { -1.0 };
            let local = DVec3::new(sign(1) * h.x, sign(2) * h.y, sign(4) * h.z * 0.8);
            pose.transform_point(local).as_vec3()
        })
        .collect();
    if model.against_wall {
        points.push(
            pose.transform_point(DVec3::new(-h.x - 0.02, 0.0, 0.0))
                .as_vec3(),
        );
    }
    let mut sdf = vec![0.0f32; points.len()];
    room.sdf(&points, &mut sdf);
    let inside: f32 = sdf[..8].iter().map(|d| (-d - 0.03).max(0.0)).sum();
    let back = if model.against_wall {
        sdf[8].abs()
    } else {
        0.0
    };
    inside + back
}

fn accepted(s: &(f64, usize, f64), config: &SearchConfig) -> bool {
    s.0 >= config.min_score && s.1 >= config.min_pixels && s.2 >= config.min_precision
}

/// `mask` grown by `n` pixels.
fn dilate_n(mask: &[bool], w: usize, h: usize, n: usize) -> Vec<bool> {
    (0..n).fold(mask.to_vec(), |m, _| dilate(&m, w, h))
}

/// Hypotheses of the models that stand on `supporter`, on its top face.
fn support_hypotheses<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    supporter: usize,
    pose: &Pose,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    let base = &models[supporter];
    let mut out = Vec::new();
    for (m, model) in models.iter().enumerate() {
        if model.placement != Placement::On(supporter) {
            continue;
        }
        let step = 0.03f32;
        let (nx, ny) = (
            (2.0 * base.half.x / step) as i32,
            (2.0 * base.half.y / step) as i32,
        );
        let mut hyps = Vec::new();
        for i in 0..=nx {
            for j in 0..=ny {
                let local = Vec3::new(
                    -base.half.x + i as f32 * step,
                    -base.half.y + j as f32 * step,
                    base.half.z + model.half.z,
                );
                let t = pose.transform_point(local.as_dvec3());
                for k in 0..config.headings {
                    let yaw = std::f64::consts::TAU * k as f64 / config.headings as f64;
                    hyps.push(Hypothesis {
                        model: m,
                        pose: Pose::from_yaw_translation(yaw, t),
                    });
                }
            }
        }
        out.extend(prune(target, models, hyps, config));
    }
    out
}

/// Coordinate descent on (x, y, z, yaw) with shrinking steps, scored with the fine cloud.
fn refine<F: Field>(
    target: &Target<F>,
    explained: &[bool],
    model: &ObjectModel,
    start: &Pose,
    config: &SearchConfig,
) -> (Pose, (f64, usize, f64)) {
    let mut buf = ZBuffer::default();
    let mut eval =
        |pose: &Pose| hypothesis_score(target, explained, model, false, pose, &mut buf, config);
    let mut pose = *start;
    let mut best = eval(&pose);
    let vertical = model.placement == Placement::Wall;
    for (step, turn) in [
        (0.05, 10f64.to_radians()),
        (0.02, 4f64.to_radians()),
        (0.01, 1.5f64.to_radians()),
    ] {
        loop {
            let mut improved = false;
            let mut moves: Vec<Pose> = Vec::new();
            for d in [-step, step] {
                moves.push(shifted(&pose, DVec3::new(d, 0.0, 0.0)));
                moves.push(shifted(&pose, DVec3::new(0.0, d, 0.0)));
                if vertical {
                    moves.push(shifted(&pose, DVec3::new(0.0, 0.0, d)));
                }
            }
            if !vertical {
                for a in [-turn, turn] {
                    moves.push(Pose::from_yaw_translation(pose.yaw() + a, pose.translation));
                }
            }
            for candidate in moves {
                let s = eval(&candidate);
                if s.0 > best.0 {
                    best = s;
                    pose = candidate;
                    improved = true;
                }
            }
            if !improved {
                break;
            }
        }
    }
    (pose, best)
}

fn shifted(pose: &Pose, d: DVec3) -> Pose {
    Pose::new(pose.rotation, pose.translation + d)
}

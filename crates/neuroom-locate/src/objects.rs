//! Object finding and initial poses by render-and-compare of pose hypotheses against the detections.
//!
//! Hypotheses per model follow where the model may stand: on the floor (a grid of positions whose box
//! centre projects into a detection × a ring of headings), against a wall (the empty room's surface
//! behind a detected pixel, facing along its normal), or on top of an object already placed. Each is
//! projected ([`neuroom_panorama::cloud::splat`]) and scored, pixel by pixel, by how much better its colours (under
//! a fitted tone: a per-channel gain and a directional shading, for the light changed) explain the
//! panorama than the empty room's colours do. The best hypothesis over all models is taken, refined
//! by coordinate descent and put into the scene: its pixels then count with its own colour error and
//! distance (a later object must explain them better to stand in front, and is hidden behind it), and
//! its box is taken (later objects may not stand inside it); the search goes on until no hypothesis
//! explains enough: objects absent from the panorama are not invented. Identical instances (one model,
//! several ids) are placed one after another at distinct poses. Then each placed object is searched again
//! in the scene of all the others, and a model left out gets its place back from the objects standing
//! in it when that explains the whole panorama better. The light is modelled, not gated: the objects'
//! colours are relit by the light the panorama shows around them ([`crate::local_light`]), and each
//! object's tone absorbs what remains of its light's level and colour.

use std::collections::HashMap;

use glam::{DMat3, DVec3, Vec2, Vec3};
use neuroom_core::image::{relit, srgb_to_linear};
use neuroom_core::obb::OrientedBox;
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use neuroom_panorama::cloud::{Cloud, Silhouette, SplatView, ZBuffer, splat};
use neuroom_panorama::sphere::{direction, neighbours};
use neuroom_panorama::{Detection, ObjectModel, Support};
use neuroom_render::Scene;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::evidence::{SearchView, colour_error, dilate, relit_room, room_gains};
use crate::lattice::LatticePose;
use crate::local_light::linear_under_gain;
use crate::memo::{PlacedKey, PoseKey, ScoreKey, ScoreMemo};
use crate::outline::OutlineSteps;
use crate::stage::LocateStage;

/// Search settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SearchConfig {
    /// Floor grid spacing (metres).
    pub grid: f32,
    /// Headings tried per position.
    pub headings: usize,
    /// Hypotheses kept per model after non-maximum suppression.
    pub keep: usize,
    /// Besides those, hypotheses kept per model in each detected region (the best there, whose box axis
    /// projects into it): a small far object scores below many poses of the same model on larger
    /// objects, and would otherwise have no hypothesis where it stands.
    pub keep_per_region: usize,
    /// Least distance between kept hypotheses of one model (metres).
    pub suppression: f32,
    /// Largest gain between an object's learnt colours and the panorama (and its inverse), overall.
    pub max_gain: f64,
    /// Largest ratio of one channel's gain to the overall gain (and its inverse).
    pub max_chroma: f64,
    /// Colour error assumed for the empty room where it has no surface (mean absolute sRGB).
    pub unknown_error: f32,
    /// Largest colour error one pixel counts with (mean absolute sRGB), for the room and the objects
    /// alike: a model is never exact (a thin panel its training missed, a highlight, a shadow its light
    /// does not cast), and a pixel that neither the room nor the object explains says nothing of which
    /// is there; without a bound, one badly modelled part vetoes an object that explains the rest.
    pub error_cap: f64,
    /// Detections are grown by this many pixels before box centres are tested against them.
    pub allowed_margin: usize,
    /// Room misfit (metres, see `room_misfit`) at which a hypothesis's score is divided by e.
    pub wall_distance: f32,
    /// Hypotheses refined before each placement (the best refined one is placed).
    pub contenders: usize,
    /// Of those, the most of one model.
    pub contenders_per_model: usize,
    /// [`SearchConfig::contenders_per_model`] of the pass over the objects after the search in the
    /// scene of the placed objects (`residual_search`), whose polished hypotheses near an object's true place may rank below
    /// three near its wrong one.
    pub residual_contenders_per_model: usize,
    /// Least score of a placed object (sum of colour-error gains, sRGB units × pixels).
    pub min_score: f64,
    /// Least pixels a placed object must explain better than the empty room.
    pub min_pixels: usize,
    /// Least fraction of its visible pixels it must explain better than the empty room.
    pub min_precision: f64,
    /// Least mean gain in colour error over its visible pixels (mean absolute sRGB): an object must
    /// explain what it covers clearly better than the empty room, not a large patch of floor or wall
    /// a little better (a light's glow the room's re-shading leaves, or noise).
    pub min_contrast: f64,
    /// Depth tolerance of the empty room's occlusion (metres).
    pub occlusion_tolerance: f32,
    /// Sub-pixels per pixel along each axis when a hypothesis is splatted
    /// ([`neuroom_panorama::cloud::SplatView::supersample`]): a pixel of the panorama integrates what it
    /// sees, so a thin leg or a silhouette's rim shows as a mix of the object and the room behind it.
    /// 1 (whole pixels, rims half covered) by default: measured on the validation suite, 2 found more
    /// objects on average but lost some in the worst room (docs/experiment-log.md).
    pub supersample: usize,
    /// Boxes are shrunk by this fraction before objects are tested for standing inside one another.
    pub contact_tolerance: f64,
    /// Largest fraction of the smaller box two placed objects may share.
    pub max_overlap: f64,
    /// Largest brightening (relative, beyond its gain) of an object's surfaces that face the light's
    /// direction, and darkening of those facing away: a lamp above or beside an object lights its faces
    /// unevenly, in a way the captures' light did not (0: one gain for every face).
    pub directional_shading: f64,
    /// Whether the directional term is fitted per colour channel: light of different colours from
    /// different sides (a cold window on one side, a warm lamp on the other; an object captured
    /// under a sunset, warm on one face and blue on the other) tints an object's faces differently,
    /// which one direction for all channels cannot show. Measured on the validation suite
    /// (docs/experiment-log.md): more objects found on average and in the worst room.
    pub chromatic_shading: bool,
    /// The camera stands in free space (on a tripod or a robot, whose legs or base take about 30 cm
    /// around it): no object's box, grown by this margin (metres), may reach the vertical line from
    /// the floor up to the camera. Without it a chair put under the camera explains the bottom of the
    /// panorama, where the room renders poorly; with 10 cm, the blender-lite stool still stood 16 cm
    /// from that line, on the light the ceiling panel throws on the floor below the camera.
    pub camera_clearance: f64,
    /// Weight of a hypothesis's outline credit (the `outline` module): per pair of 4-neighbours across
    /// its outline, the panorama's own colour step there beyond the scene's and the panorama's noise,
    /// counted as a colour-error gain of its rim pixel (0: the outline is not looked at). A model's
    /// colours are least right at its rim, where the step is the one cue its colour error does not
    /// swamp; a step is measured across three pixels (the blur's width) and stands for their evidence.
    /// Measured on the validation suite (docs/experiment-log.md): more objects found on average and in
    /// the worst room.
    pub outline_weight: f64,
    /// Side in pixels of the cells over which the outline credit's noise step is taken (its median
    /// there, interpolated between cells): a textured floor (a checkered one whose model renders it
    /// blurred) steps everywhere, and an outline there earns only beyond that; 0: one noise step for
    /// the whole panorama. A cell is several times the blur's width, so that an outline's own pairs
    /// are a minority of any cell's and leave its median, and small enough to tell a floor from the
    /// plain wall above it. Measured on the validation suite (docs/experiment-log.md): a higher mean
    /// and worst room than one noise step for the panorama, every room better than without the
    /// outline credit.
    pub outline_cell: usize,
}

impl Default for SearchConfig {
    fn default() -> Self {
        Self {
            grid: 0.15,
            headings: 12,
            keep: 30,
            keep_per_region: 2,
            suppression: 0.3,
            max_gain: 2.5,
            max_chroma: 1.25,
            unknown_error: 0.05,
            error_cap: 0.2,
            allowed_margin: 4,
            wall_distance: 0.15,
            contenders: 10,
            contenders_per_model: 3,
            residual_contenders_per_model: 6,
            min_score: 1.0,
            min_pixels: 25,
            min_precision: 0.5,
            min_contrast: 0.015,
            occlusion_tolerance: 0.1,
            supersample: 1,
            contact_tolerance: 0.1,
            max_overlap: 0.1,
            directional_shading: 0.6,
            chromatic_shading: true,
            camera_clearance: 0.3,
            outline_weight: 3.0,
            outline_cell: 16,
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
    /// Pixels it explains better than the scene before it was placed.
    pub explained: usize,
}

impl Found {
    /// Its pose (`object_to_world`).
    pub fn pose(&self) -> Pose {
        Pose::from_rows_unchecked(&self.object_to_world)
    }

    /// Model `model`, given instance id `id`, at the pose and with the score of `refined`.
    fn refined(model: usize, id: u16, refined: Refined) -> Self {
        Self {
            model,
            id,
            object_to_world: refined.pose.to_rows(),
            score: refined.score.gain,
            explained: refined.score.explained,
        }
    }

    /// Moves it to the pose of `refined`, with that pose's score.
    fn take(&mut self, refined: Refined) {
        *self = Self::refined(self.model, self.id, refined);
    }
}

/// How far (metres) an object standing on another may be from resting on its top face.
const SUPPORT_TOLERANCE: f64 = 0.05;

/// How far (metres) beyond its inset edge an object's centre may stand and still rest on its
/// supporter's top: a pose's rounding (the top's grid is laid out in `f32`), never a step of the
/// descent. Without it a hypothesis on the grid's edge counted as standing in the air.
const SUPPORT_EDGE_TOLERANCE: f64 = 1e-3;

#[derive(Clone, Copy, Debug)]
struct Hypothesis {
    model: usize,
    pose: Pose,
}

impl Hypothesis {
    fn key(&self) -> PlacedKey {
        PlacedKey {
            model: self.model,
            pose: PoseKey::of(&self.pose),
        }
    }
}

/// The scene as the objects placed so far make it: per pixel, the colour error of the nearest
/// surface (the empty room's, or a placed object's where one is in front) and that surface's distance;
/// and the boxes of the placed objects (the room's volume they occupy).
struct Placed {
    error: Vec<f32>,
    /// The colour the scene shows per pixel (the relit empty room's, or a placed object's under its
    /// tone), for the outline credit of hypotheses in front of it; empty when that is not looked at.
    colour: Vec<[f32; 3]>,
    depth: Vec<f32>,
    /// Whether the pixel still shows the empty room (no placed object in front).
    room_front: Vec<bool>,
    boxes: Vec<OrientedBox>,
    /// The placed objects, in the order they were put in (what makes this scene, for [`ScoreMemo`]).
    contents: Vec<PlacedKey>,
}

impl Placed {
    /// The empty room.
    fn nothing<F>(target: &Target<F>) -> Self {
        Self {
            error: target.room_error.clone(),
            colour: match target.outline {
                Some(_) => target.room_color.clone(),
                None => Vec::new(),
            },
            depth: target.view.empty_depth.clone(),
            room_front: vec![true; target.room_error.len()],
            boxes: Vec::new(),
            contents: Vec::new(),
        }
    }

    /// Whether `model` at `pose` would stand inside a placed object: the two boxes, shrunk by a
    /// tolerance so that objects may touch (a lamp on a nightstand), share more than `max_overlap` of
    /// the smaller one's volume.
    fn collides(&self, model: &ObjectModel, pose: &Pose, config: &SearchConfig) -> bool {
        stands_inside(&self.boxes, model, pose, config)
    }

    /// Whether `model` at `pose` stands on the top face of a placed object: its box centre above that
    /// object's top, its bottom within a few centimetres of it.
    fn supports(&self, model: &ObjectModel, pose: &Pose) -> bool {
        self.boxes.iter().any(|b| rests_on(b, model, pose))
    }

    /// The panorama's colour error summed over its pixels (of the nearest surface at each).
    fn total_error(&self) -> f64 {
        self.error.iter().map(|&e| e as f64).sum()
    }

    /// How much lower the panorama's summed colour error is in `other` than here.
    fn error_gain(&self, other: &Placed) -> f64 {
        self.total_error() - other.total_error()
    }

    /// Pixels whose nearest surface differs between this scene and `other`.
    fn changed(&self, other: &Placed) -> usize {
        self.depth
            .iter()
            .zip(&other.depth)
            .filter(|(a, b)| (*a - *b).abs() > 1e-4)
            .count()
    }

    /// Whether `other` explains the panorama clearly better than this scene: its error is lower by at
    /// least the least contrast ([`SearchConfig::min_contrast`]) on average over the pixels where the
    /// two differ, as a placed object must explain its own pixels.
    fn clearly_better(&self, other: &Placed, config: &SearchConfig) -> bool {
        let gain = self.error_gain(other);
        gain > 0.0 && gain >= config.min_contrast * self.changed(other) as f64
    }

    /// Puts `object` into the scene: its visible pixels take its colour error and distance, its box
    /// takes its volume.
    fn add<F>(
        &mut self,
        target: &Target<F>,
        models: &[ObjectModel],
        object: &Hypothesis,
        config: &SearchConfig,
    ) {
        let (model, pose) = (&models[object.model], &object.pose);
        let sil = silhouette(target, &model.fine, pose, &self.depth);
        let judged = judge(target, self, &sil, config);
        for s in &judged.samples {
            let colour = judged.tone.colour(s.learnt, s.normal);
            let error = s.error_showing(colour, 1.0, config);
            self.error[s.pixel] = error.min(config.error_cap) as f32;
            if let Some(c) = self.colour.get_mut(s.pixel) {
                *c = colour.map(|v| v as f32);
            }
        }
        for (&p, &d) in sil.pixels.iter().zip(&sil.depths) {
            self.depth[p as usize] = d;
            self.room_front[p as usize] = false;
        }
        self.boxes.push(model.box_at(pose));
        self.contents.push(object.key());
    }
}

/// Whether `model` at `pose` stands on the top face of `base`: its box centre above that top, its
/// bottom within a few centimetres of it.
fn rests_on(base: &OrientedBox, model: &ObjectModel, pose: &Pose) -> bool {
    let local = base.pose.inverse().transform_point(pose.translation);
    let half = 0.5 * base.size;
    let inset = support_inset(model) as f64;
    let edge = inset - SUPPORT_EDGE_TOLERANCE;
    local.x.abs() <= half.x - edge
        && local.y.abs() <= half.y - edge
        && (local.z - half.z - model.half.z as f64).abs() < SUPPORT_TOLERANCE
}

/// How far inside the edges of the top face it stands on an object's centre must be: a quarter of its
/// smaller half width. With its centre of mass on the very edge it would tip over; on living a0_l1 a vase
/// on the cabinet's front edge explained the edge's pixels better than the true one (10 against 5.5).
fn support_inset(model: &ObjectModel) -> f32 {
    0.25 * model.half.x.min(model.half.y)
}

/// `found` without the objects that stand on another model (a lamp on a desk) where no placed object of
/// that model holds them up any more: taking a supporter out of the scene takes out what stood on it,
/// rather than leaving it in the air.
fn without_orphans(models: &[ObjectModel], mut found: Vec<Found>) -> Vec<Found> {
    let held_up = |f: &Found, found: &[Found]| {
        !matches!(models[f.model].support, Support::On(_))
            || found.iter().any(|s| stands_on(models, f, s))
    };
    while let Some(k) = found.iter().position(|f| !held_up(f, &found)) {
        found.remove(k);
    }
    found
}

/// Whether `model` at `pose` would stand inside one of `boxes` ([`Placed::collides`]).
pub(crate) fn stands_inside(
    boxes: &[OrientedBox],
    model: &ObjectModel,
    pose: &Pose,
    config: &SearchConfig,
) -> bool {
    let shrink = 1.0 - config.contact_tolerance;
    let candidate = OrientedBox::new(*pose, 2.0 * shrink * model.half.as_dvec3());
    boxes.iter().any(|b| {
        let other = OrientedBox::new(b.pose, shrink * b.size);
        let smaller = candidate.volume().min(other.volume()).max(1e-9);
        candidate.intersection_volume(&other) / smaller > config.max_overlap
    })
}

/// What the search compares against.
struct Target<'a, F> {
    view: &'a SearchView,
    /// The empty room's field (wall distances).
    room: &'a F,
    camera: Pose,
    allowed: Vec<Vec<bool>>,
    /// The detection each pixel lies in (the first listed, grown as `allowed`; `None` outside every
    /// detection).
    region: Vec<Option<u32>>,
    tolerance: f32,
    /// Sub-pixels per pixel of a splat, along each axis.
    supersample: usize,
    /// The empty room's colour per pixel under the query's global gain ([`relit`]).
    room_color: Vec<[f32; 3]>,
    /// `room_color` in linear light, where a light field relights it per hypothesis (empty without
    /// one): converted once, not for every hypothesis that covers the pixel.
    room_linear: Vec<[f32; 3]>,
    /// Colour error of the empty room per pixel (mean absolute difference from `room_color`, as
    /// [`crate::evidence::residual`]; a constant where it has no surface).
    room_error: Vec<f32>,
    /// The panorama's colour steps for the outline credit ([`SearchConfig::outline_weight`]; `None`
    /// when it is 0).
    outline: Option<OutlineSteps>,
    /// The scores computed so far ([`hypothesis_score`]), by scene and pose.
    scores: ScoreMemo<PoseScore>,
}

/// How well a hypothesis explains the panorama in a scene: its colours against the scene's pixel by
/// pixel, discounted by how far it stands from where the room allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseScore {
    /// The sum over its visible pixels of the scene's colour error minus its own (sRGB units ×
    /// pixels), divided by e per [`SearchConfig::wall_distance`] of its room misfit when positive.
    pub gain: f64,
    /// Pixels it explains better than the scene.
    pub explained: usize,
    /// Their fraction of its visible pixels.
    pub precision: f64,
}

impl PoseScore {
    /// The score of nothing explained (a hypothesis that stands inside a placed object or by the
    /// camera).
    const NOTHING: PoseScore = PoseScore {
        gain: 0.0,
        explained: 0,
        precision: 0.0,
    };

    /// Its visible pixels.
    fn visible(&self) -> f64 {
        self.explained as f64 / self.precision.max(1e-9)
    }

    /// Whether the search places an object so scored: it explains enough pixels, most of those it
    /// covers, and each of them clearly better than the scene on average
    /// ([`SearchConfig::min_contrast`]).
    fn accepted(&self, config: &SearchConfig) -> bool {
        self.gain >= config.min_score
            && self.explained >= config.min_pixels
            && self.precision >= config.min_precision
            && self.gain >= config.min_contrast * self.visible()
    }
}

/// A hypothesis refined by [`descend`]: where it ended and its score there.
#[derive(Clone, Copy, Debug)]
struct Refined {
    pose: Pose,
    score: PoseScore,
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
        let room_color = relit_room(view);
        let n = view.width() * view.height();
        let mut allowed = vec![vec![false; n]; models];
        let mut region = vec![None; n];
        for (r, d) in detections.iter().enumerate() {
            for &p in &d.pixels {
                region[p as usize].get_or_insert(r as u32);
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
            region: grow_regions(region, view.width(), view.height(), config.allowed_margin),
            tolerance: config.occlusion_tolerance,
            supersample: config.supersample,
            room_error: room_color
                .iter()
                .zip(&view.query.data)
                .zip(&view.empty_depth)
                .enumerate()
                .map(|(p, ((r, q), d))| {
                    if !view.sees(p) {
                        0.0
                    } else if *d > 0.0 {
                        colour_error(*q, *r).min(config.error_cap as f32)
                    } else {
                        config.unknown_error
                    }
                })
                .collect(),
            room_linear: match view.light {
                Some(_) => room_color.iter().map(|c| c.map(srgb_to_linear)).collect(),
                None => Vec::new(),
            },
            outline: (config.outline_weight > 0.0).then(|| {
                let (w, h) = (view.width(), view.height());
                let (query, cell) = (&view.query.data, config.outline_cell);
                OutlineSteps::new(query, &room_color, |p| view.sees(p), (w, h), cell)
            }),
            room_color,
            scores: ScoreMemo::new(),
        }
    }
}

impl<F> Target<'_, F> {
    /// The light at an object hypothesis's `pixels`, as the room around them shows it: per pixel the
    /// gain of the light field estimated without them ([`crate::local_light::LightField::gains_without`];
    /// with them, a large object's own colour would pass for the light of the place it stands in).
    /// `None` with one light everywhere.
    fn light_around(&self, pixels: &[u32]) -> Option<Vec<[f32; 3]>> {
        let light = self.view.light.as_ref()?;
        Some(light.field.gains_without(pixels))
    }

    /// The empty room's colour at pixel `p` where the light field's gain is `field_gain` (in place of
    /// the gain `room_color` was relit by; `None`: that one).
    fn room_under(&self, p: usize, field_gain: Option<[f32; 3]>) -> [f32; 3] {
        match (&self.view.light, field_gain) {
            (Some(light), Some(g)) => {
                let own = light.field.gain(p);
                linear_under_gain(self.room_linear[p], std::array::from_fn(|k| g[k] / own[k]))
            }
            _ => self.room_color[p],
        }
    }

    /// An object's learnt colour `c` on its surface of world normal `normal`, seen at pixel `p` at
    /// distance `depth`, where the light field's gain is `field_gain` ([`SearchView::light`]; `None`:
    /// one light everywhere): an object takes the light of the place it stands in.
    fn lit(
        &self,
        field_gain: Option<[f32; 3]>,
        c: Vec3,
        normal: Vec3,
        p: usize,
        depth: f32,
    ) -> Vec3 {
        match (&self.view.light, field_gain) {
            (Some(light), Some(g)) => {
                let n = self.camera.rotation.transpose() * normal.as_dvec3();
                let point = || self.view.direction(p) * depth;
                Vec3::from(light.relight_object(g, c.to_array(), point, n.as_vec3()))
            }
            _ => c,
        }
    }
}

/// What the object search looks at: the panorama at the found camera, the empty room, the detections and
/// the models to find.
pub struct SearchInput<'a, F> {
    /// The room without objects (a scene of the background alone, for floor heights and wall normals).
    pub empty: &'a Scene<F>,
    /// The panorama and the empty room at the working resolution.
    pub view: &'a SearchView,
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

/// The score of model `m` at `pose` in the empty room, as the search ranks hypotheses.
pub fn pose_score<F: Field>(
    input: &SearchInput<F>,
    m: usize,
    pose: &Pose,
    config: &SearchConfig,
) -> PoseScore {
    let models = relit_models(input);
    let input = SearchInput {
        models: &models,
        ..*input
    };
    let target = Target::new(&input, config);
    let placed = Placed::nothing(&target);
    let model = &input.models[m];
    score_afresh(&target, &placed, model, false, pose, config)
}

/// The search's objective for the objects `found` placed in `input`: the panorama's summed colour error
/// with them in front of the empty room (lower is better). Compared between the arrangement the search
/// found and the true one, it tells a search that missed a better arrangement from a colour model that
/// prefers a wrong one.
pub fn arrangement_error<F: Field>(
    input: &SearchInput<F>,
    found: &[Found],
    config: &SearchConfig,
) -> f64 {
    let models = relit_models(input);
    let input = SearchInput {
        models: &models,
        ..*input
    };
    let target = Target::new(&input, config);
    scene_error(&target, &models, found, config)
}

/// How one object of an arrangement stands among the others, as the search would judge it there.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectStanding {
    /// The object's instance id.
    pub id: u16,
    /// Its score among the others (see [`SearchConfig::min_score`]); 0 where it collides or blocks
    /// the camera.
    pub score: f64,
    /// Pixels it explains better than the scene without it.
    pub explained: usize,
    /// Their fraction of its visible pixels.
    pub precision: f64,
    /// Whether the search would accept it there.
    pub accepted: bool,
}

/// How each object of `found` stands among the others of `found` ([`ObjectStanding`]): compared between
/// the arrangement the search found and the true one, it tells an object the search could not see
/// from one it did not reach.
pub fn object_standings<F: Field>(
    input: &SearchInput<F>,
    found: &[Found],
    config: &SearchConfig,
) -> Vec<ObjectStanding> {
    let models = relit_models(input);
    let input = SearchInput {
        models: &models,
        ..*input
    };
    let target = Target::new(&input, config);
    (0..found.len())
        .map(|k| {
            let score = standing(&target, &models, found, k, config);
            ObjectStanding {
                id: found[k].id,
                score: score.gain,
                explained: score.explained,
                precision: score.precision,
                accepted: score.accepted(config),
            }
        })
        .collect()
}

/// Finds the objects of `input` and their initial poses, telling `progress` each pass as it starts
/// (from [`LocateStage::Hypotheses`] to [`LocateStage::Residual`]).
pub fn find_objects<F: Field>(
    input: &SearchInput<F>,
    config: &SearchConfig,
    progress: &mut dyn FnMut(LocateStage),
) -> Vec<Found> {
    progress(LocateStage::Hypotheses);
    let models = relit_models(input);
    let input = &SearchInput {
        models: &models,
        ..*input
    };
    let target = Target::new(input, config);
    let (empty, models) = (input.empty, input.models);
    let floor = floor_height(empty, &input.camera_to_world);
    let empty_room = Placed::nothing(&target);
    let pool = pruned_hypotheses(&target, &empty_room, models, &[], floor, config);
    progress(LocateStage::Place);
    let found = greedy(&target, models, pool.clone(), Vec::new(), config);
    progress(LocateStage::Revisit);
    let found = revisit(&target, models, &pool, found, config);
    progress(LocateStage::Exchange);
    let found = exchange(&target, models, &pool, found, config);
    progress(LocateStage::Remove);
    let found = take_outs(&target, models, &pool, found, config);
    progress(LocateStage::Residual);
    residual_search(&target, models, &pool, found, floor, config)
}

/// Every model's hypotheses, its best few as scored in the scene `placed` ([`prune_in`]): on the
/// floor's grid, on the walls, or on the objects of `found` that carry them.
fn pruned_hypotheses<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    found: &[Found],
    floor: f32,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    let mut pool = Vec::new();
    for (m, model) in models.iter().enumerate() {
        let hyps = match model.support {
            Support::Floor => floor_hypotheses(target, m, model, floor, config),
            Support::Wall => wall_hypotheses(target, m, model),
            Support::On(supporter) => found
                .iter()
                .filter(|f| f.model == supporter)
                .flat_map(|f| support_grid(m, model, &models[supporter], &f.pose(), config))
                .collect(),
        };
        pool.extend(prune_in(target, placed, models, hyps, config));
    }
    pool
}

/// The search again from `found`, with every model's hypotheses pruned anew in the scene of the placed
/// objects: the pool was pruned in the empty room, where the placed objects' pixels draw every model's
/// best hypotheses to them, so a model may have had none near where it stands (a chair 0.8 m from its
/// nearest hypothesis on bedroom a1_l1). Greedy placement of the models still short of instances
/// follows, kept when it explains the panorama clearly better than `found`
/// ([`Placed::clearly_better`]). Then a pass over the objects placed before them (from the old and the
/// new hypotheses, these [`polished`], [`SearchConfig::residual_contenders_per_model`] of them per
/// model), kept when it lowers the colour error: each of its moves was accepted on its own pixels, and
/// a chair moved 1.4 m to where it stands gains 4 over the 1400 pixels it changes. The newcomers stay
/// where the greedy placement put them.
fn residual_search<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    pool: &[Hypothesis],
    found: Vec<Found>,
    floor: f32,
    config: &SearchConfig,
) -> Vec<Found> {
    let scene = placed_scene(target, models, &found, config);
    let fresh = pruned_hypotheses(target, &scene, models, &found, floor, config);
    let wider: Vec<Hypothesis> = pool
        .iter()
        .copied()
        .chain(polished(target, &scene, models, fresh.clone(), config))
        .collect();
    let added = greedy(target, models, fresh, found.clone(), config);
    let added_scene = placed_scene(target, models, &added, config);
    let (base_scene, base) = if scene.clearly_better(&added_scene, config) {
        (added_scene, added)
    } else {
        (scene, found.clone())
    };
    let pass = SearchConfig {
        contenders_per_model: config.residual_contenders_per_model,
        ..config.clone()
    };
    // The objects placed before stand first; the newcomers were just placed where they explain most.
    let before = base.iter().filter(|f| found.contains(f)).count();
    let moved = revisit_first(target, models, &wider, base.clone(), before, &pass);
    let moved_scene = placed_scene(target, models, &moved, config);
    if base_scene.error_gain(&moved_scene) > 0.0 {
        moved
    } else {
        base
    }
}

/// `hypotheses`, each moved to where its coarse score in the scene `placed` peaks nearby (one round of
/// [`descend`] on the coarse cloud): the grid's 30° headings left bedroom a1_l1's chair 16° and 6 cm off
/// its nearest hypothesis, which scored 11.8 there (33.8 polished, 48.9 where the chair stands), below
/// the three best that a pass over the objects refines.
fn polished<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    hypotheses: Vec<Hypothesis>,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    hypotheses
        .into_par_iter()
        .map(|h| Hypothesis {
            pose: descend(target, placed, models, &h, true, &POLISH_STEPS, config).pose,
            ..h
        })
        .collect()
}

/// The models with their clouds' colours under the panorama's light as the empty room shows it (its
/// per-channel gain): a light's colour tints every object alike, so each object's own colour gain
/// ([`limited_gain`]) is limited around the room's, not around the captures' light.
fn relit_models<F>(input: &SearchInput<F>) -> Vec<ObjectModel> {
    let gains = room_gains(input.view);
    let relight = |cloud: &Cloud| Cloud {
        colors: cloud
            .colors
            .iter()
            .map(|c| Vec3::from(relit(c.to_array(), gains)))
            .collect(),
        ..cloud.clone()
    };
    input
        .models
        .iter()
        .map(|m| ObjectModel {
            coarse: relight(&m.coarse),
            fine: relight(&m.fine),
            ..m.clone()
        })
        .collect()
}

/// Height of the floor under the camera.
fn floor_height<F: Field>(empty: &Scene<F>, camera: &Pose) -> f32 {
    let field = &empty.models[empty.background.model].field;
    let start = camera.translation.as_vec3();
    neuroom_panorama::database::floor_below(field, start, empty.background.bounds_min.z)
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

/// The pixels that points of the vertical axis of `model`'s box at `pose` project to (its centre, and a
/// quarter or a half of its height above and below): the centre of an open object (a desk, a chair) may
/// show the floor or wall through it.
fn axis_pixels<'t, F>(
    target: &'t Target<F>,
    model: &ObjectModel,
    pose: &Pose,
) -> impl Iterator<Item = usize> + 't {
    let (w, h) = (target.view.width(), target.view.height());
    let to_camera = target.camera.inverse();
    let (centre, half) = (pose.translation, model.half.z as f64);
    [0.0, 0.5, -0.5, 0.9, -0.9]
        .into_iter()
        .filter_map(move |f| {
            let point = centre + DVec3::Z * (f * half);
            neuroom_panorama::sphere::project(to_camera.transform_point(point), w, h)
                .map(|pix| (pix.y as usize).min(h - 1) * w + pix.x as usize % w)
        })
}

/// Whether `model` at `pose` stands where model `m` may be: a point of its axis projects into a pixel
/// the detections allow for it.
fn axis_allowed<F>(target: &Target<F>, m: usize, model: &ObjectModel, pose: &Pose) -> bool {
    axis_pixels(target, model, pose).any(|p| target.allowed[m][p])
}

/// The detected region `model` at `pose` stands in: the first its axis projects into.
fn axis_region<F>(target: &Target<F>, model: &ObjectModel, pose: &Pose) -> Option<u32> {
    axis_pixels(target, model, pose).find_map(|p| target.region[p])
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
            if axis_allowed(target, m, model, &probe) {
                out.extend(every_heading(m, t, config));
            }
        }
    }
    out
}

/// Model `m` standing at `t`, turned to each of [`SearchConfig::headings`] headings.
fn every_heading(m: usize, t: DVec3, config: &SearchConfig) -> impl Iterator<Item = Hypothesis> {
    let headings = config.headings;
    (0..headings).map(move |k| Hypothesis {
        model: m,
        pose: Pose::from_yaw_translation(std::f64::consts::TAU * k as f64 / headings as f64, t),
    })
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
        // The wall faces the camera that sees it: a learned room's SDF may rise again behind its
        // walls, and a point just past the zero level would turn the object to face the wall.
        let mut n = Vec3::new(n.x, n.y, 0.0).normalize();
        if n.dot((target.camera.translation - p).as_vec3()) < 0.0 {
            n = -n;
        }
        let centre = p + (n * model.half.x).as_dvec3();
        out.push(Hypothesis {
            model: m,
            pose: Pose::from_yaw_translation(n.y.atan2(n.x) as f64, centre),
        });
    }
    out
}

/// Scores hypotheses in the empty room and keeps the best few of each model at distinct positions
/// ([`keep_best`]).
fn prune<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    hyps: Vec<Hypothesis>,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    prune_in(target, &Placed::nothing(target), models, hyps, config)
}

/// [`prune`] in the scene `placed`: hypotheses score by what they explain beyond its objects.
fn prune_in<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    hyps: Vec<Hypothesis>,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    let scored: Vec<Scored> = hyps
        .into_par_iter()
        .map(|h| {
            let model = &models[h.model];
            let s = hypothesis_score(target, placed, models, &h, true, config);
            Scored {
                score: s.gain,
                hypothesis: h,
                region: axis_region(target, model, &h.pose),
            }
        })
        .collect();
    keep_best(scored, config)
}

/// A hypothesis with its score in the empty room and the detected region it stands in.
struct Scored {
    score: f64,
    hypothesis: Hypothesis,
    region: Option<u32>,
}

/// Of one model's scored hypotheses, the best [`SearchConfig::keep`] and, in each detected region,
/// the best [`SearchConfig::keep_per_region`] (counting those already kept), no two within the
/// suppression distance; hypotheses that explain nothing are dropped.
fn keep_best(mut scored: Vec<Scored>, config: &SearchConfig) -> Vec<Hypothesis> {
    scored.retain(|s| s.score > 0.0);
    scored.sort_by(|a, b| b.score.total_cmp(&a.score));
    let far_from = |kept: &[&Scored], h: &Scored| {
        let at = h.hypothesis.pose.translation;
        kept.iter()
            .all(|k| k.hypothesis.pose.translation.distance(at) > config.suppression as f64)
    };
    let mut kept: Vec<&Scored> = Vec::new();
    for h in &scored {
        if kept.len() >= config.keep {
            break;
        }
        if far_from(&kept, h) {
            kept.push(h);
        }
    }
    let mut in_region: HashMap<u32, usize> = HashMap::new();
    for r in kept.iter().filter_map(|k| k.region) {
        *in_region.entry(r).or_default() += 1;
    }
    for h in &scored {
        let Some(r) = h.region else { continue };
        let n = in_region.entry(r).or_default();
        if *n < config.keep_per_region && far_from(&kept, h) {
            *n += 1;
            kept.push(h);
        }
    }
    kept.into_iter().map(|k| k.hypothesis).collect()
}

/// What `cloud` at `pose` shows in front of the scene's surfaces at `depth`.
fn silhouette<F>(target: &Target<F>, cloud: &Cloud, pose: &Pose, depth: &[f32]) -> Silhouette {
    let view = SplatView {
        camera_to_world: &target.camera,
        width: target.view.width(),
        height: target.view.height(),
        room_depth: depth,
        tolerance: target.tolerance,
        supersample: target.supersample,
    };
    ZBuffer::with_thread_local(|buffer| splat(cloud, pose, &view, buffer))
}

/// How well a silhouette explains the panorama ([`PoseScore`]), its colours under the object's tone.
/// The score is the sum over its
/// visible pixels of the scene's colour error there (the empty room's, or a placed object's it would
/// stand in front of) minus the object's, its colours under the [`Tone`] fitted to those pixels (the
/// light changed). Both the room and the object are seen there under the light the room around the
/// silhouette shows ([`Target::light_around`]).
fn score<F>(
    target: &Target<F>,
    placed: &Placed,
    sil: &Silhouette,
    config: &SearchConfig,
) -> PoseScore {
    let judged = judge(target, placed, sil, config);
    if judged.samples.is_empty() {
        return PoseScore::NOTHING;
    }
    let (mut total, mut wins) = (0.0f64, 0usize);
    for s in &judged.samples {
        let error = s.error_showing(judged.tone.colour(s.learnt, s.normal), s.cover, config);
        let d = s.baseline - error.min(config.error_cap);
        total += d;
        if d > 0.0 {
            wins += 1;
        }
    }
    PoseScore {
        gain: total,
        explained: wins,
        precision: wins as f64 / judged.samples.len() as f64,
    }
}

/// A silhouette's visible pixels as the scene and the object would show them, and the object's tone.
struct Judged {
    samples: Vec<ToneSample>,
    tone: Tone,
}

/// The samples of `sil`'s visible pixels against the scene `placed`, under the light around the
/// silhouette, and the tone fitted to them.
fn judge<F>(
    target: &Target<F>,
    placed: &Placed,
    sil: &Silhouette,
    config: &SearchConfig,
) -> Judged {
    // What the camera did not see (outside a photo's field of view) neither supports nor refutes a
    // hypothesis.
    let visible: Vec<usize> = (0..sil.pixels.len())
        .filter(|&i| target.view.sees(sil.pixels[i] as usize))
        .collect();
    let pixels: Vec<u32> = visible.iter().map(|&i| sil.pixels[i]).collect();
    let around = target.light_around(&pixels);
    let inside = target.outline.as_ref().map(|_| {
        let mut inside = sil.pixels.clone();
        inside.sort_unstable();
        inside
    });
    let samples: Vec<ToneSample> = visible
        .iter()
        .enumerate()
        .map(|(j, &i)| {
            let p = sil.pixels[i] as usize;
            let gain = around.as_ref().map(|a| a[j]);
            let known = target.view.empty_depth[p] > 0.0;
            // A pixel the object covers in part mixes it with the room behind it.
            let cover = if known { sil.cover[i] as f64 } else { 1.0 };
            let (query, room) = (target.view.query.data[p], target.room_under(p, gain));
            let baseline = if placed.room_front[p] && known {
                colour_error(query, room).min(config.error_cap as f32)
            } else {
                placed.error[p]
            };
            ToneSample {
                pixel: p,
                query,
                room,
                learnt: target.lit(gain, sil.colors[i], sil.normals[i], p, sil.depths[i]),
                cover,
                normal: sil.normals[i],
                baseline: baseline as f64,
                outline: match (&target.outline, &inside) {
                    (Some(steps), Some(inside)) => {
                        steps.credit(&placed.colour, inside, p, |q| target.view.sees(q))
                    }
                    _ => 0.0,
                },
            }
        })
        .collect();
    let tone = if samples.is_empty() {
        Tone::NEUTRAL
    } else {
        fit_tone(&samples, config)
    };
    Judged { samples, tone }
}

/// How an object's learnt colours look under the panorama's light: a per-channel gain (the light's
/// colour and level), and a first-order directional term (faces turned to the light are brighter),
/// one per colour channel ([`SearchConfig::chromatic_shading`]; otherwise the three alike).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Tone {
    gain: [f64; 3],
    /// Per channel, the relative brightening of a face per unit of its normal along this vector.
    light: [DVec3; 3],
}

impl Tone {
    const NEUTRAL: Tone = Tone {
        gain: [1.0; 3],
        light: [DVec3::ZERO; 3],
    };

    /// The colour a point of learnt colour `c` with world normal `n` shows.
    fn colour(&self, c: Vec3, n: Vec3) -> [f64; 3] {
        let n = n.as_dvec3();
        std::array::from_fn(|k| self.gain[k] * (1.0 + self.light[k].dot(n)) * c[k] as f64)
    }
}

/// One visible pixel of a silhouette, for [`fit_tone`] and [`score`].
struct ToneSample {
    /// The pixel.
    pixel: usize,
    /// The panorama's colour.
    query: [f32; 3],
    /// The empty room's colour (behind a rim pixel's uncovered part).
    room: [f32; 3],
    /// The object's learnt colour.
    learnt: Vec3,
    /// Fraction of the pixel the object covers.
    cover: f64,
    /// The object's normal there (world frame).
    normal: Vec3,
    /// The scene's colour error there (the empty room's under the same light, or a placed object's).
    baseline: f64,
    /// Its outline credit ([`crate::outline::OutlineSteps::credit`]; 0 inside the outline, or when
    /// the outline is not looked at).
    outline: f64,
}

impl ToneSample {
    /// Its colour error with the object showing colour `c` over the fraction `cover` of it
    /// ([`object_error`]), less its outline credit ([`SearchConfig::outline_weight`]).
    fn error_showing(&self, c: [f64; 3], cover: f64, config: &SearchConfig) -> f64 {
        object_error(self.query, self.room, c, cover) - config.outline_weight * self.outline
    }
}

/// The [`Tone`] (within the search's limits) that best explains `samples`, robustly: a least-squares
/// fit ([`weighted_tone`]) reweighted over [`TONE_ROUNDS`] rounds with Cauchy weights of each pixel's
/// colour error, so that what the model lacks or the light adds to a few pixels (a thin panel its
/// training missed, a highlight, a shadow) does not drag the tone of all the others.
fn fit_tone(samples: &[ToneSample], config: &SearchConfig) -> Tone {
    let mut weights = vec![1.0; samples.len()];
    let mut tone = weighted_tone(samples, &weights, config);
    for _ in 0..TONE_ROUNDS {
        let errors: Vec<f64> = samples.iter().map(|s| tone_error(&tone, s)).collect();
        let mut sorted = errors.clone();
        let mid = sorted.len() / 2;
        let median = *sorted.select_nth_unstable_by(mid, f64::total_cmp).1;
        let scale = (2.5 * median).max(TONE_LEAST_SCALE);
        for (w, e) in weights.iter_mut().zip(&errors) {
            *w = 1.0 / (1.0 + (e / scale).powi(2));
        }
        tone = weighted_tone(samples, &weights, config);
    }
    tone
}

/// Reweighting rounds of [`fit_tone`].
const TONE_ROUNDS: usize = 2;

/// Smallest scale of [`fit_tone`]'s weights (mean absolute sRGB): the noise of a camera's colours, so
/// that a tone that explains most pixels exactly does not make the rest outliers.
const TONE_LEAST_SCALE: f64 = 0.02;

/// The colour error of sample `s` under `tone`.
fn tone_error(tone: &Tone, s: &ToneSample) -> f64 {
    let c = tone.colour(s.learnt, s.normal);
    (0..3)
        .map(|k| (s.query[k] as f64 - s.cover * c[k] - (1.0 - s.cover) * s.room[k] as f64).abs())
        .sum::<f64>()
        / 3.0
}

/// The [`Tone`] (within the search's limits) that best explains `samples` weighted by `weights`: the
/// gain by least squares, then the directional term given that gain (damped, so that directions the
/// normals do not span stay unlit).
fn weighted_tone(samples: &[ToneSample], weights: &[f64], config: &SearchConfig) -> Tone {
    let (mut num, mut den) = ([0.0f64; 3], [0.0f64; 3]);
    for (s, w) in samples.iter().zip(weights) {
        for k in 0..3 {
            let c = s.learnt[k] as f64;
            num[k] += w * s.cover * c * (s.query[k] as f64 - (1.0 - s.cover) * s.room[k] as f64);
            den[k] += w * s.cover * s.cover * c * c;
        }
    }
    let gain = limited_gain(std::array::from_fn(|k| num[k] / den[k].max(1e-9)), config);
    if config.directional_shading <= 0.0 {
        return Tone {
            gain,
            light: [DVec3::ZERO; 3],
        };
    }
    // The normal equations of the directional term: one system per channel, or one for all three.
    let mut systems = [LightSystem::EMPTY; 3];
    for (s, w) in samples.iter().zip(weights) {
        for (k, g) in gain.iter().enumerate() {
            let lit = s.cover * g * s.learnt[k] as f64;
            let rest = s.query[k] as f64 - (1.0 - s.cover) * s.room[k] as f64 - lit;
            let row = s.normal.as_dvec3() * lit;
            let system = if config.chromatic_shading { k } else { 0 };
            systems[system].add(row, rest, *w);
        }
    }
    let light = if config.chromatic_shading {
        systems.map(|system| system.solved(config.directional_shading))
    } else {
        [systems[0].solved(config.directional_shading); 3]
    };
    Tone { gain, light }
}

/// The least-squares normal equations `ata · l = atb` of a directional term `l`.
#[derive(Clone, Copy)]
struct LightSystem {
    ata: DMat3,
    atb: DVec3,
}

impl LightSystem {
    /// No equations yet.
    const EMPTY: LightSystem = LightSystem {
        ata: DMat3::ZERO,
        atb: DVec3::ZERO,
    };

    /// Adds the equation `row · l = rest` with weight `w`.
    fn add(&mut self, row: DVec3, rest: f64, w: f64) {
        self.ata += w * DMat3::from_cols(row * row.x, row * row.y, row * row.z);
        self.atb += w * row * rest;
    }

    /// The solution, damped (directions the normals do not span stay unlit) and no longer than
    /// `limit`.
    fn solved(&self, limit: f64) -> DVec3 {
        let ata = self.ata;
        let damping = 1e-3 * (ata.x_axis.x + ata.y_axis.y + ata.z_axis.z) + 1e-9;
        let light = (ata + DMat3::from_diagonal(DVec3::splat(damping))).inverse() * self.atb;
        if light.is_finite() {
            light.clamp_length_max(limit)
        } else {
            DVec3::ZERO
        }
    }
}

/// `gain` within the search's limits: its overall level (geometric mean) within
/// [`SearchConfig::max_gain`] of 1, each channel within [`SearchConfig::max_chroma`] of that level (a
/// light's colour tints every object alike; a strong tint is a wrong object fitted to the wrong place).
fn limited_gain(gain: [f64; 3], config: &SearchConfig) -> [f64; 3] {
    let gain = gain.map(|g| g.max(1e-3));
    let level = (gain[0] * gain[1] * gain[2])
        .cbrt()
        .clamp(1.0 / config.max_gain, config.max_gain);
    gain.map(|g| level * (g / level).clamp(1.0 / config.max_chroma, config.max_chroma))
}

/// The colour error against the panorama's colour `q` of an object showing colour `c` covering the
/// fraction `cover` of the pixel (the empty room's colour `r` fills the rest).
fn object_error(q: [f32; 3], r: [f32; 3], c: [f64; 3], cover: f64) -> f64 {
    (0..3)
        .map(|k| {
            let predicted = cover * c[k] + (1.0 - cover) * r[k] as f64;
            (q[k] as f64 - predicted).abs()
        })
        .sum::<f64>()
        / 3.0
}

/// The pool's hypotheses worth refining next: the best-scoring ones (acceptance is judged once refined),
/// at most [`SearchConfig::contenders_per_model`] of each model and [`SearchConfig::contenders`] in
/// all (a coarse hypothesis of the right object may start farther from its optimum than a wrong one).
fn contenders<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    pool: &[Hypothesis],
    config: &SearchConfig,
) -> Vec<usize> {
    let mut scored: Vec<(usize, f64)> = pool
        .par_iter()
        .enumerate()
        .map(|(k, h)| (k, hypothesis_score(target, placed, models, h, true, config)))
        .filter(|(_, s)| s.gain > 0.0)
        .map(|(k, s)| (k, s.gain))
        .collect();
    scored.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut per_model = vec![0usize; models.len()];
    let mut out = Vec::new();
    for (k, _) in scored {
        let m = pool[k].model;
        if out.len() < config.contenders && per_model[m] < config.contenders_per_model {
            per_model[m] += 1;
            out.push(k);
        }
    }
    out
}

/// Takes the best hypothesis over all models while one explains enough, refining and committing each,
/// in the scene of the objects `found` already holds.
fn greedy<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    mut pool: Vec<Hypothesis>,
    mut found: Vec<Found>,
    config: &SearchConfig,
) -> Vec<Found> {
    let mut placed = placed_scene(target, models, &found, config);
    let mut used = vec![0usize; models.len()];
    for f in &found {
        used[f.model] += 1;
        let at = f.pose().translation;
        suppress_near(&mut pool, f.model, at, config);
    }
    loop {
        pool.retain(|h| used[h.model] < models[h.model].ids.len());
        let contenders = contenders(target, &placed, models, &pool, config);
        if contenders.is_empty() {
            break;
        }
        let refined: Vec<(usize, Refined)> = contenders
            .par_iter()
            .map(|&k| (k, refine(target, &placed, models, &pool[k], config)))
            .collect();
        let best = refined
            .iter()
            .filter(|(_, r)| r.score.accepted(config))
            .max_by(|a, b| a.1.score.gain.total_cmp(&b.1.score.gain))
            .map(|&(k, r)| (k, pool[k].model, r));
        // Contenders that fail once refined leave the pool with the winner.
        let mut drop = vec![false; pool.len()];
        for (k, r) in &refined {
            drop[*k] = !r.score.accepted(config);
        }
        if let Some((k, ..)) = best {
            drop[k] = true;
        }
        let mut dropped = drop.into_iter();
        pool.retain(|_| !dropped.next().unwrap_or(false));
        let Some((_, m, refined)) = best else {
            continue;
        };
        let (model, pose) = (&models[m], refined.pose);
        placed.add(target, models, &Hypothesis { model: m, pose }, config);
        let id = free_id(model, &found);
        used[m] += 1;
        found.push(Found::refined(m, id, refined));
        suppress_near(&mut pool, m, pose.translation, config);
        pool.extend(support_hypotheses(target, models, m, &pose, config));
    }
    found
}

/// Drops the hypotheses of model `m` within the suppression distance of `at`, where one of its objects
/// stands.
fn suppress_near(pool: &mut Vec<Hypothesis>, m: usize, at: DVec3, config: &SearchConfig) {
    pool.retain(|o| o.model != m || o.pose.translation.distance(at) > config.suppression as f64);
}

/// The scene with every object of `found` placed, in order.
fn placed_scene<F>(
    target: &Target<F>,
    models: &[ObjectModel],
    found: &[Found],
    config: &SearchConfig,
) -> Placed {
    let mut placed = Placed::nothing(target);
    for f in found {
        let object = Hypothesis {
            model: f.model,
            pose: f.pose(),
        };
        placed.add(target, models, &object, config);
    }
    placed
}

/// The first instance id of `model` that no object of `found` carries.
fn free_id(model: &ObjectModel, found: &[Found]) -> u16 {
    model
        .ids
        .iter()
        .copied()
        .find(|id| found.iter().all(|f| f.id != *id))
        .unwrap_or(model.ids[0])
}

/// The colour error of the whole panorama with `found` placed: the sum over pixels of the error of the
/// nearest surface (an object's, or the empty room's).
fn scene_error<F>(
    target: &Target<F>,
    models: &[ObjectModel],
    found: &[Found],
    config: &SearchConfig,
) -> f64 {
    placed_scene(target, models, found, config).total_error()
}

/// A model left out (fewer placed than its instances) may have lost its place to a wrong object placed
/// first: the greedy search cannot take an object back. Each of its best hypotheses in the empty room is
/// put in, the placed objects it collides with (and what stood on them) are taken out, and the search
/// goes on from there (they may find another place) and revisits every object. Of these exchanges, the
/// one that lowers the whole panorama's colour error most is kept, when it is clearly lower
/// ([`Placed::clearly_better`]): a swap that changes thousands of pixels for a gain of a few units is
/// the colour model's noise, not evidence.
fn exchange<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    pool: &[Hypothesis],
    mut found: Vec<Found>,
    config: &SearchConfig,
) -> Vec<Found> {
    let mut scene = placed_scene(target, models, &found, config);
    let empty = Placed::nothing(target);
    for (m, model) in models.iter().enumerate() {
        if found.iter().filter(|f| f.model == m).count() >= model.ids.len() {
            continue;
        }
        let own: Vec<Hypothesis> = pool.iter().filter(|h| h.model == m).cloned().collect();
        let starts: Vec<Refined> = contenders(target, &empty, models, &own, config)
            .par_iter()
            .map(|&k| refine(target, &empty, models, &own[k], config))
            .filter(|r| r.score.accepted(config))
            .collect();
        let mut best: Option<(f64, Vec<Found>, Placed)> = None;
        for refined in starts {
            let newcomer = [model.box_at(&refined.pose)];
            let (kept, taken_out): (Vec<Found>, Vec<Found>) =
                found.iter().cloned().partition(|f| {
                    let at = f.pose();
                    !stands_inside(&newcomer, &models[f.model], &at, config)
                });
            if taken_out.is_empty() {
                continue;
            }
            let mut start = without_orphans(models, kept);
            start.push(Found::refined(m, free_id(model, &start), refined));
            let (candidate, candidate_scene) =
                search_on(target, models, pool.to_vec(), pool, start, config);
            let gain = scene.error_gain(&candidate_scene);
            if scene.clearly_better(&candidate_scene, config)
                && best.as_ref().is_none_or(|(g, ..)| gain > *g)
            {
                best = Some((gain, candidate, candidate_scene));
            }
        }
        if let Some((_, candidate, candidate_scene)) = best {
            (found, scene) = (candidate, candidate_scene);
        }
    }
    found
}

/// Whether `object` stands on `base` (its model is held up by `base`'s, and it rests on its top).
fn stands_on(models: &[ObjectModel], object: &Found, base: &Found) -> bool {
    models[object.model].support == Support::On(base.model)
        && rests_on(
            &models[base.model].box_at(&base.pose()),
            &models[object.model],
            &object.pose(),
        )
}

/// The search from the objects `start` holds: placements from `hypotheses` while one explains enough,
/// then a pass over every object (with the whole `pool`); the objects and their scene.
fn search_on<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    hypotheses: Vec<Hypothesis>,
    pool: &[Hypothesis],
    start: Vec<Found>,
    config: &SearchConfig,
) -> (Vec<Found>, Placed) {
    let found = greedy(target, models, hypotheses, start, config);
    let found = revisit(target, models, pool, found, config);
    let scene = placed_scene(target, models, &found, config);
    (found, scene)
}

/// Each placed object in turn is taken out (with what stood on it) and the search goes on without it
/// where it stood, then revisits every object: an object placed early in a wrong pose (a bed turned
/// across the wardrobe's place) keeps the right ones out, and may find its true pose once they are in.
/// A take-out is kept when the whole panorama's colour error is clearly lower
/// ([`Placed::clearly_better`]).
fn take_outs<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    pool: &[Hypothesis],
    mut found: Vec<Found>,
    config: &SearchConfig,
) -> Vec<Found> {
    let mut scene = placed_scene(target, models, &found, config);
    for k in 0..found.len() {
        let Some(taken_out) = found.get(k) else {
            break;
        };
        let at = taken_out.pose().translation;
        let mut rest = found.clone();
        rest.remove(k);
        let rest = without_orphans(models, rest);
        let mut elsewhere = pool.to_vec();
        suppress_near(&mut elsewhere, taken_out.model, at, config);
        let (candidate, candidate_scene) = search_on(target, models, elsewhere, pool, rest, config);
        if scene.clearly_better(&candidate_scene, config) {
            (found, scene) = (candidate, candidate_scene);
        }
    }
    found
}

/// Each placed object again, in the scene of all the others: later objects may explain its pixels
/// better, or show it was put in the wrong place. Its pose is searched again from where it stands
/// (also turned by a quarter and a half turn, unless it hangs on a wall) and from the model's best
/// hypotheses; it keeps the best refined pose, or leaves the scene when none is accepted any more.
fn revisit<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    pool: &[Hypothesis],
    found: Vec<Found>,
    config: &SearchConfig,
) -> Vec<Found> {
    let count = found.len();
    revisit_first(target, models, pool, found, count, config)
}

/// [`revisit`] of the first `count` objects of `found` only (the others stay where they are).
fn revisit_first<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    pool: &[Hypothesis],
    mut found: Vec<Found>,
    mut count: usize,
    config: &SearchConfig,
) -> Vec<Found> {
    let mut k = 0;
    while k < count.min(found.len()) {
        let mut others = found.clone();
        others.remove(k);
        let placed = placed_scene(target, models, &others, config);
        let m = found[k].model;
        let model = &models[m];
        // An object that stands on another is searched again from where it stands only while it
        // still rests on something: from the air it would stay there.
        let on_something =
            |pose: &Pose| !matches!(model.support, Support::On(_)) || placed.supports(model, pose);
        let mut starts: Vec<Hypothesis> = revisit_starts(model, &found[k].pose())
            .into_iter()
            .filter(|pose| on_something(pose))
            .map(|pose| Hypothesis { model: m, pose })
            .collect();
        let mut own: Vec<Hypothesis> = pool.iter().filter(|h| h.model == m).cloned().collect();
        if let Support::On(supporter) = model.support {
            for (j, f) in found.iter().enumerate() {
                if j != k && f.model == supporter {
                    let at = f.pose();
                    own.extend(
                        support_hypotheses(target, models, supporter, &at, config)
                            .into_iter()
                            .filter(|h| h.model == m),
                    );
                }
            }
        }
        starts.extend(
            contenders(target, &placed, models, &own, config)
                .into_iter()
                .map(|i| own[i]),
        );
        let refined: Vec<Refined> = starts
            .par_iter()
            .map(|h| refine(target, &placed, models, h, config))
            .filter(|r| r.score.accepted(config))
            .collect();
        // The first of the best scores, in the order of the starts.
        let best = refined
            .into_iter()
            .min_by(|a, b| b.score.gain.total_cmp(&a.score.gain));
        match best {
            Some(refined) => {
                let from = found[k].pose();
                found[k].take(refined);
                for j in carried(models, &mut found, k, &from) {
                    // Those not revisited after it take their score where they were carried.
                    if j <= k || j >= count {
                        let s = standing(target, models, &found, j, config);
                        found[j].score = s.gain;
                        found[j].explained = s.explained;
                    }
                }
                k += 1;
            }
            None => {
                found.remove(k);
                count -= 1;
                // What stood on it leaves with it; those already revisited shift the index, and
                // those to revisit the count.
                let kept = without_orphans(models, found.clone());
                let lost = |range: &[Found]| range.iter().filter(|f| !kept.contains(f)).count();
                k -= lost(&found[..k]);
                count -= lost(&found[..count.min(found.len())]);
                found = kept;
            }
        }
    }
    found
}

/// Moves what stood on the `k`-th object of `found` when it stood at `from` along with it to where it
/// stands now, as lifting a table carries the toy on it: an object's support is kept by every move,
/// never left in the air. Returns the indices of the objects carried.
fn carried(models: &[ObjectModel], found: &mut [Found], k: usize, from: &Pose) -> Vec<usize> {
    let to = found[k].pose();
    let before = Found {
        object_to_world: from.to_rows(),
        ..found[k].clone()
    };
    let motion = to.compose(&from.inverse());
    let mut moved = Vec::new();
    for (j, f) in found.iter_mut().enumerate() {
        if j != k && stands_on(models, f, &before) {
            f.object_to_world = motion.compose(&f.pose()).to_rows();
            moved.push(j);
        }
    }
    moved
}

/// Where [`revisit`] searches an object's pose again from where it stands at `current`: there, and turned
/// by a quarter, a half and three quarters of a turn (a box seen from one side looks alike turned so),
/// and by [`REVISIT_SMALL_TURN`] either way: the descent of [`refine`] turns 15° at most per step and
/// only one coordinate at a time, so an object left a little turned and shifted can stay there. A wall
/// object keeps facing out of its wall.
fn revisit_starts(model: &ObjectModel, current: &Pose) -> Vec<Pose> {
    let turns: &[f64] = if model.support == Support::Wall {
        &[0.0]
    } else {
        &[0.0, -REVISIT_SMALL_TURN, REVISIT_SMALL_TURN, 0.5, 1.0, 1.5]
    };
    turns
        .iter()
        .map(|turn| {
            Pose::from_yaw_translation(
                current.yaw() + turn * std::f64::consts::PI,
                current.translation,
            )
        })
        .collect()
}

/// The small turn either way [`revisit`] also starts from, in half turns: 18°. On bedroom a0_l1 a chair
/// left 12° turned and 7 cm off (scoring 125) reaches its true pose (scoring 241) when started 10° to one
/// side or 10–40° to the other; with these starts the bedroom preset's IoU went from 76.7 to 79.3 %.
const REVISIT_SMALL_TURN: f64 = 0.1;

/// [`score`] of hypothesis `h` (coarse or fine cloud) in the scene `placed`, discounted by its
/// [`room_misfit`]; looked up when already computed ([`Target::scores`]).
fn hypothesis_score<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    h: &Hypothesis,
    coarse: bool,
    config: &SearchConfig,
) -> PoseScore {
    let key = ScoreKey {
        object: h.key(),
        coarse,
    };
    target.scores.get_or(&placed.contents, key, || {
        score_afresh(target, placed, &models[h.model], coarse, &h.pose, config)
    })
}

/// [`hypothesis_score`] computed, not looked up.
fn score_afresh<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    model: &ObjectModel,
    coarse: bool,
    pose: &Pose,
    config: &SearchConfig,
) -> PoseScore {
    if placed.collides(model, pose, config) || blocks_camera(target, model, pose, config) {
        return PoseScore::NOTHING;
    }
    let cloud = if coarse { &model.coarse } else { &model.fine };
    let sil = silhouette(target, cloud, pose, &placed.depth);
    let s = score(target, placed, &sil, config);
    misfit_discounted(s, target, model, pose, config)
}

/// Whether `model` at `pose` reaches the line the camera stands on ([`SearchConfig::camera_clearance`]):
/// its box, grown by the clearance, holds that line's point at the box centre's height (at the
/// camera's height, for a box above it).
fn blocks_camera<F>(
    target: &Target<F>,
    model: &ObjectModel,
    pose: &Pose,
    config: &SearchConfig,
) -> bool {
    let camera = target.camera.translation;
    let probe = DVec3::new(camera.x, camera.y, pose.translation.z.min(camera.z));
    model.box_at(pose).contains(probe, config.camera_clearance)
}

/// A score `s` of `model` at `pose` divided by e per [`SearchConfig::wall_distance`] of its
/// [`room_misfit`] (a loss is left as it is).
fn misfit_discounted<F: Field>(
    mut s: PoseScore,
    target: &Target<F>,
    model: &ObjectModel,
    pose: &Pose,
    config: &SearchConfig,
) -> PoseScore {
    if s.gain > 0.0 {
        s.gain *= (-(room_misfit(target.room, model, pose) / config.wall_distance) as f64).exp();
    }
    s
}

/// How far `model` at `pose` is from standing as the room allows (metres): the depth by which its box
/// corners enter the room's surfaces (beyond a small tolerance), plus, when it stands against a wall, the
/// larger distance of the two ends of its back from the wall: its back lies along the wall, not one
/// point of it near a wall and the rest turned away.
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
        for side in [-1.0, 1.0] {
            let end = DVec3::new(-h.x - 0.02, side * BACK_ENDS * h.y, 0.0);
            points.push(pose.transform_point(end).as_vec3());
        }
    }
    let mut sdf = vec![0.0f32; points.len()];
    room.sdf(&points, &mut sdf);
    let inside: f32 = sdf[..8].iter().map(|d| (-d - 0.03).max(0.0)).sum();
    let back = sdf[8..].iter().fold(0.0f32, |m, d| m.max(d.abs()));
    inside + back
}

/// Where the ends of an object's back are taken, as a fraction of its half width: halfway to its
/// corners (measured: 0.8 gave the bedroom and office presets IoU 75.6 and 72.4 %, 0.5 gives 76.7 and
/// 76.4 %).
const BACK_ENDS: f64 = 0.5;

/// The score of the `k`-th object of `found` among the others, as [`hypothesis_score`] gives it
/// (nothing where it collides with them).
fn standing<F: Field>(
    target: &Target<F>,
    models: &[ObjectModel],
    found: &[Found],
    k: usize,
    config: &SearchConfig,
) -> PoseScore {
    let mut rest = found.to_vec();
    rest.remove(k);
    let others = placed_scene(target, models, &rest, config);
    let (f, model) = (&found[k], &models[found[k].model]);
    let pose = f.pose();
    if others.collides(model, &pose, config) {
        return PoseScore::NOTHING;
    }
    let sil = silhouette(target, &model.fine, &pose, &others.depth);
    let s = score(target, &others, &sil, config);
    misfit_discounted(s, target, model, &pose, config)
}

/// `mask` grown by `n` pixels.
fn dilate_n(mask: &[bool], w: usize, h: usize, n: usize) -> Vec<bool> {
    (0..n).fold(mask.to_vec(), |m, _| dilate(&m, w, h))
}

/// Grows labelled regions into unlabelled neighbouring pixels, `n` pixels (as [`dilate_n`]).
fn grow_regions(region: Vec<Option<u32>>, w: usize, h: usize, n: usize) -> Vec<Option<u32>> {
    (0..n).fold(region, |r, _| {
        (0..w * h)
            .map(|i| r[i].or_else(|| neighbours(i, w, h).find_map(|j| r[j])))
            .collect()
    })
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
        if model.support != Support::On(supporter) {
            continue;
        }
        let hyps = support_grid(m, model, base, pose, config);
        out.extend(prune(target, models, hyps, config));
    }
    out
}

/// Poses of model `m` on the top face of `base` standing at `pose`: a grid 3 cm apart, every heading.
fn support_grid(
    m: usize,
    model: &ObjectModel,
    base: &ObjectModel,
    pose: &Pose,
    config: &SearchConfig,
) -> Vec<Hypothesis> {
    let step = 0.03f32;
    let top = (base.half.truncate() - Vec2::splat(support_inset(model))).max(Vec2::ZERO);
    let (nx, ny) = ((2.0 * top.x / step) as i32, (2.0 * top.y / step) as i32);
    let mut hyps = Vec::new();
    for i in 0..=nx {
        for j in 0..=ny {
            let local = Vec3::new(
                -top.x + i as f32 * step,
                -top.y + j as f32 * step,
                base.half.z + model.half.z,
            );
            let t = pose.transform_point(local.as_dvec3());
            hyps.extend(every_heading(m, t, config));
        }
    }
    hyps
}

/// Coordinate descent on (x, y, z, yaw) from `start` with shrinking steps, scored with the fine cloud
/// in the scene `placed`.
fn refine<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    start: &Hypothesis,
    config: &SearchConfig,
) -> Refined {
    descend(target, placed, models, start, false, &REFINE_STEPS, config)
}

/// The (metres, degrees) steps of [`refine`], coarse to fine.
const REFINE_STEPS: [(f64, f64); 4] = [(0.1, 15.0), (0.05, 8.0), (0.02, 3.0), (0.01, 1.0)];

/// The step of [`polished`]: a third of a grid cell, a quarter of the heading grid's step.
const POLISH_STEPS: [(f64, f64); 1] = [(0.05, 8.0)];

/// Coordinate descent on (x, y, z, yaw) over `steps` (metres, degrees), scored with the coarse or the
/// fine cloud. The poses visited lie on a fine lattice ([`LatticePose`]), so that a pose reached again
/// (by another start, or by another pass in the same scene) has the same score, looked up.
fn descend<F: Field>(
    target: &Target<F>,
    placed: &Placed,
    models: &[ObjectModel],
    start: &Hypothesis,
    coarse: bool,
    steps: &[(f64, f64)],
    config: &SearchConfig,
) -> Refined {
    let m = start.model;
    let model = &models[m];
    let eval = |pose: &LatticePose| {
        let h = Hypothesis {
            model: m,
            pose: pose.pose(),
        };
        hypothesis_score(target, placed, models, &h, coarse, config)
    };
    let mut pose = LatticePose::nearest(&start.pose);
    let mut best = eval(&pose);
    let vertical = model.support == Support::Wall;
    // An object that stands on another slides on its supporter's top, never off it into the air.
    let supported = matches!(model.support, Support::On(_));
    for &(step, turn) in steps {
        // The move last taken: its opposite leads back to a pose already scored lower.
        let mut taken: Option<usize> = None;
        loop {
            let mut improved = false;
            let mut moves: Vec<LatticePose> = Vec::new();
            // A wall object slides along its wall (its y axis), up and down, and to and from the
            // wall (its x axis: its hypothesis stands where the learned wall is); others on the floor.
            let axes = if vertical {
                let (sin, cos) = pose.yaw_rad().sin_cos();
                let (along, out) = (DVec3::new(-sin, cos, 0.0), DVec3::new(cos, sin, 0.0));
                vec![
                    along,
                    DVec3::Z,
                    (along + DVec3::Z) * 0.7,
                    (along - DVec3::Z) * 0.7,
                    out,
                ]
            } else {
                vec![
                    DVec3::X,
                    DVec3::Y,
                    DVec3::new(0.7, 0.7, 0.0),
                    DVec3::new(0.7, -0.7, 0.0),
                ]
            };
            for axis in axes {
                for d in [-step, step] {
                    moves.push(pose.moved(axis * d));
                }
            }
            if !vertical {
                for a in [-turn, turn] {
                    moves.push(pose.turned(a));
                }
            }
            // Moves come in opposite pairs (2i, 2i + 1), so the way back of move j is j ^ 1.
            let back = taken.map(|j| j ^ 1);
            taken = None;
            for (j, candidate) in moves.into_iter().enumerate() {
                if Some(j) == back || (supported && !placed.supports(model, &candidate.pose())) {
                    continue;
                }
                let s = eval(&candidate);
                if s.gain > best.gain {
                    best = s;
                    pose = candidate;
                    taken = Some(j);
                    improved = true;
                }
            }
            if !improved {
                break;
            }
        }
    }
    Refined {
        pose: pose.pose(),
        score: best,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_field::AnalyticField;
    use neuroom_panorama::cloud::surface_cloud;
    use std::f64::consts::FRAC_PI_2;

    fn model(half: Vec3) -> ObjectModel {
        ObjectModel {
            ids: vec![1],
            half,
            coarse: Cloud::default(),
            fine: Cloud::default(),
            support: Support::Floor,
            against_wall: false,
        }
    }

    /// Samples of a box's three visible faces (up, and two sides) whose learnt colours the panorama
    /// shows under `gain`, the top `top` times and the side facing +x `side` times brighter.
    fn shaded_faces(gain: [f64; 3], top: f64, side: f64) -> Vec<ToneSample> {
        let faces = [(Vec3::Z, top), (Vec3::X, side), (Vec3::Y, 1.0)];
        let learnt = [
            Vec3::new(0.6, 0.4, 0.3),
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(0.2, 0.3, 0.6),
        ];
        let mut out = Vec::new();
        for (normal, shade) in faces {
            for c in learnt {
                out.push(ToneSample {
                    pixel: out.len(),
                    query: std::array::from_fn(|k| (gain[k] * shade * c[k] as f64) as f32),
                    room: [0.9; 3],
                    learnt: c,
                    cover: 1.0,
                    normal,
                    baseline: 0.3,
                    outline: 0.0,
                });
            }
        }
        out
    }

    #[test]
    fn a_small_object_keeps_hypotheses_in_its_own_region() {
        let config = SearchConfig {
            keep: 3,
            keep_per_region: 1,
            ..SearchConfig::default()
        };
        let at = |x: f64, score: f64, region: Option<u32>| Scored {
            score,
            hypothesis: Hypothesis {
                model: 0,
                pose: Pose::from_yaw_translation(0.0, DVec3::new(x, 0.0, 0.0)),
            },
            region,
        };
        // Many strong poses on a large object (region 0), a weak one on a small far object (region 1),
        // one outside every region and one that explains nothing (region 2).
        let mut scored: Vec<Scored> = (0..10)
            .map(|i| at(i as f64, 50.0 - i as f64, Some(0)))
            .collect();
        scored.extend([
            at(20.0, 4.0, Some(1)),
            at(21.0, 3.0, Some(1)),
            at(30.0, 5.0, None),
        ]);
        scored.push(at(40.0, -1.0, Some(2)));
        let kept: Vec<f64> = keep_best(scored, &config)
            .iter()
            .map(|h| h.pose.translation.x)
            .collect();
        assert_eq!(kept, vec![0.0, 1.0, 2.0, 20.0]);
    }

    #[test]
    fn regions_grow_into_unlabelled_neighbours_across_the_seam() {
        // 4 × 3 pixels: region 7 at column 0 of the middle row, region 2 at column 2 of it.
        let mut region = vec![None; 12];
        region[4] = Some(7);
        region[6] = Some(2);
        let grown = grow_regions(region, 4, 3, 1);
        // Column 3 is beside column 0 across the seam (and beside column 2): the first-listed
        // neighbour wins there; a pixel already labelled keeps its label.
        assert_eq!(grown[4], Some(7));
        assert_eq!(grown[0], Some(7));
        assert_eq!(grown[8], Some(7));
        assert_eq!(grown[6], Some(2));
        assert_eq!(grown[2], Some(2));
        assert!(grown[7].is_some() && grown[5].is_some());
        assert_eq!(grown[1], None);
        assert_eq!(grown[3], None);
    }

    #[test]
    fn the_tone_finds_the_light_colour_and_which_faces_it_lights() {
        let config = SearchConfig::default();
        let gain = [1.2, 1.0, 0.9];
        // The side facing +y keeps the learnt shade: the gain is its, tops are 1.3×, +x sides 0.8×.
        let samples = shaded_faces(gain, 1.3, 0.8);
        let tone = fit_tone(&samples, &config);
        for s in &samples {
            let shown = tone.colour(s.learnt, s.normal);
            for k in 0..3 {
                assert!(
                    (shown[k] - s.query[k] as f64).abs() < 0.03,
                    "{shown:?} against {:?} ({tone:?})",
                    s.query
                );
            }
        }
        assert!(tone.light[0].z > 0.1 && tone.light[0].x < -0.1, "{tone:?}");
        // Without the directional term, one gain must serve every face.
        let flat = fit_tone(
            &samples,
            &SearchConfig {
                directional_shading: 0.0,
                ..config.clone()
            },
        );
        assert_eq!(flat.light, [DVec3::ZERO; 3]);
        // An implausibly strong direction is held to the limit.
        let strong = fit_tone(&shaded_faces(gain, 4.0, 0.1), &config);
        assert!(strong.light[0].length() <= config.directional_shading + 1e-9);
    }

    #[test]
    fn a_chromatic_tone_shows_light_of_two_colours_from_two_sides() {
        // Warm light from +x, cold from −x: the +x face shows more red and less blue, the −x face
        // the opposite; the top shows the learnt colour.
        let tilt = [DVec3::X * 0.3, DVec3::ZERO, DVec3::X * -0.3];
        let learnt = [Vec3::new(0.6, 0.5, 0.4), Vec3::new(0.3, 0.5, 0.6)];
        let mut samples = Vec::new();
        for normal in [Vec3::X, -Vec3::X, Vec3::Z, Vec3::Y] {
            for c in learnt {
                samples.push(ToneSample {
                    pixel: samples.len(),
                    query: std::array::from_fn(|k| {
                        ((1.0 + tilt[k].dot(normal.as_dvec3())) * c[k] as f64) as f32
                    }),
                    room: [0.9; 3],
                    learnt: c,
                    cover: 1.0,
                    normal,
                    baseline: 0.3,
                    outline: 0.0,
                });
            }
        }
        let worst = |config: &SearchConfig| {
            let tone = fit_tone(&samples, config);
            samples
                .iter()
                .map(|s| tone_error(&tone, s))
                .fold(0.0f64, f64::max)
        };
        let chromatic = SearchConfig::default();
        let one_direction = SearchConfig {
            chromatic_shading: false,
            ..chromatic.clone()
        };
        assert!(worst(&chromatic) < 0.01, "{}", worst(&chromatic));
        assert!(worst(&one_direction) > 0.05);
    }

    #[test]
    fn an_object_must_explain_what_it_covers_clearly_better_than_the_room() {
        let config = SearchConfig::default();
        // 1000 visible pixels, 950 of them better: a nightstand on the floor, gaining 0.012 per pixel
        // on average where the lamp's glow falls, against a true one gaining 0.025 on 220 pixels.
        let accepted = |gain, explained, precision| {
            PoseScore {
                gain,
                explained,
                precision,
            }
            .accepted(&config)
        };
        assert!(!accepted(12.0, 950, 0.95));
        assert!(accepted(5.5, 176, 0.8));
        // The other limits still hold: too few pixels, too small a fraction of them, too low a score.
        assert!(!accepted(5.5, 20, 0.8));
        assert!(!accepted(5.5, 176, 0.4));
        assert!(!accepted(0.5, 26, 0.9));
    }

    #[test]
    fn objects_may_touch_but_not_stand_inside_one_another() {
        let table = model(Vec3::new(0.3, 0.3, 0.25));
        let lamp = model(Vec3::new(0.1, 0.1, 0.15));
        let placed = Placed {
            error: Vec::new(),
            colour: Vec::new(),
            depth: Vec::new(),
            room_front: Vec::new(),
            contents: Vec::new(),
            boxes: vec![table.box_at(&Pose::from_yaw_translation(0.3, DVec3::new(1.0, 1.0, 0.25)))],
        };
        let config = SearchConfig::default();
        let on_top = Pose::from_yaw_translation(1.0, DVec3::new(1.1, 0.9, 0.65));
        let beside = Pose::from_yaw_translation(0.0, DVec3::new(1.0, 1.52, 0.15));
        let inside = Pose::from_yaw_translation(0.0, DVec3::new(1.2, 1.0, 0.3));
        assert!(!placed.collides(&lamp, &on_top, &config));
        assert!(!placed.collides(&lamp, &beside, &config));
        assert!(placed.collides(&lamp, &inside, &config));
        assert!(placed.collides(
            &table,
            &Pose::from_yaw_translation(0.0, DVec3::new(1.3, 1.0, 0.25)),
            &config
        ));
        // Standing on the table's top, anywhere on it but with its centre on the very edge; not beside
        // it at the same height, not sunk into it.
        assert!(placed.supports(&lamp, &on_top));
        let table_at = |x: f64, y: f64| {
            Pose::from_yaw_translation(0.3, DVec3::new(1.0, 1.0, 0.25))
                .transform_point(DVec3::new(x, y, 0.4))
        };
        let near_edge = Pose::from_yaw_translation(0.0, table_at(0.27, 0.0));
        let on_edge = Pose::from_yaw_translation(0.0, table_at(0.29, 0.0));
        assert!(placed.supports(&lamp, &near_edge));
        assert!(!placed.supports(&lamp, &on_edge));
        // The inset narrows the top face, not the height it rests at: 4 cm above it is within reach.
        let above = Pose::from_yaw_translation(1.0, DVec3::new(1.1, 0.9, 0.69));
        assert!(placed.supports(&lamp, &above));
        assert!(placed.supports(
            &lamp,
            &Pose::from_yaw_translation(2.0, DVec3::new(0.75, 1.2, 0.65))
        ));
        assert!(!placed.supports(
            &lamp,
            &Pose::from_yaw_translation(1.0, DVec3::new(1.5, 1.0, 0.65))
        ));
        assert!(!placed.supports(&lamp, &beside));
        assert!(!placed.supports(&lamp, &inside));
    }

    /// A table (model 0) and a lamp that stands on it (model 1).
    fn table_and_lamp() -> [ObjectModel; 2] {
        let lamp = ObjectModel {
            support: Support::On(0),
            ..model(Vec3::new(0.1, 0.1, 0.15))
        };
        [model(Vec3::new(0.3, 0.3, 0.25)), lamp]
    }

    /// Model `m` found as instance `id` turned by `yaw` at (`x`, 1, `z`).
    fn found_at(m: usize, id: u16, yaw: f64, x: f64, z: f64) -> Found {
        Found {
            model: m,
            id,
            object_to_world: Pose::from_yaw_translation(yaw, DVec3::new(x, 1.0, z)).to_rows(),
            score: 1.0,
            explained: 30,
        }
    }

    #[test]
    fn taking_a_supporter_out_takes_out_what_stood_on_it() {
        let models = table_and_lamp();
        let at = |m: usize, id: u16, x: f64, z: f64| found_at(m, id, 0.2, x, z);
        let on_table = at(1, 2, 1.1, 0.65);
        let in_the_air = at(1, 3, 2.5, 0.65);
        let scene = vec![on_table.clone(), at(0, 1, 1.0, 0.25), in_the_air];
        let kept = without_orphans(&models, scene);
        assert_eq!(kept.len(), 2);
        assert!(kept.contains(&on_table));
        // The table taken out, its lamp goes too.
        assert!(without_orphans(&models, vec![on_table]).is_empty());
    }

    #[test]
    fn every_pose_of_the_support_grid_rests_on_its_supporter() {
        let (table, lamp) = (
            model(Vec3::new(0.207, 0.25, 0.24)),
            model(Vec3::new(0.15, 0.15, 0.2)),
        );
        for yaw in [0.0, 1.0, std::f64::consts::PI] {
            let pose = Pose::from_yaw_translation(yaw, DVec3::new(4.1639, 3.3943, 0.2407));
            let grid = support_grid(1, &lamp, &table, &pose, &SearchConfig::default());
            assert!(!grid.is_empty());
            for h in grid {
                assert!(
                    rests_on(&table.box_at(&pose), &lamp, &h.pose),
                    "{:?}",
                    h.pose
                );
            }
        }
    }

    #[test]
    fn a_moved_supporter_carries_what_stood_on_it() {
        let models = table_and_lamp();
        let at = |m: usize, yaw: f64, x: f64, z: f64| found_at(m, m as u16 + 1, yaw, x, z);
        let from = Pose::from_yaw_translation(0.2, DVec3::new(1.0, 1.0, 0.25));
        let mut found = vec![
            at(0, 0.2, 1.0, 0.25),
            at(1, 0.5, 1.1, 0.65),
            at(1, 0.0, 2.5, 0.65),
        ];
        // The table moves 1.5 m and turns a quarter turn.
        let to = Pose::from_yaw_translation(0.2 + FRAC_PI_2, DVec3::new(2.0, 2.0, 0.25));
        found[0].object_to_world = to.to_rows();
        assert_eq!(carried(&models, &mut found, 0, &from), vec![1]);
        let (lamp_pose, box_now) = (found[1].pose(), models[0].box_at(&to));
        assert!(rests_on(&box_now, &models[1], &lamp_pose));
        // It keeps its place and heading on the table's top.
        let before = from.inverse().transform_point(DVec3::new(1.1, 1.0, 0.65));
        let now = to.inverse().transform_point(lamp_pose.translation);
        assert!(before.distance(now) < 1e-9);
        assert!((lamp_pose.yaw() - (0.5 + FRAC_PI_2)).abs() < 1e-9);
        // The one that stood elsewhere stays.
        assert_eq!(found[2], at(1, 0.0, 2.5, 0.65));
    }

    #[test]
    fn a_changed_scene_must_explain_the_pixels_it_changes_clearly_better() {
        let config = SearchConfig::default();
        let scene = |error: f32, changed: usize| Placed {
            error: (0..1000)
                .map(|i| if i < changed { error } else { 0.05 })
                .collect(),
            colour: Vec::new(),
            depth: (0..1000)
                .map(|i| if i < changed { 1.0 } else { 3.0 })
                .collect(),
            room_front: vec![true; 1000],
            boxes: Vec::new(),
            contents: Vec::new(),
        };
        let now = scene(0.05, 0);
        // 400 pixels changed: 0.01 lower on each is within the colour model's noise, 0.02 is not.
        assert!(!now.clearly_better(&scene(0.04, 400), &config));
        assert!(now.clearly_better(&scene(0.03, 400), &config));
        assert!(!now.clearly_better(&scene(0.06, 400), &config));
        assert_eq!(now.changed(&scene(0.03, 400)), 400);
    }

    #[test]
    fn a_revisit_also_starts_a_little_turned_either_way_except_on_a_wall() {
        let current = Pose::from_yaw_translation(0.3, DVec3::new(1.0, 2.0, 0.4));
        let mut standing = model(Vec3::new(0.3, 0.3, 0.4));
        let yaws = |m: &ObjectModel| -> Vec<f64> {
            revisit_starts(m, &current)
                .iter()
                .map(|p| {
                    assert_eq!(p.translation, current.translation);
                    (p.yaw() - 0.3).to_degrees().rem_euclid(360.0).round()
                })
                .collect()
        };
        let mut turns = yaws(&standing);
        turns.sort_by(f64::total_cmp);
        assert_eq!(turns, vec![0.0, 18.0, 90.0, 180.0, 270.0, 342.0]);
        standing.support = Support::Wall;
        assert_eq!(yaws(&standing), vec![0.0]);
    }

    #[test]
    fn an_object_against_a_wall_lies_along_it() {
        // A 4 m × 3.7 m room; a shelf (36 cm deep, 80 cm wide) whose back faces +y.
        let room = neuroom_field::AnalyticField::RoomShell {
            centre: Vec3::new(1.975, 1.85, 1.3),
            half: Vec3::new(1.975, 1.85, 1.3),
            color: neuroom_field::AnalyticColor::Constant(Vec3::splat(0.5)),
        };
        let shelf = ObjectModel {
            against_wall: true,
            ..model(Vec3::new(0.18, 0.4, 0.75))
        };
        let at = |yaw_deg: f64, x: f64, y: f64| {
            Pose::from_yaw_translation(yaw_deg.to_radians(), DVec3::new(x, y, 0.75))
        };
        // Back flush to the wall y = 3.7 (its −x side turned to +y).
        assert!(room_misfit(&room, &shelf, &at(-90.0, 2.0, 3.5)) < 0.02);
        // Turned 35° off that wall in the corner: the middle of its back is 19 cm from the wall, the
        // ends taken 7 and 30 cm.
        let turned = room_misfit(&room, &shelf, &at(-55.0, 3.55, 3.36));
        assert!(turned > 0.3, "{turned}");
    }

    /// A grey box standing in a plain room, its colours in the panorama tinted by `tint` (the room's
    /// not), seen from 1.4 m high: the room, the view, the box's model, the camera and the box's pose.
    fn tinted_box(tint: Vec3) -> (Scene<AnalyticField>, SearchView, ObjectModel, Pose, Pose) {
        use neuroom_field::{AnalyticColor, CodeSet};
        use neuroom_render::{Background, InstanceCodes, Model, RenderConfig, SceneObject};
        let (centre, half) = (Vec3::new(2.0, 1.5, 1.3), Vec3::new(2.0, 1.5, 1.3));
        let room = AnalyticField::RoomShell {
            centre,
            half,
            color: AnalyticColor::Position {
                origin: centre,
                scale: 3.0,
            },
        };
        let grey = Vec3::splat(0.5);
        let box_half = Vec3::new(0.3, 0.2, 0.25);
        let cuboid = |rgb: Vec3| AnalyticField::Cuboid {
            centre: Vec3::ZERO,
            half: box_half,
            color: AnalyticColor::Constant(rgb),
        };
        let pose = Pose::from_yaw_translation(0.5, DVec3::new(2.7, 2.0, box_half.z as f64));
        let camera = Pose::new(DMat3::IDENTITY, DVec3::new(1.5, 1.4, 1.4));
        let scene = |objects: Vec<SceneObject>| Scene {
            models: vec![
                Model {
                    field: room.clone(),
                    inv_s: 400.0,
                },
                Model {
                    field: cuboid(grey * tint),
                    inv_s: 400.0,
                },
            ],
            background: Background {
                model: 0,
                bounds_min: centre - half - Vec3::splat(0.05),
                bounds_max: centre + half + Vec3::splat(0.05),
                codes: InstanceCodes::default(),
                tone: neuroom_render::Tone::IDENTITY,
            },
            objects,
        };
        let width = 128;
        let config = RenderConfig::default();
        let with_box = scene(vec![SceneObject::new(1, 1, &pose, box_half)]);
        let cam = neuroom_core::camera::Equirect::new(width, width / 2).unwrap();
        let (query, _, _) = neuroom_render::render_image(&with_box, &cam, &camera, &config);
        let empty = scene(Vec::new());
        let (room_rgb, depth) = crate::render_background(&empty, &camera, width as usize, &config);
        let view = SearchView {
            query,
            empty: room_rgb,
            empty_depth: depth,
            seen: None,
            light: None,
        };
        let cloud = |spacing| surface_cloud(&cuboid(grey), box_half, spacing, CodeSet::default());
        let model = ObjectModel {
            coarse: cloud(0.04),
            fine: cloud(0.025),
            ..model(box_half)
        };
        (empty, view, model, camera, pose)
    }

    /// Runs `check` on the [`tinted_box`] of `tint`: its target, the empty room's scene, the box's model
    /// and its pose.
    fn in_tinted_view(
        tint: Vec3,
        check: impl FnOnce(&Target<AnalyticField>, &Placed, &ObjectModel, &Pose),
    ) {
        let (empty, view, model, camera, pose) = tinted_box(tint);
        let models = [model];
        let input = SearchInput {
            empty: &empty,
            view: &view,
            camera_to_world: camera,
            detections: &[],
            models: &models,
        };
        let target = Target::new(&input, &SearchConfig::default());
        check(&target, &Placed::nothing(&target), &models[0], &pose);
    }

    #[test]
    fn an_object_under_a_coloured_light_is_explained_by_its_tone() {
        // The light's colour is fitted per object, not assumed: a box tinted warm or cold in the
        // panorama is accepted where it stands.
        let config = SearchConfig::default();
        let tints = [
            Vec3::ONE,
            Vec3::new(1.2, 1.0, 0.85),
            Vec3::new(0.85, 1.0, 1.2),
        ];
        for tint in tints {
            in_tinted_view(tint, |target, placed, model, pose| {
                let s = score_afresh(target, placed, model, false, pose, &config);
                assert!(s.accepted(&config), "tint {tint}: {s:?}");
            });
        }
    }

    #[test]
    fn the_panoramas_step_along_the_true_outline_raises_the_score() {
        // Where the box stands, the panorama steps from the box to the room across its outline; a
        // hypothesis on the bare floor away from it finds no such step along its own.
        let config = SearchConfig::default();
        let blind = SearchConfig {
            outline_weight: 0.0,
            ..config.clone()
        };
        in_tinted_view(Vec3::ONE, |target, placed, model, pose| {
            let credit = |at: &Pose| {
                let with = score_afresh(target, placed, model, false, at, &config).gain;
                with - score_afresh(target, placed, model, false, at, &blind).gain
            };
            let away = Pose::from_yaw_translation(
                pose.yaw(),
                pose.translation + DVec3::new(0.6, -1.0, 0.0),
            );
            let (true_credit, away_credit) = (credit(pose), credit(&away));
            assert!(true_credit > 1.0, "{true_credit}");
            assert!(
                away_credit < 0.25 * true_credit,
                "{away_credit} vs {true_credit}"
            );
        });
    }

    #[test]
    fn a_looked_up_score_is_the_score_computed_afresh() {
        // Scores are kept per scene and pose: a score looked up is the one computing it gives, in
        // the empty room and in a scene with an object placed, whether the hypothesis overlaps it
        // or not.
        let config = SearchConfig::default();
        in_tinted_view(Vec3::ONE, |target, empty, model, pose| {
            let models = [model.clone()];
            let at = |yaw: f64, dx: f64, dy: f64| Hypothesis {
                model: 0,
                pose: Pose::from_yaw_translation(
                    pose.yaw() + yaw,
                    pose.translation + DVec3::new(dx, dy, 0.0),
                ),
            };
            let mut placed = Placed::nothing(target);
            placed.add(target, &models, &at(0.0, 0.0, 0.0), &config);
            let hypotheses = [
                at(0.0, 0.0, 0.0),   // inside the placed box
                at(0.3, 0.05, 0.6),  // beside it, partly in front of it
                at(0.0, -2.0, -1.0), // far from it, clear of its pixels
                at(1.0, -1.2, 0.9),
            ];
            for h in &hypotheses {
                for scene in [empty, &placed] {
                    for coarse in [true, false] {
                        let direct = score_afresh(target, scene, model, coarse, &h.pose, &config);
                        for _ in 0..2 {
                            let looked_up =
                                hypothesis_score(target, scene, &models, h, coarse, &config);
                            assert_eq!(looked_up, direct, "{h:?} coarse {coarse}");
                        }
                    }
                }
            }
        });
    }
}

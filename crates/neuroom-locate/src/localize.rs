//! Camera localization: database search, then direct alignment through the renderer.
//!
//! 1. The query is reduced to the database size; its features are correlated with every database
//!    panorama over all headings ([`crate::yaw`]), once with signed gradients and once with their
//!    orientations (robust to a lighting change); the best (position, heading) pairs of each are
//!    candidates.
//! 2. Each candidate is aligned in 6-DoF to its own database panorama (a free keyframe: colour + depth
//!    are stored) on edge orientations, which another lighting leaves in place; this pulls it from the
//!    grid point to near the true camera. Candidates that meet at one pose count once; the best
//!    correlations go on.
//! 3. Each of them gets one round against a keyframe rendered from the background model at its pose and
//!    re-shaded to the panorama's light ([`crate::shading::match_shading`]: the room under other lamps
//!    changes each surface by a gain that follows its normal, which reverses some of the edges between
//!    walls, floor and ceiling); the best correlation is refined a few more rounds at finer resolutions
//!    (each render removes the parallax error of the last).

use std::time::Instant;

use glam::{DMat3, DVec3};
use neuroom_core::camera::Equirect;
use neuroom_core::camera_effects::rotate_panorama;
use neuroom_core::image::RgbImage;
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use neuroom_panorama::database::Database;
use neuroom_render::{RenderConfig, Scene, render_image};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::align::{AlignConfig, Alignment, Keyframe, align, best_start};
use crate::features::FeatureMap;
use crate::level::{LevelConfig, leveling, tilted_up};
use crate::shading::match_shading;
use crate::sphere_image::SphereImage;
use crate::stage::LocateStage;
use crate::yaw::{YawMatch, best_yaws};

/// Settings of [`localize`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocalizeConfig {
    /// Blur of the heading search's features (database pixels).
    pub yaw_sigma: f32,
    /// Headings kept per database panorama.
    pub yaws_per_entry: usize,
    /// Candidates of each heading search (signed gradients, then orientations; a candidate both find
    /// is aligned once) aligned against their database panorama.
    pub candidates: usize,
    /// Softness of the orientation features ([`FeatureMap::orientation`]).
    pub orientation_softness: f32,
    /// Candidates refined against rendered keyframes, the best by their aligned correlation.
    pub finalists: usize,
    /// Coarse alignments closer than this to a better one (metres, and the same in radians of
    /// heading) found the same pose: only the better goes on, so that the finalists differ.
    #[serde(default = "default_distinct")]
    pub distinct: f64,
    /// Re-shade each rendered keyframe to the panorama's light before aligning to it.
    #[serde(default = "default_reshade")]
    pub reshade: bool,
    /// Alignment against database panoramas.
    pub coarse: AlignConfig,
    /// Widths of the rendered keyframes, one refinement round each; every finalist gets the first
    /// round, the best of them the others.
    pub fine_widths: Vec<usize>,
    /// Alignment against rendered keyframes.
    pub fine: AlignConfig,
    /// Rendering of the keyframes.
    pub render: RenderConfig,
    /// When the best finalist's refined correlation is below [`CameraEvidence::strong`], this many
    /// more finalists (the next best after the first rendered round) are refined too and the best
    /// correlation wins: a light the captures never saw can rank a wrong place first. Each goes on
    /// to the next round only while it leads after the one before (`finish`).
    #[serde(default = "default_fallbacks")]
    pub fallbacks: usize,
    /// How the final correlation and the best other place become the camera's confidence.
    #[serde(default)]
    pub evidence: CameraEvidence,
    /// Level a tilted panorama first ([`crate::level::estimate_up`]), locate it as a level one, then
    /// refine the camera in all six degrees of freedom; `None`: the camera is taken to be level.
    #[serde(default = "default_level")]
    pub level: Option<LevelConfig>,
    /// The wider search for a camera that would be said lost ([`CameraEvidence::says_lost`]).
    #[serde(default)]
    pub lost_search: LostSearch,
    /// When the found camera's evidence is not strong ([`CameraEvidence::strong`]), the rounds after
    /// the first are run again from four starts this far (metres) from it, along the room's two
    /// horizontal axes, and the camera that correlates best is kept. Under a light unlike the
    /// captures' a light's edges can hold the alignment a few centimetres to decimetres from the
    /// camera, and a start on the camera's other side descends to it. 0 (the default) leaves the
    /// camera as found: on the validation suite the cameras came nearer but the objects found from
    /// them fell (docs/experiment-log.md).
    #[serde(default)]
    pub restart_offset: f64,
    /// Tilts tried before each rendered round in six degrees of freedom ([`TiltGrid`]); none by
    /// default: on the validation suite the grid brought some tilted cameras nearer and lost others
    /// (docs/experiment-log.md).
    #[serde(default)]
    pub tilt_grid: TiltGrid,
}

/// Tilts tried before each rendered round that aligns in six degrees of freedom: the round starts
/// from the one whose features correlate best with the keyframe. Gauss–Newton on blurred features
/// does not turn a camera whose tilt is off by more than its finest blur reaches (a levelling from
/// straight edges can be off by a few degrees, and a tilt moves the horizon by about its angle in
/// pixels times width / 360), and a light's edges can hold it there; a grid over the two tilt
/// angles needs no gradient. The grid is in degrees because the error it corrects is an angle,
/// whatever the room or the resolution.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TiltGrid {
    /// Spacing of the grid (degrees).
    pub step_deg: f64,
    /// Steps to each side about each horizontal axis: `(2 · steps + 1)²` tilts, the start's among
    /// them; 0 tries none.
    pub steps: usize,
}

impl Default for TiltGrid {
    /// No grid: 0 steps (1° apart when some are asked for).
    fn default() -> Self {
        Self {
            step_deg: 1.0,
            steps: 0,
        }
    }
}

impl TiltGrid {
    /// The grid's tilts about `at`'s centre (turns about the world's two horizontal axes), `at`
    /// itself first.
    fn around(&self, at: &Pose) -> Vec<Pose> {
        let steps = self.steps as i32;
        let mut tilts = vec![*at];
        for a in -steps..=steps {
            for b in -steps..=steps {
                if (a, b) == (0, 0) {
                    continue;
                }
                let turn = DMat3::from_rotation_x((f64::from(a) * self.step_deg).to_radians())
                    * DMat3::from_rotation_y((f64::from(b) * self.step_deg).to_radians());
                tilts.push(Pose::new(turn * at.rotation, at.translation));
            }
        }
        tilts
    }
}

/// The search again, wider, for a camera that would be said lost ([`CameraEvidence::says_lost`]):
/// under a light the captures never saw, the true place can rank below the heading search's first
/// candidates, and the rendered rounds then refine only wrong places. The trigger is the camera's
/// confidence, not its correlation alone: a wrong place can correlate a little above
/// [`CameraEvidence::weak`] with the room's few edges that line up, and it is then said lost for
/// being weak or ambiguous all the same; the search that would find the camera must run wherever
/// the camera would be reported lost, or the report is its only outcome. Every finalist of the
/// wider search is refined as a fallback is, unless one reaches the strong evidence first, and the
/// camera that correlates better is kept, so a camera already right stays. It costs time only
/// where the camera would otherwise be said lost.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LostSearch {
    /// Candidates of each heading search ([`LocalizeConfig::candidates`]).
    pub candidates: usize,
    /// Finalists refined against rendered keyframes ([`LocalizeConfig::finalists`]).
    pub finalists: usize,
}

impl Default for LostSearch {
    fn default() -> Self {
        Self {
            candidates: 25,
            finalists: 16,
        }
    }
}

impl LostSearch {
    /// Whether this search runs for the camera `found` with `config`: the camera would be said
    /// lost, and this search is wider than the one that found it.
    fn wanted(&self, found: &CameraEstimate, config: &LocalizeConfig) -> bool {
        config.evidence.says_lost(found.confidence) && self.finalists > config.finalists
    }

    /// `config` widened to this search.
    fn widened(&self, config: &LocalizeConfig) -> LocalizeConfig {
        LocalizeConfig {
            candidates: self.candidates.max(config.candidates),
            finalists: self.finalists,
            fallbacks: self.finalists.saturating_sub(1),
            ..config.clone()
        }
    }
}

fn default_level() -> Option<LevelConfig> {
    Some(LevelConfig::default())
}

fn default_fallbacks() -> usize {
    2
}

/// How strong the evidence for a found camera is: the correlation of the aligned features with the
/// empty room rendered there ([`Alignment::score`]) and how much better it is than the best other
/// place the search found. A camera in the right place under a light unlike the captures' still
/// correlates well above `weak`; one in the wrong place correlates only with the room's few edges that
/// happen to line up.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraEvidence {
    /// Correlation at which the evidence is nil.
    pub weak: f64,
    /// Correlation at which it is full.
    pub strong: f64,
    /// Another place (farther than [`CameraEvidence::other_place`] metres or radians) whose first-round
    /// correlation comes within this fraction of the best one's makes the camera ambiguous: its
    /// confidence is halved when the two tie, not at all when they differ by this fraction.
    pub margin: f64,
    /// Distance (metres, and radians of heading) beyond which a finalist counts as another place.
    pub other_place: f64,
    /// Confidence below which the camera is reported as not found reliably.
    pub lost_below: f64,
}

impl Default for CameraEvidence {
    fn default() -> Self {
        Self {
            weak: 0.25,
            strong: 0.5,
            margin: 0.15,
            other_place: 0.5,
            lost_below: 0.5,
        }
    }
}

impl CameraEvidence {
    /// Whether a camera of this `confidence` is reported as not found reliably.
    pub fn says_lost(&self, confidence: f64) -> bool {
        confidence < self.lost_below
    }

    /// The confidence in [0, 1] of a camera whose final correlation is `score`, with the best
    /// first-round correlation `first` and the best first-round correlation of another place
    /// `other` (if any).
    pub fn confidence(&self, score: f64, first: f64, other: Option<f64>) -> f64 {
        let strength = ((score - self.weak) / (self.strong - self.weak)).clamp(0.0, 1.0);
        let distinct = other.map_or(1.0, |o| {
            ((first - o) / (self.margin * first.abs().max(1e-9))).clamp(0.0, 1.0)
        });
        strength * (0.5 + 0.5 * distinct)
    }
}

fn default_distinct() -> f64 {
    0.1
}

fn default_reshade() -> bool {
    true
}

impl Default for LocalizeConfig {
    fn default() -> Self {
        Self {
            yaw_sigma: 1.0,
            yaws_per_entry: 2,
            candidates: 10,
            orientation_softness: 0.5,
            finalists: 8,
            distinct: default_distinct(),
            reshade: default_reshade(),
            coarse: AlignConfig {
                sigmas: vec![4.0, 2.0, 1.0],
                orientation: Some(0.5),
                ..AlignConfig::default()
            },
            fine_widths: vec![128, 256, 256, 512],
            fine: AlignConfig {
                sigmas: vec![2.0, 1.0],
                ..AlignConfig::default()
            },
            render: neuroom_panorama::database::low_resolution_render(),
            fallbacks: default_fallbacks(),
            evidence: CameraEvidence::default(),
            level: default_level(),
            lost_search: LostSearch::default(),
            restart_offset: 0.0,
            tilt_grid: TiltGrid::default(),
        }
    }
}

/// The found camera and how it was found.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CameraEstimate {
    /// The panorama's camera.
    pub camera_to_world: [[f64; 4]; 4],
    /// Feature correlation at the solution (1 = perfect).
    pub score: f64,
    /// Best heading-search correlation.
    pub search_score: f64,
    /// How sure the camera is, in [0, 1] ([`CameraEvidence::confidence`]).
    #[serde(default)]
    pub confidence: f64,
    /// Why the camera may be wrong, when its confidence is below [`CameraEvidence::lost_below`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
    /// The chosen camera's correlation after the first rendered round.
    #[serde(default)]
    pub first_round: f64,
    /// The best correlation of another place ([`CameraEvidence::other_place`] away) in that round,
    /// when one was scored there: how distinct the chosen place is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub other_place: Option<f64>,
    /// Finalists refined past the first round (1, or more when the best one's evidence was weak;
    /// [`LocalizeConfig::fallbacks`]).
    #[serde(default)]
    pub tried: usize,
    /// The tilt (degrees) of the levelling the kept camera was located under: the one found in the
    /// panorama's edges, or 0 when the camera located as taken correlated better ([`localize`]).
    #[serde(default)]
    pub tilt_deg: f64,
    /// Seconds: heading search, coarse alignment, rendered refinement.
    pub seconds: [f64; 3],
}

impl CameraEstimate {
    /// The camera as a pose.
    pub fn pose(&self) -> Pose {
        Pose::from_rows_unchecked(&self.camera_to_world)
    }
}

/// Finds the camera of `panorama` (a full panorama, or a photo on its sphere) in the room whose
/// empty-room scene (no objects) is `scene`, using `db`.
///
/// A panorama whose edges show no tilt (of at least [`LevelConfig::min_tilt_deg`]) is located as
/// taken: the rendered rounds keep the camera upright but for the last, which frees its tilt too. One
/// whose edges show a tilt is located levelled first (the heading search and the coarse alignment
/// assume a level camera) with every rendered round in six degrees of freedom. The levelling is a
/// hypothesis, not a decision: the straight edges of a lamp's pool or a spot's cone vote for a false
/// up as readily as the room's own edges do. So when the levelled camera's evidence is not strong
/// ([`CameraEvidence::strong`], as for [`LocalizeConfig::fallbacks`]), the panorama is located as
/// taken too and the camera that correlates better with the empty room is kept; the final correlation
/// is measured against the panorama as taken in both cases, so it judges the two on the same evidence.
/// A camera that would then be said lost ([`CameraEvidence::says_lost`]) is searched for again,
/// wider ([`LostSearch`]), under the tilt hypothesis that won. `progress` is told each search as it
/// starts ([`LocateStage::Camera`], then [`LocateStage::CameraAsTaken`] and
/// [`LocateStage::CameraWider`] when they run).
pub fn localize<F: Field>(
    scene: &Scene<F>,
    db: &Database,
    panorama: &SphereImage,
    config: &LocalizeConfig,
    progress: &mut dyn FnMut(LocateStage),
) -> Result<CameraEstimate, String> {
    if db.entries.is_empty() {
        return Err("the localization database has no panoramas".into());
    }
    let to_level = levelling(panorama, config);
    let panorama = &panorama.without_clipped();
    let mut locate = |stage: LocateStage, to_level: Option<DMat3>, config: &LocalizeConfig| {
        progress(stage);
        localize_as(scene, db, panorama, to_level, config)
            .map(|estimate| TiltHypothesis { estimate, to_level })
    };
    let kept = match to_level {
        None => locate(LocateStage::Camera, None, config)?,
        Some(to_level) => {
            let levelled = locate(LocateStage::Camera, Some(to_level), config)?;
            if levelled.estimate.score >= config.evidence.strong {
                levelled
            } else {
                locate(LocateStage::CameraAsTaken, None, config)?.or_better(levelled)
            }
        }
    };
    if !config.lost_search.wanted(&kept.estimate, config) {
        return Ok(kept.estimate);
    }
    let widened = locate(
        LocateStage::CameraWider,
        kept.to_level,
        &config.lost_search.widened(config),
    )?;
    Ok(kept.or_better(widened).estimate)
}

/// A camera located under one hypothesis of the panorama's tilt.
struct TiltHypothesis {
    estimate: CameraEstimate,
    /// The levelling it was located under (camera frame → level frame); `None`: as taken.
    to_level: Option<DMat3>,
}

impl TiltHypothesis {
    /// This camera, or `other` where it correlates better with the empty room; either way with the
    /// time of both.
    fn or_better(self, other: TiltHypothesis) -> TiltHypothesis {
        let (mut kept, dropped) = if other.estimate.score > self.estimate.score {
            (other, self)
        } else {
            (self, other)
        };
        for (k, d) in kept
            .estimate
            .seconds
            .iter_mut()
            .zip(dropped.estimate.seconds)
        {
            *k += d;
        }
        kept
    }
}

/// [`localize`] under one hypothesis of the camera's tilt: `to_level` (camera frame → level frame)
/// levels the panorama for the search, `None` takes it as level.
fn localize_as<F: Field>(
    scene: &Scene<F>,
    db: &Database,
    panorama: &SphereImage,
    to_level: Option<DMat3>,
    config: &LocalizeConfig,
) -> Result<CameraEstimate, String> {
    let t0 = Instant::now();
    let levelled = match to_level {
        Some(l) => Some(
            SphereImage::panorama(
                rotate_panorama(&panorama.rgb, &l.transpose()).map_err(|e| e.to_string())?,
            )
            .without_clipped(),
        ),
        None => None,
    };
    let small = levelled
        .as_ref()
        .unwrap_or(panorama)
        .downsample(db.width, db.height);
    let matches = search(db, &small, config);
    let search_score = matches.first().map_or(0.0, |m| m.score);
    let t1 = Instant::now();
    let inside = |a: &Alignment| {
        let t = a.camera_to_world.translation.as_vec3();
        let room = &scene.background;
        t.cmpge(room.bounds_min).all() && t.cmple(room.bounds_max).all()
    };
    let coarse = coarse_candidates(db, &small, &matches, &inside, config);
    // A levelled candidate's camera, turned back into the panorama's own frame.
    let coarse: Vec<Alignment> = coarse
        .into_iter()
        .map(|a| match to_level {
            Some(l) => Alignment {
                camera_to_world: Pose::new(
                    a.camera_to_world.rotation * l,
                    a.camera_to_world.translation,
                ),
                ..a
            },
            None => a,
        })
        .collect();
    let t2 = Instant::now();
    let six_dof = six_dof(config);
    let (first, rest) = config.fine_widths.split_first().unzip();
    let (last, middle) = match rest.and_then(<[usize]>::split_last) {
        Some((last, middle)) => (std::slice::from_ref(last), middle),
        None => (&[][..], &[][..]),
    };
    let early = if to_level.is_some() { &six_dof } else { config };
    // A refinement that leaves the room (a photo of a bare wall can slide off) keeps its start.
    let within = |refined: Alignment, start: &Alignment| {
        if inside(&refined) { refined } else { *start }
    };
    let mut rounds: Vec<Alignment> = coarse
        .par_iter()
        .map(|c| {
            let first = first.map(std::slice::from_ref).unwrap_or(&[]);
            within(refine(scene, panorama, c, first, early), c)
        })
        .collect();
    rounds.sort_by(|a, b| b.score.total_cmp(&a.score));
    let finished = finish(
        &rounds,
        config,
        middle.len(),
        |start, k| within(refine(scene, panorama, start, &middle[k..=k], early), start),
        |halfway| within(refine(scene, panorama, halfway, last, &six_dof), halfway),
    );
    let finished = restarted(finished, config, |start| {
        let rounds = config.fine_widths.get(1..).unwrap_or_default();
        within(refine(scene, panorama, start, rounds, &six_dof), start)
    });
    let t3 = Instant::now();
    let mut estimate = judged(&finished, &rounds, &config.evidence);
    estimate.search_score = search_score;
    estimate.tilt_deg = to_level.map_or(0.0, |l| rotation_angle(&l).to_degrees());
    estimate.seconds = [
        (t1 - t0).as_secs_f64(),
        (t2 - t1).as_secs_f64(),
        (t3 - t2).as_secs_f64(),
    ];
    Ok(estimate)
}

/// The rotation that levels `panorama` (camera frame → level frame), when it is a full panorama whose
/// edges show a tilt of at least [`LevelConfig::min_tilt_deg`].
fn levelling(panorama: &SphereImage, config: &LocalizeConfig) -> Option<DMat3> {
    let level = config.level.as_ref()?;
    if panorama.seen.is_some() {
        return None;
    }
    tilted_up(&panorama.rgb, level).map(leveling)
}

/// The heading search's `matches` aligned to their database panoramas (`small` is the query at the
/// database's size), those that stay in the room (`inside`), distinct, best first; when every one
/// slid out, the search's own database poses.
fn coarse_candidates(
    db: &Database,
    small: &SphereImage,
    matches: &[YawMatch],
    inside: &(dyn Fn(&Alignment) -> bool + Sync),
    config: &LocalizeConfig,
) -> Vec<Alignment> {
    let mut coarse: Vec<Alignment> = matches
        .par_iter()
        .map(|m| {
            let entry = &db.entries[m.entry];
            let keyframe = Keyframe {
                rgb: &entry.rgb,
                depth: &entry.depth,
                camera_to_world: entry.camera_to_world(),
            };
            let init = Pose::from_yaw_translation(m.yaw, entry.position.as_dvec3());
            align(&keyframe, small, &init, &config.coarse)
        })
        .collect();
    coarse.retain(|a| inside(a));
    if coarse.is_empty() {
        coarse = matches
            .iter()
            .map(|m| Alignment {
                camera_to_world: Pose::from_yaw_translation(
                    m.yaw,
                    db.entries[m.entry].position.as_dvec3(),
                ),
                score: m.score,
            })
            .collect();
    }
    coarse.sort_by(|a, b| b.score.total_cmp(&a.score));
    distinct(coarse, config.distinct, config.finalists.max(1))
}

/// The estimate of the `finished` camera, its confidence judged from its correlation and the best
/// other place among the first rendered `rounds` ([`CameraEvidence`]); timings and the search's
/// score are left for the caller.
fn judged(finished: &Finished, rounds: &[Alignment], evidence: &CameraEvidence) -> CameraEstimate {
    let best = finished.best;
    let other = rounds
        .iter()
        .find(|a| !same_place(a, &best, evidence.other_place))
        .map(|a| a.score);
    let confidence = evidence.confidence(best.score, finished.first_round, other);
    let warning = evidence.says_lost(confidence).then(|| {
        let rival = other.map_or(String::new(), |o| {
            format!(
                ", another place correlates {o:.2} against {:.2}",
                finished.first_round
            )
        });
        format!(
            "the camera is not found reliably (confidence {confidence:.2}: correlation {:.2} with \
             the empty room, {} of {} candidates tried{rival}); the arrangement may be turned or moved",
            best.score,
            finished.tried,
            rounds.len(),
        )
    });
    CameraEstimate {
        camera_to_world: best.camera_to_world.to_rows(),
        score: best.score,
        search_score: 0.0,
        confidence,
        warning,
        first_round: finished.first_round,
        other_place: other,
        tried: finished.tried,
        tilt_deg: 0.0,
        seconds: [0.0; 3],
    }
}

/// The angle of rotation `r` (radians).
fn rotation_angle(r: &DMat3) -> f64 {
    ((r.x_axis.x + r.y_axis.y + r.z_axis.z - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
}

/// The best of the finalists refined to the end, and how many were refined past the first round.
struct Finished {
    best: Alignment,
    /// Its correlation after the first rendered round.
    first_round: f64,
    /// Its correlation after each of the middle rounds.
    marks: Vec<f64>,
    tried: usize,
}

/// Refines `rounds` (best first) to the end, through the `middle_rounds` middle rounds (`middle`,
/// given the round's index) and the last (`last`): the best one, then while the best so far
/// correlates below the strong evidence, up to [`LocalizeConfig::fallbacks`] more. A fallback goes
/// on to the next round only while it correlates better than the best so far did after the same
/// round, and so enters the last only when it leads after every middle one: the rounds render
/// keyframes ever wider, most of a finalist's time, and a place behind at the same keyframe width
/// and light is a place the finer edges of the later rounds would have to lift past a better one
/// (each round aligns from where the last left the camera and rarely moves it far).
fn finish(
    rounds: &[Alignment],
    config: &LocalizeConfig,
    middle_rounds: usize,
    middle: impl Fn(&Alignment, usize) -> Alignment,
    last: impl Fn(&Alignment) -> Alignment,
) -> Finished {
    let mut halfway = rounds[0];
    let mut marks = Vec::with_capacity(middle_rounds);
    for k in 0..middle_rounds {
        halfway = middle(&halfway, k);
        marks.push(halfway.score);
    }
    let mut finished = Finished {
        best: last(&halfway),
        first_round: rounds[0].score,
        marks,
        tried: 1,
    };
    for start in rounds.iter().skip(1).take(config.fallbacks) {
        if finished.best.score >= config.evidence.strong {
            break;
        }
        finished.tried += 1;
        let Some(leading) = ahead_through(start, &finished.marks, &middle) else {
            continue;
        };
        let done = last(&leading.halfway);
        if done.score > finished.best.score {
            finished = Finished {
                best: done,
                first_round: start.score,
                marks: leading.marks,
                tried: finished.tried,
            };
        }
    }
    finished
}

/// `finished`, its camera replaced by the best of `refined` from four starts
/// [`LocalizeConfig::restart_offset`] away from it along the room's horizontal axes when one correlates
/// better; left as it is when its evidence is strong or the offset is 0.
fn restarted(
    mut finished: Finished,
    config: &LocalizeConfig,
    refined: impl Fn(&Alignment) -> Alignment + Sync,
) -> Finished {
    let d = config.restart_offset;
    if d <= 0.0 || finished.best.score >= config.evidence.strong {
        return finished;
    }
    let best = finished.best.camera_to_world;
    let starts: Vec<Alignment> = [DVec3::X, -DVec3::X, DVec3::Y, -DVec3::Y]
        .into_iter()
        .map(|axis| Alignment {
            camera_to_world: Pose::new(best.rotation, best.translation + axis * d),
            score: 0.0,
        })
        .collect();
    let ends: Vec<Alignment> = starts.par_iter().map(&refined).collect();
    for end in ends {
        if end.score > finished.best.score {
            finished.best = end;
        }
    }
    finished
}

/// A fallback through the middle rounds, and its correlation after each.
struct Leading {
    halfway: Alignment,
    marks: Vec<f64>,
}

/// `start` through the middle rounds (`middle`) while it correlates better than `best_marks`, the
/// best so far after each; `None` once it does not.
fn ahead_through(
    start: &Alignment,
    best_marks: &[f64],
    middle: &impl Fn(&Alignment, usize) -> Alignment,
) -> Option<Leading> {
    let mut halfway = *start;
    let mut marks = Vec::with_capacity(best_marks.len());
    for (k, &mark) in best_marks.iter().enumerate() {
        halfway = middle(&halfway, k);
        if halfway.score <= mark {
            return None;
        }
        marks.push(halfway.score);
    }
    Some(Leading { halfway, marks })
}

/// Whether two cameras stand within `radius` metres and radians of heading of each other.
fn same_place(a: &Alignment, b: &Alignment, radius: f64) -> bool {
    let (pa, pb) = (&a.camera_to_world, &b.camera_to_world);
    pa.translation.distance(pb.translation) < radius && angle_between(pa.yaw(), pb.yaw()) < radius
}

/// Heading search over the database with two kinds of features: signed log-luminance gradients
/// (discriminative under the lights of the captures) and their orientations (which survive a lighting
/// change that reverses edges); the best `config.candidates` of each, without repeats, best first.
fn search(db: &Database, small: &SphereImage, config: &LocalizeConfig) -> Vec<YawMatch> {
    let kinds: [&dyn Fn(FeatureMap) -> FeatureMap; 2] = [&|f| f.normalized(), &|f| {
        f.orientation(config.orientation_softness).normalized()
    }];
    let mut found: Vec<YawMatch> = Vec::new();
    let seen = small.seen_plane();
    for kind in kinds {
        let query = kind(small.features(config.yaw_sigma));
        let refs: Vec<FeatureMap> = db
            .entries
            .iter()
            .map(|e| {
                let valid: Vec<bool> = e.depth.iter().map(|d| *d > 0.0).collect();
                kind(FeatureMap::masked(&e.rgb, &valid, config.yaw_sigma))
            })
            .collect();
        for m in best_yaws(
            &query,
            seen.as_ref(),
            &refs,
            config.yaws_per_entry,
            config.candidates.max(1),
        ) {
            let repeat = found
                .iter()
                .any(|f| f.entry == m.entry && angle_between(f.yaw, m.yaw) < 0.1);
            if !repeat {
                found.push(m);
            }
        }
    }
    found
}

/// The first `keep` of `sorted` (best first) that are not within `radius` (metres, and radians of
/// heading) of an earlier one.
fn distinct(sorted: Vec<Alignment>, radius: f64, keep: usize) -> Vec<Alignment> {
    let mut out: Vec<Alignment> = Vec::with_capacity(keep);
    for a in sorted {
        if !out.iter().any(|b| same_place(&a, b, radius)) {
            out.push(a);
        }
        if out.len() == keep {
            break;
        }
    }
    out
}

/// Absolute difference of two angles (radians), in [0, π].
fn angle_between(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d)
}

/// The correlation of `panorama` with the empty room rendered at `camera_to_world`, after one round
/// of alignment at the last of [`LocalizeConfig::fine_widths`], as the final round scores a camera:
/// compared between the found camera and the true one, it tells a search that never reached the true
/// place from a correlation that prefers a wrong one.
pub fn camera_correlation<F: Field>(
    scene: &Scene<F>,
    panorama: &SphereImage,
    camera_to_world: &Pose,
    config: &LocalizeConfig,
) -> f64 {
    let start = Alignment {
        camera_to_world: *camera_to_world,
        score: 0.0,
    };
    let last = config.fine_widths.last().copied().unwrap_or(512);
    refine(
        scene,
        &panorama.without_clipped(),
        &start,
        &[last],
        &six_dof(config),
    )
    .score
}

/// `config` with its rendered rounds aligning in six degrees of freedom (the tilt free).
fn six_dof(config: &LocalizeConfig) -> LocalizeConfig {
    LocalizeConfig {
        fine: AlignConfig {
            upright: false,
            ..config.fine.clone()
        },
        ..config.clone()
    }
}

/// Rounds of render-and-align, one per keyframe width.
fn refine<F: Field>(
    scene: &Scene<F>,
    panorama: &SphereImage,
    start: &Alignment,
    widths: &[usize],
    config: &LocalizeConfig,
) -> Alignment {
    let mut current = *start;
    for &width in widths {
        let at = current.camera_to_world;
        let (rgb, depth) = render_background(scene, &at, width, &config.render);
        let query = panorama.downsample(width, width / 2);
        let view = Rendered {
            rgb: &rgb,
            depth: &depth,
            query: &query,
            at,
        };
        current = if config.reshade {
            relit_round(&view, config)
        } else {
            let start = view.start(config);
            view.no_worse(
                view.align(view.rgb, &start, &config.fine),
                &[view.rgb],
                config,
            )
        };
    }
    current
}

/// A keyframe rendered at `at` and the query at its size.
struct Rendered<'a> {
    rgb: &'a RgbImage,
    depth: &'a [f32],
    query: &'a SphereImage,
    at: Pose,
}

impl Rendered<'_> {
    /// Aligns the query to the keyframe's geometry coloured `rgb`, starting at `start`.
    fn align(&self, rgb: &RgbImage, start: &Pose, config: &AlignConfig) -> Alignment {
        let keyframe = Keyframe {
            rgb,
            depth: self.depth,
            camera_to_world: self.at,
        };
        align(&keyframe, self.query, start, config)
    }

    /// Where the round's alignments start: the keyframe's own pose, or, when they free the tilt, the
    /// tilt about it ([`TiltGrid`]) that correlates best with the keyframe as rendered.
    fn start(&self, config: &LocalizeConfig) -> Pose {
        if config.fine.upright || config.tilt_grid.steps == 0 {
            return self.at;
        }
        let keyframe = Keyframe {
            rgb: self.rgb,
            depth: self.depth,
            camera_to_world: self.at,
        };
        let tilts = config.tilt_grid.around(&self.at);
        best_start(&keyframe, self.query, &tilts, &config.fine)
            .map_or(self.at, |best| best.camera_to_world)
    }

    /// `aligned`, or the keyframe's own pose when that correlates better with one of the keyframe's
    /// colourings `rgbs` than `aligned` does: a round never leaves a camera worse than it found it (a
    /// light unlike the captures' can pull the alignment off a pose the room agrees with).
    fn no_worse(
        &self,
        aligned: Alignment,
        rgbs: &[&RgbImage],
        config: &LocalizeConfig,
    ) -> Alignment {
        let held = AlignConfig {
            iterations: 0,
            ..config.fine.clone()
        };
        let before = (rgbs.iter())
            .map(|rgb| self.align(rgb, &self.at, &held).score)
            .fold(f64::NEG_INFINITY, f64::max);
        if before > aligned.score {
            Alignment {
                camera_to_world: self.at,
                score: before,
            }
        } else {
            aligned
        }
    }
}

/// One round against the keyframe as rendered and as re-shaded to the query's light. The re-shaded
/// keyframe explains the query better (its score is the round's: it ranks finalists), but a gain that
/// follows the normal can misplace edges where the light varies along a surface; so the pose is the
/// one of the two whose edge orientations ([`FeatureMap::orientation`], blind to contrast) agree better
/// with the keyframe as rendered. Under a light like the captures' there is no re-shading, and one
/// alignment.
fn relit_round(view: &Rendered, config: &LocalizeConfig) -> Alignment {
    let shaded = match_shading(
        &view.query.rgb,
        view.rgb,
        &view.query.seen_depth(view.depth),
    );
    let start = view.start(config);
    if shaded == *view.rgb {
        let aligned = view.align(view.rgb, &start, &config.fine);
        return view.no_worse(aligned, &[view.rgb], config);
    }
    let aligned = aligned_to_both(view, &shaded, &start, config);
    view.no_worse(aligned, &[view.rgb, &shaded], config)
}

/// The round's alignment from `start` to the plain and the re-shaded keyframe: the pose the one whose
/// edges agree better with the plain keyframe, the score the better one.
fn aligned_to_both(
    view: &Rendered,
    shaded: &RgbImage,
    start: &Pose,
    config: &LocalizeConfig,
) -> Alignment {
    let (plain, relit) = rayon::join(
        || view.align(view.rgb, start, &config.fine),
        || view.align(shaded, start, &config.fine),
    );
    let judge = AlignConfig {
        iterations: 0,
        orientation: Some(config.orientation_softness),
        sigmas: config.fine.sigmas.last().copied().into_iter().collect(),
        ..config.fine.clone()
    };
    let agreement = |a: &Alignment| view.align(view.rgb, &a.camera_to_world, &judge).score;
    let pose = if agreement(&relit) > agreement(&plain) {
        relit.camera_to_world
    } else {
        plain.camera_to_world
    };
    Alignment {
        camera_to_world: pose,
        score: relit.score.max(plain.score),
    }
}

/// Colour and ray depth of `scene` (the empty room: a scene without objects) seen from `camera_to_world`
/// by a `width × width/2` panorama.
pub fn render_background<F: Field>(
    scene: &Scene<F>,
    camera_to_world: &Pose,
    width: usize,
    config: &RenderConfig,
) -> (RgbImage, Vec<f32>) {
    let camera = Equirect {
        width: width as u32,
        height: (width / 2) as u32,
    };
    let (rgb, depth, _) = render_image(scene, &camera, camera_to_world, config);
    (rgb, depth.data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::cell::RefCell;

    /// A finalist at `x` metres along the room's x axis with first-round correlation `score`.
    fn finalist(x: f64, score: f64) -> Alignment {
        Alignment {
            camera_to_world: Pose::from_yaw_translation(0.0, DVec3::new(x, 0.0, 0.0)),
            score,
        }
    }

    /// `start` given the correlation `scores[x]` of its place, where it stands.
    fn scored(start: &Alignment, scores: &[f64]) -> Alignment {
        let x = start.camera_to_world.translation.x as usize;
        Alignment {
            score: scores[x],
            ..*start
        }
    }

    /// Runs [`finish`] on three finalists whose correlations after one middle round and after the
    /// last are given per place; returns it and the places that entered the last round.
    fn finish_three(halfway: [f64; 3], end: [f64; 3]) -> (Finished, Vec<usize>) {
        finish_three_through(&[halfway], end).0
    }

    /// [`finish_three`] through a middle round per entry of `middle` (each place's correlation
    /// after it); also the places that entered each middle round.
    fn finish_three_through(
        middle: &[[f64; 3]],
        end: [f64; 3],
    ) -> ((Finished, Vec<usize>), Vec<Vec<usize>>) {
        let rounds = [finalist(0.0, 0.4), finalist(1.0, 0.35), finalist(2.0, 0.3)];
        let finished_places = RefCell::new(Vec::new());
        let entered = RefCell::new(vec![Vec::new(); middle.len()]);
        let finished = finish(
            &rounds,
            &LocalizeConfig::default(),
            middle.len(),
            |start, k| {
                entered.borrow_mut()[k].push(start.camera_to_world.translation.x as usize);
                scored(start, &middle[k])
            },
            |start| {
                let done = scored(start, &end);
                finished_places
                    .borrow_mut()
                    .push(start.camera_to_world.translation.x as usize);
                done
            },
        );
        (
            (finished, finished_places.into_inner()),
            entered.into_inner(),
        )
    }

    /// A finished camera at the origin with final correlation `score`.
    fn finished_at_origin(score: f64) -> Finished {
        Finished {
            best: finalist(0.0, score),
            first_round: score,
            marks: Vec::new(),
            tried: 1,
        }
    }

    #[test]
    fn a_restart_that_correlates_better_replaces_the_camera() {
        let config = LocalizeConfig {
            restart_offset: 0.15,
            ..LocalizeConfig::default()
        };
        // Only the start on the +x side reaches the camera (at x = 0.2) and correlates better.
        let refined = |start: &Alignment| {
            let x = start.camera_to_world.translation.x;
            if x > 0.1 {
                finalist(0.2, 0.45)
            } else {
                Alignment {
                    score: 0.3,
                    ..*start
                }
            }
        };
        let finished = restarted(finished_at_origin(0.4), &config, refined);
        assert_eq!(finished.best.camera_to_world.translation.x, 0.2);
        assert_eq!(finished.best.score, 0.45);
        assert_eq!(
            finished.first_round, 0.4,
            "the first round's evidence stays"
        );
    }

    #[test]
    fn strong_evidence_or_no_offset_tries_no_restart() {
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let refined = |start: &Alignment| {
            calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            Alignment {
                score: 0.99,
                ..*start
            }
        };
        let on = LocalizeConfig {
            restart_offset: 0.15,
            ..LocalizeConfig::default()
        };
        let strong = restarted(finished_at_origin(0.6), &on, refined);
        let off = restarted(finished_at_origin(0.3), &LocalizeConfig::default(), refined);
        assert_eq!((strong.best.score, off.best.score), (0.6, 0.3));
        assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 0);
        restarted(finished_at_origin(0.3), &on, refined);
        assert_eq!(calls.load(std::sync::atomic::Ordering::Relaxed), 4);
    }

    #[test]
    fn a_fallback_behind_halfway_skips_the_last_round() {
        let (finished, last) = finish_three([0.30, 0.25, 0.45], [0.35, 0.9, 0.48]);
        assert_eq!(last, vec![0, 2], "place 1 trails place 0 halfway");
        assert_eq!(finished.tried, 3);
        assert_eq!(finished.best.camera_to_world.translation.x, 2.0);
        assert_eq!(
            (finished.first_round, finished.marks.clone()),
            (0.3, vec![0.45])
        );
    }

    #[test]
    fn a_fallback_ahead_halfway_but_behind_at_the_end_loses() {
        let (finished, last) = finish_three([0.30, 0.32, 0.25], [0.35, 0.33, 0.9]);
        assert_eq!(last, vec![0, 1]);
        assert_eq!(finished.best.camera_to_world.translation.x, 0.0);
        assert_eq!(
            finished.marks,
            vec![0.30],
            "place 2 is judged against the kept place"
        );
    }

    #[test]
    fn the_tilt_grid_turns_about_the_horizontal_axes_only() {
        let at = Pose::from_yaw_translation(0.7, DVec3::new(1.0, 2.0, 1.5));
        let grid = TiltGrid {
            step_deg: 1.5,
            steps: 2,
        };
        let tilts = grid.around(&at);
        assert_eq!(tilts.len(), 25);
        assert_eq!(tilts[0], at);
        let mut ups: Vec<DVec3> = Vec::new();
        for t in &tilts {
            assert_eq!(t.translation, at.translation);
            let up = t.rotation * DVec3::Z;
            let tilt = up.angle_between(DVec3::Z).to_degrees();
            assert!(tilt < 1.5 * 2.0 * 2f64.sqrt() + 1e-9, "{tilt}");
            assert!(
                ups.iter()
                    .all(|u| u.angle_between(up) > 1.0f64.to_radians())
            );
            ups.push(up);
        }
        let none = TiltGrid { steps: 0, ..grid };
        assert_eq!(none.around(&at), vec![at]);
    }

    /// The judged estimate of a camera at the origin that correlates `score`, with another place
    /// 3 m away that correlated `other` in the first round, if any.
    fn estimate_judged(score: f64, other: Option<f64>) -> CameraEstimate {
        let mut rounds = vec![finalist(0.0, score)];
        rounds.extend(other.map(|o| finalist(3.0, o)));
        judged(
            &finished_at_origin(score),
            &rounds,
            &CameraEvidence::default(),
        )
    }

    #[test]
    fn a_camera_said_lost_gets_the_wider_search_even_above_weak() {
        let config = LocalizeConfig::default();
        let lost = &config.lost_search;
        // Above `weak`, but another place correlates as well: said lost, so searched again.
        let ambiguous = estimate_judged(0.3, Some(0.3));
        assert!(ambiguous.score > config.evidence.weak);
        assert!(ambiguous.warning.is_some());
        assert!(lost.wanted(&ambiguous, &config));
        // Strong and distinct: neither said lost nor searched again.
        let sure = estimate_judged(0.6, Some(0.3));
        assert!(sure.warning.is_none());
        assert!(!lost.wanted(&sure, &config));
        // A search no wider than the first one is not run again.
        let narrow = LostSearch {
            finalists: config.finalists,
            ..LostSearch::default()
        };
        assert!(!narrow.wanted(&ambiguous, &config));
    }

    #[test]
    fn strong_evidence_tries_no_fallback() {
        let (finished, last) = finish_three([0.30, 0.9, 0.9], [0.6, 0.9, 0.9]);
        assert_eq!((finished.tried, last), (1, vec![0]));
    }

    #[test]
    fn a_fallback_behind_after_a_middle_round_skips_the_rounds_after_it() {
        // Place 1 trails place 0 after the first middle round: it renders no more. Place 2 leads
        // after both and wins.
        let ((finished, last), entered) =
            finish_three_through(&[[0.30, 0.25, 0.35], [0.32, 0.9, 0.40]], [0.35, 0.9, 0.48]);
        assert_eq!(entered, vec![vec![0, 1, 2], vec![0, 2]]);
        assert_eq!(last, vec![0, 2]);
        assert_eq!(finished.best.camera_to_world.translation.x, 2.0);
        assert_eq!(finished.marks, vec![0.35, 0.40]);
    }
}

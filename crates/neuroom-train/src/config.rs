//! Training configuration, with the defaults stated in the code (see [`TrainConfig::default`]).

use crate::augment::vendored_env_maps;
use crate::losses::LossWeights;
use crate::ray_choice::RayChoice;
use neuroom_core::formats::DepthNoise;
use neuroom_field::kernel::Precision;
use neuroom_field::{Group, NUM_GROUPS};
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// Default steps of an object model. The held-out quality of 5 minutes of training is reached
/// within a run's spread after 1 500–2 000 steps (docs/benchmarks.md, "Training"); the validation
/// suite measures locate with models of these budgets.
pub const OBJECT_STEPS: u64 = 2_000;
/// Default steps of the room's model: past its quality of 10 minutes of training after 1 500 steps;
/// the validation suite's budget.
pub const BACKGROUND_STEPS: u64 = 3_000;
/// The most steps of a model given a time budget alone: a ceiling no budget of hours reaches on a CPU,
/// so the time, not the steps, ends the run.
pub const TIME_BUDGET_MAX_STEPS: u64 = 1_000_000;

/// How long and how a model trains: what differs between objects and the room.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelBudget {
    /// Most optimisation steps.
    pub steps: u64,
    /// Wall-clock budget in seconds (data loading excluded); the step count is then fitted to it during
    /// the run (at most `steps`), so the learning-rate decay still ends on time.
    pub time_budget_s: Option<f64>,
    /// Rays per step.
    pub batch_rays: usize,
    /// Samples in the shell around the observed surface, per ray.
    pub shell_samples: usize,
    /// Samples spread over the ray's span in the box, per ray (all samples of a ray without depth).
    pub uniform_samples: usize,
    /// log2 of the hash table size of the field.
    pub log2_table: u32,
    /// Finest hash-grid resolution of the field.
    pub finest_resolution: usize,
    /// Near-surface SDF band half-width, as a fraction of the box diagonal.
    pub sdf_band: f32,
    /// Smallest shell half-width, as a fraction of the box diagonal (the shell is `5 / (inv_s · |n · d|)`
    /// wide otherwise — wider for grazing rays — capped at 10 % of the diagonal).
    pub shell_min: f32,
}

/// The clock a time budget is counted on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum BudgetClock {
    /// Wall-clock seconds.
    #[default]
    Wall,
    /// CPU seconds of the process divided by its worker threads: a budget other programs on the machine
    /// do not shrink. It is not the idle wall clock: threads that wait for each other use no CPU, so the
    /// same number of seconds runs more steps than on an idle machine (about 1.5× measured here).
    Cpu,
}

/// The surface an object's SDF starts from, before any step (the analytic base the network adds to).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum ObjectStart {
    /// A box of [`START_INSET`] × the object's half extents (room.json `size`): the object's known
    /// extent, whatever its shape. A tall bookcase or a wide bed starts where it stands.
    #[default]
    Box,
    /// A sphere of radius [`START_INSET`] × the smallest half extent. It fits a round object; in a tall
    /// or flat one it covers a small part of what the captures see, and the colour network of a
    /// bookcase 1.9 m high learnt nothing in 2 000 steps (held-out PSNR 15 dB against 24 dB from the box).
    Sphere,
}

/// How far inside the object's box its starting surface lies, as a fraction of each half extent: inside,
/// so that rays meet it where the object is, and training grows it to the surfaces the depth shows.
pub const START_INSET: f32 = 0.8;

/// Everything [`crate::room::train_room`] and [`crate::trainer::Trainer`] need to know.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Object models.
    pub object: ModelBudget,
    /// The background (room) model.
    pub background: ModelBudget,
    /// Fraction of an object batch drawn from empty rays.
    pub empty_fraction: f32,
    /// Loss weights.
    pub weights: LossWeights,
    /// Eikonal points per step: every `eikonal_stride`-th sample of the batch.
    pub eikonal_stride: usize,
    /// Learning rates per parameter group (hash, SDF network, colour network, appearance, light, object
    /// codes, variance).
    pub learning_rates: [f32; NUM_GROUPS],
    /// Warm-up steps of the learning rate.
    pub warmup_steps: u64,
    /// Exponent of the polynomial decay `(1 − step / total)^power`.
    pub decay_power: f32,
    /// Smallest learning-rate multiplier of the decay.
    pub decay_floor: f32,
    /// Hash levels active at step 0 (coarse-to-fine).
    pub start_levels: usize,
    /// Steps before the next hash level turns on.
    pub steps_per_level: u64,
    /// Every `holdout`-th frame is held out for evaluation (0 = none).
    pub holdout: usize,
    /// Steps between checkpoints (0 = only at the end).
    pub checkpoint_every: u64,
    /// Environment maps of the lighting augmentation (one light code each).
    pub env_maps: Vec<PathBuf>,
    /// Fraction of surface rays re-lit by a random augmentation map.
    pub augment_fraction: f32,
    /// One appearance code per training frame (else one shared code: captures under constant light).
    pub appearance_per_frame: bool,
    /// Seed of sampling and initialisation.
    pub seed: u64,
    /// Worker threads (0 = rayon's default). A model's gradients do not depend on it, so neither do the
    /// models trained with step budgets.
    pub threads: usize,
    /// How many of a room's models train at once, each on its share of the threads (0 = one per thread
    /// while models are left; see [`crate::lanes`]). Not part of a model: it changes when models are
    /// ready, not what they hold, so it is not serialised.
    #[serde(skip)]
    pub models_at_once: usize,
    /// The clock of the time budgets.
    #[serde(default)]
    pub budget_clock: BudgetClock,
    /// The surface object models start from.
    #[serde(default)]
    pub object_start: ObjectStart,
    /// Per-frame colour gains and pose corrections learned with the field (phone captures). Left out of
    /// the serialised form while it is the default, so configurations written before it keep their
    /// bytes (the validation suite's model cache is keyed by them).
    #[serde(default, skip_serializing_if = "FrameRefinement::is_default")]
    pub frame_refinement: FrameRefinement,
    /// Arithmetic of the fields' network products; stored in each model's field configuration, so the
    /// model renders in the arithmetic it was trained in. Left out while `f32`, as above.
    #[serde(default, skip_serializing_if = "Precision::is_f32")]
    pub mlp_precision: Precision,
    /// How a step chooses its surface rays (uniformly, or guided by the colour error). Left out while
    /// uniform, as above.
    #[serde(default, skip_serializing_if = "RayChoice::is_uniform")]
    pub ray_choice: RayChoice,
    /// Where a surface ray that has no observed depth (a phone's dropped edge samples, a hole) is
    /// sampled. Left out while the default, as above: the default changes only captures that
    /// declare their depth noise, and the suite's cache keys of those add it.
    #[serde(default, skip_serializing_if = "UnobservedSamples::is_default")]
    pub unobserved_samples: UnobservedSamples,
}

/// How the samples of a surface ray without observed depth are placed.
///
/// Spread evenly over the ray, a few samples centimetres apart rarely land inside a thin part (a
/// stool's leg, a rim), and to render the mask's opacity the field grows until they do: a phone's
/// LiDAR drops its samples along every silhouette and on thin parts, and every object trained on
/// such depth came out fat. At the model's surface, the ray's SDF is probed at evenly spaced points
/// first and its shell put where the model's current surface crosses it (the first sign change of
/// the SDF, or where the SDF is least when none does), as NeuS's up-sampling and instant-ngp's
/// occupancy grid put samples where the model has its surface. The model's surface only guides the
/// samples; it is never a depth target. It also gives whatever surface the model has in front (its
/// starting box, a floater) the samples that keep it there, so exact captures, whose every surface
/// ray has depth but for a rare pixel, keep the even spread (experiment log, 2026-12-07).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum UnobservedSamples {
    /// At the model's surface for a capture that declares its depth noise (`depth_noise`: a
    /// phone's), stratified for the others.
    #[default]
    FromCapture,
    /// Stratified over the whole ray.
    Stratified,
    /// A shell around the model's surface, found by this many SDF probes along the ray.
    ModelSurface {
        /// Evenly spaced SDF evaluations along the ray.
        probes: usize,
    },
}

/// SDF probes along a depthless surface ray of a capture with declared depth noise
/// ([`UnobservedSamples::FromCapture`]): a probe every few centimetres over an object's box.
pub const CAPTURE_PROBES: usize = 32;

impl UnobservedSamples {
    /// Whether this is the default (then it is not serialised).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// The probes along each depthless surface ray of a capture whose depth noise is
    /// `depth_noise` (`None`: exact depth); `None` when such rays are spread evenly.
    pub fn probes(&self, depth_noise: Option<DepthNoise>) -> Option<usize> {
        match *self {
            Self::FromCapture => depth_noise.map(|_| CAPTURE_PROBES),
            Self::Stratified => None,
            Self::ModelSurface { probes } => Some(probes),
        }
    }
}

/// Which frame corrections a model learns.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum RefineWhen {
    /// What the capture says its camera did (`auto_exposure`, `tracked_poses` in transforms.json).
    #[default]
    FromCapture,
    /// Both, whatever the capture says.
    Always,
    /// Neither: every frame as the capture gives it.
    Never,
}

/// How per-frame corrections are learned ([`crate::frame_corrections`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameRefinement {
    /// Which corrections are learned.
    pub when: RefineWhen,
    /// Adam's rate of the pose corrections (radians and metres).
    pub pose_lr: f32,
    /// Adam's rate of the log colour gains.
    pub gain_lr: f32,
    /// Fraction of the run before the poses move (0: from the first step). Held back, the field
    /// first learns the frames' disagreement as blur and the poses start from that; moved from the
    /// start at a low rate, they settle with the surfaces.
    pub pose_start: f32,
    /// Whether the rays that miss the object (their opacity and free-space terms) move the poses
    /// too: a frame's silhouette. A frame whose depth sees a wide flat face is otherwise held along
    /// it by the colour's edges alone; its outline pins it there. On the five rooms' phone copies
    /// it brought the frames nearer the truth on most objects and raised their held-out PSNR
    /// (experiment log, 2026-12-08). Always serialised, so the suite's cache keys of corrected
    /// rooms change with it; a configuration written while it was off and left out reads as off.
    #[serde(default)]
    pub silhouettes: bool,
    /// How strongly each pose correction is pulled back towards the tracker's pose (per metre and
    /// per radian; 0: not at all). A tracker is right to about a centimetre, and a frame whose depth
    /// sees a wide flat face is free to slide along it, held only by the colour's edges: without
    /// the pull, the playroom shelves' frames slid farther from the truth than the tracker left
    /// them. At 0.1 it brought every phone model's frames nearer the truth and cost the kitchen's
    /// locate (experiment log, 2026-12-07), so it is an option, off. Left out of the serialised
    /// form while 0, so the suite's cache keys of corrected rooms keep their bytes.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub pose_prior: f32,
    /// The channel level (sRGB, 0–1) at or above which a frame with its own exposure reads as
    /// clipped at white; 1 or more: none does. A clipped channel says its surface is at least
    /// that bright, not that bright, so the colour loss scores it as a lower bound: once a
    /// frame's gain is divided out, its clipped highlights would otherwise say the surface is
    /// darker in every frame exposed brighter, and pull the model's colour down there. A
    /// camera of fixed exposure clips every frame alike, which the model matches as it is, so
    /// only frames with a learned gain take the bound.
    #[serde(default = "default_clipped_white")]
    pub clipped_white: f32,
}

/// Default [`FrameRefinement::clipped_white`]: 250 of an 8-bit channel's 255. A phone's tone
/// curve bends its highlights towards white and its JPEG scatters a clipped patch a few levels
/// below 255, so the bound starts a little below it.
fn default_clipped_white() -> f32 {
    250.0 / 255.0
}

impl Default for FrameRefinement {
    /// Poses at 1e-4 (0.1 mm or 0.1 mrad per step at most), gains at 5e-3, poses from the first step.
    /// Adam moves a parameter by about its rate every step whatever the size of its gradient, so a
    /// direction the data barely pins (a frame sliding along a flat face it sees) walks at random by
    /// about `rate · √(steps / 3)` under the schedule's decay: at 3e-4 that was a centimetre over a
    /// model's 2 000 steps, as large as the tracker's error, and some objects' frames ended farther
    /// from the truth than the tracker left them. A tracker's centimetres are still crossed in a few
    /// hundred steps (docs/experiment-log.md, 2026-12-07).
    fn default() -> Self {
        Self {
            when: RefineWhen::FromCapture,
            pose_lr: 1e-4,
            gain_lr: 5e-3,
            pose_start: 0.0,
            silhouettes: true,
            pose_prior: 0.0,
            clipped_white: default_clipped_white(),
        }
    }
}

/// Whether `x` is 0 (then it is not serialised).
fn is_zero(x: &f32) -> bool {
    *x == 0.0
}

impl FrameRefinement {
    /// Whether this is the default (then it is not serialised).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

impl TrainConfig {
    /// The budget of a kind of model.
    pub fn budget(&self, kind: crate::ModelKind) -> &ModelBudget {
        match kind {
            crate::ModelKind::Object => &self.object,
            crate::ModelKind::Background => &self.background,
        }
    }

    /// The lanes of a room's training ([`TrainConfig::models_at_once`]): one when a time budget is set,
    /// so that each model has the whole machine for the seconds it was given.
    pub fn lanes(&self) -> usize {
        let timed = self.object.time_budget_s.is_some() || self.background.time_budget_s.is_some();
        if timed { 1 } else { self.models_at_once }
    }
}

impl Default for TrainConfig {
    /// Budgets in steps, so the same configuration gives the same models on any machine and load:
    /// objects [`OBJECT_STEPS`], 2 048 rays × (12 shell + 4 uniform) samples, T = 2^15, finest 512; the
    /// room [`BACKGROUND_STEPS`], 2 048 rays, T = 2^18, finest 1 024. Adam at 1e-2 (tables, codes),
    /// 5e-3 (networks), 1e-2 (variance), 20 warm-up steps, then linear decay to 3 %; 4 hash levels at first and one more every 40 steps; every 10th frame held out;
    /// the vendored HDR maps for augmentation, 30 % of surface rays re-lit.
    fn default() -> Self {
        let mut lr = [0.0; NUM_GROUPS];
        lr[Group::Hash as usize] = 1e-2;
        lr[Group::SdfMlp as usize] = 5e-3;
        lr[Group::ColorMlp as usize] = 5e-3;
        lr[Group::Appearance as usize] = 1e-2;
        lr[Group::Light as usize] = 1e-2;
        lr[Group::Object as usize] = 1e-2;
        lr[Group::Variance as usize] = 1e-2;
        Self {
            object: ModelBudget {
                steps: OBJECT_STEPS,
                time_budget_s: None,
                batch_rays: 2048,
                shell_samples: 12,
                uniform_samples: 4,
                log2_table: 15,
                finest_resolution: 512,
                sdf_band: 0.02,
                shell_min: 0.01,
            },
            background: ModelBudget {
                steps: BACKGROUND_STEPS,
                time_budget_s: None,
                batch_rays: 2048,
                shell_samples: 24,
                uniform_samples: 8,
                log2_table: 18,
                finest_resolution: 1024,
                sdf_band: 0.01,
                shell_min: 0.003,
            },
            empty_fraction: 0.25,
            weights: LossWeights::default(),
            eikonal_stride: 32,
            learning_rates: lr,
            warmup_steps: 20,
            decay_power: 1.0,
            decay_floor: 0.03,
            start_levels: 4,
            steps_per_level: 40,
            holdout: 10,
            checkpoint_every: 250,
            env_maps: vendored_env_maps(),
            augment_fraction: 0.3,
            appearance_per_frame: false,
            seed: 1,
            threads: 0,
            models_at_once: 0,
            budget_clock: BudgetClock::Wall,
            object_start: ObjectStart::Box,
            frame_refinement: FrameRefinement::default(),
            mlp_precision: Precision::F32,
            ray_choice: RayChoice::default(),
            unobserved_samples: UnobservedSamples::default(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depthless_rays_probe_the_model_only_where_the_capture_declares_noise() {
        let phone = Some(DepthNoise::PHONE_LIDAR);
        let default = UnobservedSamples::default();
        assert_eq!(default.probes(phone), Some(CAPTURE_PROBES));
        assert_eq!(default.probes(None), None);
        assert_eq!(UnobservedSamples::Stratified.probes(phone), None);
        let always = UnobservedSamples::ModelSurface { probes: 8 };
        assert_eq!(always.probes(None), Some(8));
        let json = serde_json::to_string(&TrainConfig::default()).unwrap();
        assert!(
            !json.contains("unobserved_samples"),
            "the default is left out"
        );
    }

    /// A frame refinement as written before the silhouettes and the clipped bound had keys.
    const WRITTEN_BEFORE: &str =
        r#"{"when":"FromCapture","pose_lr":1e-4,"gain_lr":5e-3,"pose_start":0.0}"#;

    #[test]
    fn a_frame_refinement_written_before_the_clipped_bound_reads_with_it() {
        let read: FrameRefinement = serde_json::from_str(WRITTEN_BEFORE).unwrap();
        assert_eq!(read.clipped_white, FrameRefinement::default().clipped_white);
        let json = serde_json::to_string(&FrameRefinement::default()).unwrap();
        assert!(json.contains("clipped_white"), "cache keys see the bound");
    }

    #[test]
    fn a_frame_refinement_written_while_silhouettes_were_off_reads_them_off() {
        let read: FrameRefinement = serde_json::from_str(WRITTEN_BEFORE).unwrap();
        assert!(!read.silhouettes);
        assert!(FrameRefinement::default().silhouettes);
        let json = serde_json::to_string(&FrameRefinement::default()).unwrap();
        assert!(
            json.contains("\"silhouettes\":true"),
            "cache keys see the silhouettes"
        );
    }
}

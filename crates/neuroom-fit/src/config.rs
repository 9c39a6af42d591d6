//! Settings of the holistic fit: sampling, schedule, learning rates, loss weights and ablation switches.

use crate::relations::RelationRules;
use crate::search::PoseSearchConfig;
use neuroom_render::RenderConfig;
use serde::{Deserialize, Serialize};

/// Weights of the losses (the paper: λ_pho = 1, λ_obs = 100, λ_phy = 1 for each physical term).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitLossWeights {
    /// Photometric (mean squared colour error over the sampled rays).
    pub photometric: f32,
    /// Observation (1 − cos of the viewing direction, per object).
    pub observation: f32,
    /// Magnetic (squared gap of each relation's contact).
    pub magnetic: f32,
    /// Violation (squared hinge on SDF < ε at surface points).
    pub violation: f32,
    /// Gravity (1 − cos of an upright object's tilt).
    pub gravity: f32,
    /// Wall alignment (1 − cos of the angle between a back joined to a wall and that wall).
    pub alignment: f32,
}

impl Default for FitLossWeights {
    fn default() -> Self {
        Self {
            photometric: 1.0,
            observation: 100.0,
            magnetic: 1.0,
            violation: 1.0,
            gravity: 1.0,
            alignment: 1.0,
        }
    }
}

/// Which losses take part, for the paper's ablation table.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LossSwitches {
    /// The photometric loss (joint rendering).
    pub photometric: bool,
    /// The observation loss.
    pub observation: bool,
    /// Magnetic, violation and gravity losses.
    pub physical: bool,
}

impl Default for LossSwitches {
    fn default() -> Self {
        Self {
            photometric: true,
            observation: true,
            physical: true,
        }
    }
}

/// What the second stage adapts to the panorama's lighting.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct AdaptSwitches {
    /// Per-object and background tone adjusters.
    pub tone: bool,
    /// Light and appearance code rows of the models.
    pub codes: bool,
}

impl Default for AdaptSwitches {
    fn default() -> Self {
        Self {
            tone: true,
            codes: true,
        }
    }
}

/// Everything a fit needs besides its inputs.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitConfig {
    /// Rays on the objects per iteration (N).
    pub rays: usize,
    /// Rays on the background per iteration, as a fraction of `rays` (the paper: 0.2).
    pub background_fraction: f32,
    /// Stage 1: iterations on the poses.
    pub pose_iterations: usize,
    /// Stage 2: iterations on light codes, appearance codes and tone adjusters, poses frozen.
    pub appearance_iterations: usize,
    /// Adam rate of translations (metres).
    pub lr_translation: f32,
    /// Adam rate of the 6D rotation components.
    pub lr_rotation: f32,
    /// Factor the pose rates fall to, exponentially, by the end of stage 1 (1: constant rates). On the
    /// analytic room of five cuboids, 200 and 300 iterations converge as well or better at constant
    /// rates; on trained rooms the photometric gradient is noisy, Adam turns it into steps of the full
    /// rate, and constant rates leave objects wandering by centimetres: the default falls to 0.1.
    pub lr_final_factor: f32,
    /// Adam rate of tone shifts and scales.
    pub lr_tone: f32,
    /// Adam rate of light and appearance code rows.
    pub lr_codes: f32,
    /// Loss weights.
    pub weights: FitLossWeights,
    /// Ablation switches.
    pub losses: LossSwitches,
    /// Render-and-compare search of each object's horizontal position and yaw before stage 1 (`None`:
    /// gradient descent only).
    pub search: Option<PoseSearchConfig>,
    /// Adapt the tone adjusters during stage 1 as well, so that a change of lighting is explained by
    /// colour rather than by moving objects (on trained rooms lit differently from their captures the
    /// photometric gradient otherwise drags objects away from their true poses).
    pub tone_in_pose_stage: bool,
    /// What stage 2 adapts (the paper's Table 2: none, tone only, light code only, both).
    pub adapt: AdaptSwitches,
    /// Keep objects flagged upright exactly upright: their rotation is projected onto yaw-only after each
    /// step (the gravity loss is then zero); off, only the gravity loss holds them. On by default: on the
    /// analytic room of five cuboids (3 seeds of the benchmark noise) it gives 0.13 cm / 0.09° mean
    /// APE / ARE against 0.25 cm / 0.23° with the gravity loss alone.
    pub yaw_only_upright: bool,
    /// Angle (degrees) an object's viewing direction may turn from its initial one before the
    /// observation loss acts (0: the paper's loss; see [`crate::observation`]).
    pub observation_tolerance_deg: f32,
    /// Margin of the violation loss (metres; the paper: 0.025).
    pub epsilon: f32,
    /// Gap (metres) a back joined to a wall may keep from it before the magnetic loss pulls (0: the
    /// paper's loss, which pulls it onto the wall).
    pub wall_gap: f32,
    /// Iterations between regenerations of relations and of the object mask.
    pub relation_interval: usize,
    /// Rules of relation generation.
    pub rules: RelationRules,
    /// Surface points per object for the physical losses.
    pub surface_points: usize,
    /// Half-width of the mask dilation window (2: 5×5).
    pub mask_dilation: usize,
    /// Seed of ray and surface sampling.
    pub seed: u64,
    /// Height of the before/after preview renders (width twice that); `None` renders none.
    pub preview_height: Option<u32>,
    /// The renderer's settings.
    pub render: RenderConfig,
}

impl FitConfig {
    /// Settings for initial poses that are already close, as `neuroom locate` gives them: no search
    /// (locate has searched) and pose rates a fifth of the default, so that the photometric gradient
    /// of a relit panorama refines the poses rather than drags them. Measured on the `studio` demo
    /// room (IoU of the initial poses 75.0 %): 78.3 % after this fit, 58.1 % after the default one;
    /// on a `bedroom` panorama (67.4 %): 62.0 % and 51.0 %.
    pub fn refinement() -> Self {
        Self {
            search: None,
            lr_translation: 2e-3,
            lr_rotation: 2e-3,
            ..Self::default()
        }
    }
}

impl Default for FitConfig {
    fn default() -> Self {
        Self {
            rays: 1024,
            background_fraction: 0.2,
            pose_iterations: 300,
            appearance_iterations: 100,
            lr_translation: 1e-2,
            lr_rotation: 1e-2,
            lr_final_factor: 0.1,
            lr_tone: 1e-2,
            lr_codes: 1e-2,
            weights: FitLossWeights::default(),
            losses: LossSwitches::default(),
            adapt: AdaptSwitches::default(),
            tone_in_pose_stage: true,
            search: Some(PoseSearchConfig::default()),
            yaw_only_upright: true,
            observation_tolerance_deg: 10.0,
            epsilon: 0.025,
            wall_gap: 0.04,
            relation_interval: 50,
            rules: RelationRules::default(),
            surface_points: 256,
            mask_dilation: 2,
            seed: 0,
            preview_height: Some(128),
            render: RenderConfig::default(),
        }
    }
}

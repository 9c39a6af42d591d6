//! The training loop of one model: mini-batches of rays, depth-guided sampling, the losses of
//! [`crate::losses`], coarse-to-fine hash levels, Adam with polynomial decay, and resumable checkpoints.
//!
//! One step: draw `batch_rays` rays (a fixed fraction from empty rays for objects; a fraction of surface
//! rays re-lit by an augmentation map with that map's light code), place samples along each (most in a shell
//! around the observed distance, a few spread over the ray's span in the model's box; rays without depth
//! spread all), query the field at every sample in parallel chunks, render and score each ray, add the SDF
//! terms of every sample, back-propagate, add the eikonal term on a subset of samples, and take an Adam step.
//!
//! Determinism: all random draws come from one [`Pcg32`] in a fixed order, and the field's parallel
//! reductions are ordered, so a run is reproducible for a given thread count; a checkpoint stores the step,
//! the generator, Adam's moments and the fitted step count, and resuming continues bit for bit.

use crate::augment::Augmentation;
use crate::config::{BudgetClock, ModelBudget, ObjectStart, RefineWhen, START_INSET, TrainConfig};
use crate::dataset::{Aabb, Dataset};
use crate::draws::{
    RayPlan, SampleCounts, SampleRows, near_band, probe_distances, surface_from_probes,
    write_samples,
};
use crate::frame_corrections::{Corrected, FrameAnchor, FrameCorrections};
use crate::losses::{LossParts, RayScales, RayTarget, SampleZone, ray_loss, sdf_loss};
use crate::progress::Progress;
use crate::ray_choice::ErrorMap;
use crate::rng::Pcg32;
use crate::room::TrainError;
use glam::Vec3;
use neuroom_core::formats::DepthNoise;
use neuroom_field::checkpoint::{self, CheckpointError};
use neuroom_field::clock::process_cpu_seconds;
use neuroom_field::health::{Health, MAX_FAULTS_IN_A_ROW};
use neuroom_field::{
    Adam, AdamConfig, CodeSet, Codes, NUM_GROUPS, NeusConfig, NeusField, Outputs, Params, Schedule,
    Tape,
};
use neuroom_render::volume::{RayTape, render_ray, render_ray_backward};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::time::Instant;

/// Steps timed before a time budget first fits the total step count.
const CALIBRATION_STEPS: u64 = 8;

/// Steps between later fits (the machine's load may change during a run).
const REFIT_EVERY: u64 = 50;

/// Progress of a run: what a checkpoint stores besides the field and Adam.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainState {
    /// Steps taken.
    pub step: u64,
    /// Steps of the whole run (with a time budget, refitted to the time left every few steps, so the
    /// learning-rate decay ends when the time does).
    pub total_steps: u64,
    /// The sampling generator.
    pub rng: Pcg32,
    /// Seconds spent in steps so far (over all sessions).
    pub elapsed_s: f64,
    /// Loss of the last step.
    pub last: LossParts,
    /// Health of the optimisation (faulty steps and the learning-rate scale they left).
    #[serde(default)]
    pub health: Health,
    /// Seconds per phase, summed over the steps of this session (not restored on resume).
    #[serde(skip)]
    pub profile: StepProfile,
}

/// Where a step's time goes, summed over steps (seconds).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StepProfile {
    /// Drawing rays and samples.
    pub sample: f64,
    /// Field forward pass.
    pub forward: f64,
    /// Rendering and losses.
    pub render: f64,
    /// Field backward pass.
    pub backward: f64,
    /// Eikonal term (its own forward and backward).
    pub eikonal: f64,
    /// Adam step and zeroing the gradients.
    pub adam: f64,
    /// Steps summed.
    pub steps: u64,
}

/// What kind of model is trained (changes sampling near the camera and the geometric initialisation).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum ModelKind {
    /// A movable object, in its canonical frame.
    Object,
    /// The empty room, in the world frame.
    Background,
}

/// Light-code layout of a model: the capture's own lightings, then one per augmentation map.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightCodes {
    /// Names in code order.
    pub names: Vec<String>,
    /// Number of capture lightings (codes `0..capture`); augmentation map `k` has code `capture + k`.
    pub capture: usize,
}

/// The field configuration of a model of `kind` over `bounds` (model frame: the object's box, or the
/// room); an object's SDF starts from `start`.
pub fn field_config(
    kind: ModelKind,
    bounds: Aabb,
    budget: &ModelBudget,
    start: ObjectStart,
    lights: usize,
    appearance: usize,
    seed: u64,
) -> NeusConfig {
    let mut c = match kind {
        ModelKind::Object => {
            let half: [f32; 3] = std::array::from_fn(|a| 0.5 * (bounds.max[a] - bounds.min[a]));
            let mut c = NeusConfig::object(half);
            match start {
                ObjectStart::Box => c.init.box_half_extent = Some(half.map(|h| START_INSET * h)),
                ObjectStart::Sphere => {
                    c.init.radius =
                        START_INSET * half.iter().copied().fold(f32::INFINITY, f32::min);
                    c.init.box_half_extent = None;
                }
            }
            let centre: [f32; 3] = std::array::from_fn(|a| 0.5 * (bounds.max[a] + bounds.min[a]));
            for (a, m) in centre.iter().enumerate() {
                c.bounds_min[a] += m;
                c.bounds_max[a] += m;
            }
            c.init.centre = centre;
            c
        }
        ModelKind::Background => NeusConfig::room(bounds.min, bounds.max),
    };
    c.hash.log2_table = budget.log2_table;
    c.hash.finest_resolution = budget.finest_resolution;
    c.light_codes = lights.max(1);
    c.appearance_codes = appearance.max(1);
    c.seed = seed;
    c
}

/// Reusable buffers of one step.
#[derive(Debug, Default)]
struct Batch {
    /// Samples of the surface rays, which come first; the empty rays' samples follow and need no colour.
    full: usize,
    offsets: Vec<usize>,
    t: Vec<f32>,
    points: Vec<[f32; 3]>,
    dirs: Vec<[f32; 3]>,
    appearance: Vec<u32>,
    light: Vec<u32>,
    targets: Vec<RayTarget>,
    zones: Vec<SampleZone>,
    sdf: Vec<f32>,
    rgb: Vec<f32>,
    d_sdf: Vec<f32>,
    d_rgb: Vec<f32>,
    eikonal: Vec<[f32; 3]>,
    /// Training frame of each ray.
    ray_frame: Vec<u32>,
    /// Index of each ray in the pool of surface rays (`u32::MAX` for an empty ray), for the error map.
    ray_pool: Vec<u32>,
    /// Weight of each ray's losses (importance-weighted ray choice; else 1).
    ray_weight: Vec<f32>,
    /// `∂loss/∂x` of the surface rays' samples, when poses are refined.
    d_points: Vec<[f32; 3]>,
}

/// Trains one model on one dataset.
pub struct Trainer<'a> {
    data: &'a Dataset,
    augmentation: &'a Augmentation,
    config: TrainConfig,
    budget: ModelBudget,
    kind: ModelKind,
    /// The field being learned.
    pub field: NeusField<f32>,
    adam: Adam,
    grads: Params<f32>,
    /// Step, generator and timing.
    pub state: TrainState,
    lights: LightCodes,
    /// Per-frame colour gains and pose corrections, when the capture needs them.
    frames: Option<FrameCorrections>,
    bounds: Aabb,
    diag: f32,
    surface_rays: Vec<u32>,
    empty_rays: Vec<u32>,
    /// Colour errors of the surface rays, when the ray choice is guided by them.
    errors: Option<ErrorMap>,
    batch: Batch,
    tape: Tape<f32>,
    empty_tape: Tape<f32>,
    eikonal_tape: Tape<f32>,
    /// Tape of the SDF probes along rays without observed depth.
    probe_tape: Tape<f32>,
}

impl<'a> Trainer<'a> {
    /// A fresh run: a newly initialised field over `bounds` (model frame).
    pub fn new(
        data: &'a Dataset,
        augmentation: &'a Augmentation,
        config: &TrainConfig,
        kind: ModelKind,
        bounds: Aabb,
    ) -> Self {
        let budget = config.budget(kind).clone();
        let lights = light_codes(data, augmentation);
        let appearance = if config.appearance_per_frame {
            data.origins.len()
        } else {
            1
        };
        let mut fc = field_config(
            kind,
            bounds,
            &budget,
            config.object_start,
            lights.names.len(),
            appearance,
            config.seed,
        );
        fc.mlp_precision = config.mlp_precision;
        let field = NeusField::new(fc);
        let adam = Adam::new(AdamConfig::default(), &field.params);
        let frames = corrections_for(data, config);
        let state = TrainState {
            step: 0,
            total_steps: budget.steps,
            rng: Pcg32::new(config.seed, 0x7A1E),
            elapsed_s: 0.0,
            last: LossParts::default(),
            health: Health::default(),
            profile: StepProfile::default(),
        };
        Self::assemble(
            data,
            augmentation,
            config,
            kind,
            RunParts {
                field,
                adam,
                state,
                lights,
                frames,
                errors: None,
            },
        )
    }

    /// Continues the run saved in checkpoint folder `dir` (see [`Trainer::save`]).
    pub fn resume(
        data: &'a Dataset,
        augmentation: &'a Augmentation,
        config: &TrainConfig,
        kind: ModelKind,
        dir: &Path,
    ) -> Result<Self, CheckpointError> {
        let (field, adam, meta) = checkpoint::load(dir)?;
        let bad = |message: String| CheckpointError::Tensors {
            path: dir.join("config.json"),
            message,
        };
        let adam =
            adam.ok_or_else(|| bad("no optimiser state: not a training checkpoint".into()))?;
        let state: TrainState = serde_json::from_value(meta.trainer["state"].clone())
            .map_err(|e| bad(format!("trainer.state: {e}")))?;
        let lights = light_codes(data, augmentation);
        let frames = stored_entry::<FrameCorrections>(&meta.trainer, "frames")
            .map_err(&bad)?
            .map(FrameCorrections::restored)
            .or_else(|| corrections_for(data, config));
        if let Some(f) = frames.as_ref().filter(|f| f.frames() != data.origins.len()) {
            return Err(bad(format!(
                "corrections of {} frames, this capture has {}",
                f.frames(),
                data.origins.len()
            )));
        }
        let errors = stored_entry::<ErrorMap>(&meta.trainer, "ray_errors")
            .map_err(&bad)?
            .map(ErrorMap::restored);
        if field.config().light_codes != lights.names.len().max(1) {
            return Err(bad(format!(
                "{} light codes, this run has {}",
                field.config().light_codes,
                lights.names.len()
            )));
        }
        Ok(Self::assemble(
            data,
            augmentation,
            config,
            kind,
            RunParts {
                field,
                adam,
                state,
                lights,
                frames,
                errors,
            },
        ))
    }

    fn assemble(
        data: &'a Dataset,
        augmentation: &'a Augmentation,
        config: &TrainConfig,
        kind: ModelKind,
        parts: RunParts,
    ) -> Self {
        let RunParts {
            field,
            adam,
            state,
            lights,
            frames,
            errors,
        } = parts;
        let fc = field.config();
        let bounds = Aabb {
            min: fc.bounds_min,
            max: fc.bounds_max,
        };
        let diag = (Vec3::from(bounds.max) - Vec3::from(bounds.min)).length();
        let (mut surface_rays, mut empty_rays) = (Vec::new(), Vec::new());
        for i in 0..data.rays.len() {
            let target = if data.rays.empty[i] {
                &mut empty_rays
            } else {
                &mut surface_rays
            };
            target.push(i as u32);
        }
        let grads = Params::zeros_like(&field.params);
        // A stored map is kept when it covers this pool; a guided run without one starts afresh.
        let guided = !config.ray_choice.is_uniform() && !surface_rays.is_empty();
        let errors = guided.then(|| {
            errors
                .filter(|e| e.rays() == surface_rays.len())
                .unwrap_or_else(|| ErrorMap::new(surface_rays.len()))
        });
        Self {
            data,
            augmentation,
            config: config.clone(),
            budget: config.budget(kind).clone(),
            kind,
            field,
            adam,
            grads,
            state,
            lights,
            frames,
            bounds,
            diag,
            surface_rays,
            empty_rays,
            errors,
            batch: Batch::default(),
            tape: Tape::default(),
            empty_tape: Tape::default(),
            eikonal_tape: Tape::default(),
            probe_tape: Tape::default(),
        }
    }

    /// The light codes of this model.
    pub fn light_codes(&self) -> &LightCodes {
        &self.lights
    }

    /// The per-frame corrections being learned, when the capture needs them.
    pub fn corrections(&self) -> Option<&FrameCorrections> {
        self.frames.as_ref()
    }

    /// Whether the run has reached its step count or its time budget.
    pub fn finished(&self) -> bool {
        self.state.step >= self.state.total_steps
            || self
                .budget
                .time_budget_s
                .is_some_and(|b| self.state.elapsed_s >= b)
    }

    /// One optimisation step; returns its loss.
    pub fn step(&mut self) -> LossParts {
        let start = Instant::now();
        // Only the CPU clock reads /proc, once before and once after the step.
        let cpu_start = (self.config.budget_clock == BudgetClock::Cpu).then(process_cpu_seconds);
        let mut lap = Lap(Instant::now());
        let levels = self.config.start_levels
            + (self.state.step / self.config.steps_per_level.max(1)) as usize;
        self.field.set_active_levels(levels);
        self.draw_batch();
        let mut prof = self.state.profile;
        prof.sample += lap.next();
        self.forward();
        prof.forward += lap.next();
        let (mut parts, d_inv_s) = self.ray_losses();
        parts.sdf = self.sdf_losses();
        prof.render += lap.next();
        self.backward(d_inv_s);
        prof.backward += lap.next();
        parts.eikonal = self.eikonal();
        prof.eikonal += lap.next();
        if self
            .state
            .health
            .admit(parts.total(), self.grads.all_finite())
        {
            let factor = self.schedule().factor(self.state.step) * self.state.health.lr_scale;
            let lr: [f32; NUM_GROUPS] = self.config.learning_rates.map(|r| r * factor);
            self.adam.step(&mut self.field.params, &mut self.grads, &lr);
            // The step cleared the gradients of the groups it moved; the frozen groups' are cleared here.
            self.grads.fill_zero_where(|g| lr[g as usize] == 0.0);
            let refine = self.config.frame_refinement;
            let pose_lr = if self.poses_move() {
                refine.pose_lr * factor
            } else {
                0.0
            };
            if let Some(frames) = &mut self.frames {
                frames.step(pose_lr, refine.gain_lr * factor, refine.pose_prior);
            }
        } else {
            self.grads.fill_zero();
            if let Some(frames) = &mut self.frames {
                frames.clear_grads();
            }
        }
        prof.adam += lap.next();
        prof.steps += 1;
        self.state.profile = prof;
        self.state.step += 1;
        self.state.elapsed_s += match cpu_start {
            None => start.elapsed().as_secs_f64(),
            Some(cpu) => (process_cpu_seconds() - cpu) / rayon::current_num_threads() as f64,
        };
        self.state.last = parts;
        self.calibrate();
        parts
    }

    /// Field forward pass of the batch: full outputs for the surface rays' samples, the SDF (and its
    /// gradient while poses move) for the empty rays' (their colour is never used).
    fn forward(&mut self) {
        // With moving poses the empty rays' samples need the SDF's gradient too: their position
        // gradients are what turns a frame's silhouette into its pose correction.
        let empty_outputs = if self.silhouettes_move_poses() {
            Outputs::SdfGradient
        } else {
            Outputs::Sdf
        };
        let b = &mut self.batch;
        let (n, f) = (b.points.len(), b.full);
        let codes = CodeSet {
            appearance: Codes::PerPoint(&b.appearance),
            light: Codes::PerPoint(&b.light),
            object: Codes::Fixed(0),
        };
        b.sdf.resize(n, 0.0);
        b.rgb.clear();
        b.rgb.resize(3 * n, 0.0);
        self.field.forward(
            &b.points[..f],
            &b.dirs[..f],
            &codes.slice(0, f),
            Outputs::Full,
            &mut self.tape,
        );
        self.tape.copy_sdf(&mut b.sdf[..f]);
        self.tape.copy_rgb(&mut b.rgb[..3 * f]);
        self.field.forward(
            &b.points[f..],
            &[],
            &codes.slice(f, n),
            empty_outputs,
            &mut self.empty_tape,
        );
        self.empty_tape.copy_sdf(&mut b.sdf[f..]);
    }

    /// Field backward pass of the batch (both parts) and of the sharpness; with moving poses, also the
    /// gradient of every frame's pose correction.
    fn backward(&mut self, d_inv_s: f32) {
        let poses_move = self.poses_move();
        let silhouettes = self.silhouettes_move_poses();
        let b = &mut self.batch;
        let (n, f) = (b.points.len(), b.full);
        let codes = CodeSet {
            appearance: Codes::PerPoint(&b.appearance),
            light: Codes::PerPoint(&b.light),
            object: Codes::Fixed(0),
        };
        let grads = &mut self.grads;
        b.d_points.clear();
        if poses_move {
            b.d_points.resize(if silhouettes { n } else { f }, [0.0; 3]);
        }
        self.field.backward(
            &codes.slice(0, f),
            &mut self.tape,
            &b.d_sdf[..f],
            Some(&b.d_rgb[..3 * f]),
            grads,
            poses_move.then(|| &mut b.d_points[..f]),
        );
        self.field.backward(
            &codes.slice(f, n),
            &mut self.empty_tape,
            &b.d_sdf[f..],
            None,
            grads,
            silhouettes.then(|| &mut b.d_points[f..]),
        );
        self.field.backward_inv_s(d_inv_s, grads);
        if let Some(frames) = self.frames.as_mut().filter(|_| poses_move) {
            add_pose_grads(&self.batch, frames);
        }
    }

    /// Whether the poses are refined at this step: the capture's poses are tracked and the first
    /// [`crate::config::FrameRefinement::pose_start`] of the run is over.
    fn poses_move(&self) -> bool {
        let refine = self.config.frame_refinement;
        let start =
            (refine.pose_start.clamp(0.0, 1.0) as f64 * self.state.total_steps as f64) as u64;
        self.frames.as_ref().is_some_and(|f| f.corrected.pose)
            && refine.pose_lr > 0.0
            && self.state.step >= start
    }

    /// Whether the empty rays' samples move the poses at this step
    /// ([`crate::config::FrameRefinement::silhouettes`]).
    fn silhouettes_move_poses(&self) -> bool {
        self.poses_move() && self.config.frame_refinement.silhouettes
    }

    /// The level at which the targets' channels read clipped: only where frames learn their own
    /// colour gain ([`crate::config::FrameRefinement::clipped_white`]).
    fn clipped_white(&self) -> Option<f32> {
        let white = self.config.frame_refinement.clipped_white;
        let gains = self.frames.as_ref().is_some_and(|f| f.corrected.colour);
        (gains && white < 1.0).then_some(white)
    }

    fn schedule(&self) -> Schedule {
        Schedule::Polynomial {
            warmup: self.config.warmup_steps,
            total: self.state.total_steps,
            power: self.config.decay_power,
            floor: self.config.decay_floor,
        }
    }

    /// With a time budget, fits the step count to the time left from the mean step time so far: first
    /// after the calibration steps, then every [`REFIT_EVERY`] steps.
    fn calibrate(&mut self) {
        let Some(budget) = self.budget.time_budget_s else {
            return;
        };
        let step = self.state.step;
        if step < CALIBRATION_STEPS
            || (step > CALIBRATION_STEPS && !step.is_multiple_of(REFIT_EVERY))
        {
            return;
        }
        let per_step = self.state.elapsed_s / step as f64;
        let fitted = step + ((budget - self.state.elapsed_s).max(0.0) / per_step) as u64;
        self.state.total_steps = fitted.min(self.budget.steps).max(step);
    }

    /// Draws the rays of a step and their samples, points, codes and targets.
    fn draw_batch(&mut self) {
        let mut plans = self.plan_rays();
        self.find_model_surfaces(&mut plans);
        let (counts, band) = (self.sample_counts(), self.budget.sdf_band * self.diag);
        let white = self.clipped_white();
        let b = &mut self.batch;
        b.offsets.clear();
        b.ray_frame.clear();
        b.ray_pool.clear();
        b.ray_weight.clear();
        b.offsets.push(0);
        // Surface rays first, then empty ones (see `Batch::full`).
        let (mut n, mut full) = (0, 0);
        for plan in &plans {
            n += plan.count;
            if !plan.empty {
                full = n;
            }
            b.offsets.push(n);
            b.ray_frame.push(plan.frame);
            b.ray_pool.push(plan.pool);
            b.ray_weight.push(plan.weight);
        }
        b.full = full;
        b.t.resize(n, 0.0);
        b.points.resize(n, [0.0; 3]);
        b.dirs.resize(n, [0.0; 3]);
        b.appearance.resize(n, 0);
        b.light.resize(n, 0);
        b.zones.resize(n, SampleZone::Empty);
        let rows = SampleRows {
            t: &mut b.t,
            points: &mut b.points,
            dirs: &mut b.dirs,
            appearance: &mut b.appearance,
            light: &mut b.light,
            zones: &mut b.zones,
        };
        write_samples(&plans, &counts, band, rows);
        let (rays, augmentation) = (&self.data.rays, self.augmentation);
        plans
            .par_iter()
            .map(|plan| plan.target(rays, augmentation, white))
            .collect_into_vec(&mut b.targets);
        for v in [&mut b.d_sdf, &mut b.d_rgb] {
            v.clear();
        }
        b.d_sdf.resize(n, 0.0);
        b.d_rgb.resize(3 * n, 0.0);
    }

    /// Where the model's current surface crosses each surface ray that has no observed depth
    /// ([`crate::config::UnobservedSamples::probes`]): one SDF-only pass over evenly spaced probes
    /// ([`surface_from_probes`]). The ray's shell is at least half the probes' spacing wide, so it
    /// covers the crossing the probes bracket. The probes draw no random numbers, so the step's
    /// stream is the same with them or without.
    fn find_model_surfaces(&mut self, plans: &mut [RayPlan]) {
        let noise = self.data.device.depth_noise;
        let Some(probes) = self.config.unobserved_samples.probes(noise) else {
            return;
        };
        let probes = probes.max(2);
        let unobserved: Vec<usize> = (0..plans.len())
            .filter(|&i| !plans[i].empty && plans[i].distance.is_none())
            .collect();
        if unobserved.is_empty() {
            return;
        }
        let mut points = Vec::with_capacity(unobserved.len() * probes);
        for p in unobserved.iter().map(|&i| &plans[i]) {
            points.extend(
                probe_distances(p.near, p.far, probes).map(|t| (p.origin + t * p.dir).to_array()),
            );
        }
        let tape = &mut self.probe_tape;
        self.field
            .forward(&points, &[], &CodeSet::default(), Outputs::Sdf, tape);
        let mut sdf = vec![0.0; points.len()];
        tape.copy_sdf(&mut sdf);
        for (&i, values) in unobserved.iter().zip(sdf.chunks_exact(probes)) {
            let p = &mut plans[i];
            p.model_surface = Some(surface_from_probes(p.near, p.far, values));
            p.shell = p.shell.max(0.5 * (p.far - p.near) / probes as f32);
        }
    }

    /// Samples per ray of this model's budget.
    fn sample_counts(&self) -> SampleCounts {
        SampleCounts {
            shell: self.budget.shell_samples,
            uniform: self.budget.uniform_samples,
        }
    }

    /// The step's rays in order, drawn from the step's generator: which rays, where each one's sample
    /// draws start (their count is known before they are made, so the generator is moved past them),
    /// and which are relit. Rays that miss the model's bounds are dropped.
    fn plan_rays(&mut self) -> Vec<RayPlan> {
        let inv_s = self.field.inv_s();
        let limits = ShellLimits {
            min: self.budget.shell_min * self.diag,
            max: 0.1 * self.diag,
            band: self.budget.sdf_band * self.diag,
        };
        let counts = self.sample_counts();
        let rays = &self.data.rays;
        let rng = &mut self.state.rng;
        let batch = self.budget.batch_rays;
        let n_empty = match (self.surface_rays.is_empty(), self.empty_rays.is_empty()) {
            (_, true) => 0,
            (true, false) => batch,
            (false, false) => (0..batch)
                .filter(|_| rng.next_f32() < self.config.empty_fraction)
                .count(),
        };
        let mut plans = Vec::with_capacity(batch);
        for r in 0..batch {
            let empty = r >= batch - n_empty;
            let drawn = if empty {
                let k = rng.below(self.empty_rays.len() as u32) as usize;
                PoolDraw::new(self.empty_rays[k], u32::MAX, 1.0)
            } else if let Some(map) = &self.errors {
                let d = map.draw(&self.config.ray_choice, rng);
                PoolDraw::new(self.surface_rays[d.index], d.index as u32, d.weight)
            } else {
                let k = rng.below(self.surface_rays.len() as u32);
                PoolDraw::new(self.surface_rays[k as usize], k, 1.0)
            };
            let i = drawn.ray;
            let frame = rays.frame[i] as usize;
            let (origin, dir) = match self.frames.as_ref().filter(|f| f.corrected.pose) {
                Some(f) => (
                    f.origin(frame, self.data.origin(i)),
                    f.direction(frame, Vec3::from(rays.dir[i])),
                ),
                None => (self.data.origin(i), Vec3::from(rays.dir[i])),
            };
            let Some((near, far)) = self.bounds.intersect(origin, dir) else {
                continue;
            };
            let near = if self.kind == ModelKind::Background {
                near.max(0.02)
            } else {
                near
            };
            if far <= near {
                continue;
            }
            let distance = (rays.distance[i] > 0.0).then_some(rays.distance[i]);
            let spread = depth_spread(distance, self.data.device.depth_noise);
            let normal = rays.normal(i);
            let cos = if normal == Vec3::ZERO {
                1.0
            } else {
                normal.dot(dir).abs().max(0.1)
            };
            let shell = limits.half_width(inv_s, cos, spread);
            let count = counts.of(near, far, distance.filter(|_| !empty), shell);
            let sample_rng = *rng;
            for _ in 0..count {
                rng.next_u32();
            }
            let mut light = self.data.frame_light[frame] as u32;
            let mut relight = None;
            if !empty
                && !self.augmentation.is_empty()
                && rng.next_f32() < self.config.augment_fraction
                && normal != Vec3::ZERO
            {
                let k = rng.below(self.augmentation.len() as u32) as usize;
                relight = Some(k);
                light = (self.lights.capture + k) as u32;
            }
            let appearance = if self.config.appearance_per_frame {
                frame as u32
            } else {
                0
            };
            plans.push(RayPlan {
                ray: i,
                frame: frame as u32,
                origin,
                dir,
                near,
                far,
                distance,
                model_surface: None,
                shell,
                spread,
                cos,
                normal,
                empty,
                sample_rng,
                count,
                relight,
                light,
                appearance,
                pool: drawn.pool,
                weight: drawn.weight,
            });
        }
        plans
    }

    /// Renders every ray of the batch, scores it, and writes the sample gradients; returns the loss parts
    /// and `∂loss/∂inv_s`. Rays are rendered in parallel tasks of [`RAYS_PER_TASK`]; what they add up to
    /// is summed afterwards in ray order, so the result does not depend on the thread count.
    fn ray_losses(&mut self) -> (LossParts, f32) {
        let b = &mut self.batch;
        let w = self.config.weights;
        let rays = b.targets.len();
        let with_rgb = b.targets.iter().filter(|t| t.rgb.is_some()).count().max(1);
        let with_depth = b
            .targets
            .iter()
            .filter(|t| t.distance.is_some())
            .count()
            .max(1);
        let scales = RayScales {
            color: w.color / with_rgb as f32,
            depth: w.depth / with_depth as f32,
            mask: w.mask / rays.max(1) as f32,
        };
        let inv_s = self.field.inv_s();
        let gains = self
            .frames
            .as_ref()
            .filter(|f| f.corrected.colour)
            .map(|f| (0..f.frames()).map(|k| f.gain(k)).collect::<Vec<_>>());
        let scores = score_rays(b, inv_s, &scales, gains.as_deref());
        let mut parts = LossParts::default();
        let mut d_inv_s = 0.0;
        let mut frames = self.frames.as_mut().filter(|f| f.corrected.colour);
        let mut errors = self.errors.as_mut();
        for (r, score) in scores.iter().enumerate() {
            let p = score.parts;
            if let Some(map) = errors.as_deref_mut().filter(|_| b.targets[r].rgb.is_some()) {
                map.observe(b.ray_pool[r] as usize, p[3]);
            }
            if let Some(frames) = frames.as_deref_mut() {
                frames.add_colour_grad(b.ray_frame[r] as usize, score.rgb, score.d_rgb);
            }
            parts.color += p[0];
            parts.depth += p[1];
            parts.mask += p[2];
            parts.color_mse += p[3] / with_rgb as f32;
            d_inv_s += score.d_inv_s;
        }
        if let Some(map) = errors {
            map.commit();
        }
        (parts, d_inv_s)
    }

    /// Adds the SDF supervision gradients of every sample; returns the weighted loss.
    fn sdf_losses(&mut self) -> f32 {
        let b = &mut self.batch;
        let w = self.config.weights;
        let near = b
            .zones
            .iter()
            .filter(|z| matches!(z, SampleZone::Near { .. }))
            .count()
            .max(1) as f32;
        let free = b
            .zones
            .iter()
            .filter(|z| matches!(z, SampleZone::Free { .. } | SampleZone::Empty))
            .count()
            .max(1) as f32;
        let mut loss = 0.0;
        for (r, ray) in b.offsets.windows(2).enumerate() {
            let weight = b.ray_weight[r];
            for k in ray[0]..ray[1] {
                let zone = b.zones[k];
                let scale = match zone {
                    SampleZone::Near { .. } => w.sdf_near / near,
                    SampleZone::Free { .. } | SampleZone::Empty => w.sdf_free / free,
                    SampleZone::Unknown => continue,
                };
                let scale = weight * scale;
                let (l, g) = sdf_loss(b.sdf[k], zone);
                loss += scale * l;
                b.d_sdf[k] += scale * g;
            }
        }
        loss
    }

    /// The eikonal term on every `eikonal_stride`-th sample, with a finite-difference step of a quarter of
    /// the finest active cell.
    fn eikonal(&mut self) -> f32 {
        if self.config.weights.eikonal == 0.0 {
            return 0.0;
        }
        let stride = self.config.eikonal_stride.max(1);
        let b = &mut self.batch;
        b.eikonal.clear();
        b.eikonal.extend(b.points.iter().step_by(stride).copied());
        let levels = self.field.active_levels();
        let res = self.field.grid().levels()[levels - 1].resolution as f32;
        let h = 0.25 * self.diag / 3f32.sqrt() / res;
        self.field.eikonal(
            &b.eikonal,
            Codes::Fixed(0),
            h.max(1e-4),
            self.config.weights.eikonal,
            &mut self.eikonal_tape,
            &mut self.grads,
        )
    }

    /// Writes a resumable checkpoint to folder `dir`: written beside it first, then swapped in, so `dir`
    /// always holds a complete checkpoint (the previous one survives in `<dir>.old` while swapping).
    pub fn save(&self, dir: &Path) -> Result<(), CheckpointError> {
        let io = |path: &Path, source| CheckpointError::Io {
            path: path.to_owned(),
            source,
        };
        let tmp = dir.with_extension("tmp");
        let old = dir.with_extension("old");
        let _ = std::fs::remove_dir_all(&tmp);
        let mut trainer = self.trainer_json();
        if let Some(errors) = &self.errors {
            trainer["ray_errors"] =
                serde_json::to_value(errors).map_err(|e| CheckpointError::Tensors {
                    path: tmp.join("config.json"),
                    message: format!("trainer.ray_errors: {e}"),
                })?;
        }
        checkpoint::save(&tmp, &self.field, Some(&self.adam), trainer)?;
        if dir.exists() {
            let _ = std::fs::remove_dir_all(&old);
            std::fs::rename(dir, &old).map_err(|e| io(dir, e))?;
        }
        std::fs::rename(&tmp, dir).map_err(|e| io(dir, e))?;
        let _ = std::fs::remove_dir_all(&old);
        Ok(())
    }

    /// What a model's `trainer` field holds: the state, the light codes, the kind and the frame
    /// corrections (a checkpoint adds the ray choice's error map, see [`Trainer::save`]).
    pub fn trainer_json(&self) -> serde_json::Value {
        serde_json::json!({
            "revision": crate::reuse::TRAINING_REVISION,
            "state": self.state,
            "light_codes": self.lights,
            "kind": self.kind,
            "frames": self.frames,
        })
    }
}

/// Rays rendered and scored by one parallel task of [`Trainer::ray_losses`].
const RAYS_PER_TASK: usize = 64;

/// What rendering and scoring one ray gives besides its samples' gradients.
#[derive(Clone, Copy, Debug, Default)]
struct RayScore {
    /// Weighted colour, depth and mask losses and the unweighted squared colour error.
    parts: [f32; 4],
    /// `∂loss/∂inv_s` of the ray.
    d_inv_s: f32,
    /// The rendered colour after the frame's gain.
    rgb: [f32; 3],
    /// `∂loss/∂rgb` before the gain (what the frame's gain learns from).
    d_rgb: [f32; 3],
}

/// Renders and scores every ray of `b` in parallel tasks, writing each sample's gradients into
/// `b.d_sdf` and `b.d_rgb`; `gains` holds each frame's colour gain when frames have one.
fn score_rays(
    b: &mut Batch,
    inv_s: f32,
    scales: &RayScales,
    gains: Option<&[[f32; 3]]>,
) -> Vec<RayScore> {
    let Batch {
        offsets,
        t,
        sdf,
        rgb,
        targets,
        ray_frame,
        ray_weight,
        d_sdf,
        d_rgb,
        ..
    } = b;
    let rays = targets.len();
    let (rgb3, _) = rgb.as_chunks::<3>();
    let mut d_sdf = &mut d_sdf[..];
    let mut d_rgb3 = d_rgb.as_chunks_mut::<3>().0;
    let mut tasks = Vec::with_capacity(rays.div_ceil(RAYS_PER_TASK));
    for first in (0..rays).step_by(RAYS_PER_TASK) {
        let last = (first + RAYS_PER_TASK).min(rays);
        let len = offsets[last] - offsets[first];
        let (sdf_part, sdf_rest) = std::mem::take(&mut d_sdf).split_at_mut(len);
        let (rgb_part, rgb_rest) = std::mem::take(&mut d_rgb3).split_at_mut(len);
        (d_sdf, d_rgb3) = (sdf_rest, rgb_rest);
        tasks.push((first..last, sdf_part, rgb_part));
    }
    let inputs = RayInputs {
        t,
        sdf,
        rgb: rgb3,
        inv_s,
        scales,
        gains,
    };
    tasks
        .into_par_iter()
        .map(|(range, d_sdf, d_rgb)| {
            let base = offsets[range.start];
            let mut tape = RayTape::default();
            range
                .map(|r| {
                    let (s, e) = (offsets[r], offsets[r + 1]);
                    let (frame, weight) = (ray_frame[r] as usize, ray_weight[r]);
                    let ray = RayRef {
                        samples: s..e,
                        frame,
                        weight,
                        target: &targets[r],
                    };
                    let d = (
                        &mut d_sdf[s - base..e - base],
                        &mut d_rgb[s - base..e - base],
                    );
                    score_ray(&inputs, &ray, &mut tape, d)
                })
                .collect::<Vec<_>>()
        })
        .flatten()
        .collect()
}

/// The sample values every ray of a step reads.
struct RayInputs<'a> {
    t: &'a [f32],
    sdf: &'a [f32],
    rgb: &'a [[f32; 3]],
    inv_s: f32,
    scales: &'a RayScales,
    gains: Option<&'a [[f32; 3]]>,
}

/// One ray of a step: its samples, frame, loss weight and target.
struct RayRef<'a> {
    samples: std::ops::Range<usize>,
    frame: usize,
    weight: f32,
    target: &'a RayTarget,
}

/// Renders and scores one ray, writing its samples' gradients into `d_sdf` and `d_rgb`.
fn score_ray(
    inputs: &RayInputs,
    ray: &RayRef,
    tape: &mut RayTape<f32>,
    (d_sdf, d_rgb): (&mut [f32], &mut [[f32; 3]]),
) -> RayScore {
    let s = ray.samples.clone();
    let sdf = &inputs.sdf[s.clone()];
    let mut out = render_ray(
        &inputs.t[s.clone()],
        sdf,
        &inputs.rgb[s],
        inputs.inv_s,
        tape,
    );
    let gain = inputs.gains.map(|g| g[ray.frame]);
    if let Some(gain) = gain {
        out.rgb = std::array::from_fn(|k| gain[k] * out.rgb[k]);
    }
    let scales = RayScales {
        color: ray.weight * inputs.scales.color,
        depth: ray.weight * inputs.scales.depth,
        mask: ray.weight * inputs.scales.mask,
    };
    let (parts, mut g) = ray_loss(&out, ray.target, &scales);
    let d_rgb_out = g.rgb;
    if let Some(gain) = gain {
        g.rgb = std::array::from_fn(|k| gain[k] * g.rgb[k]);
    }
    let d_inv_s = render_ray_backward(sdf, inputs.inv_s, tape, &g, d_sdf, d_rgb);
    RayScore {
        parts,
        d_inv_s,
        rgb: out.rgb,
        d_rgb: d_rgb_out,
    }
}

/// The entry `key` of a checkpoint's `trainer` field, when it is there and not null; an error message
/// naming it when it does not parse.
fn stored_entry<T: serde::de::DeserializeOwned>(
    trainer: &serde_json::Value,
    key: &str,
) -> Result<Option<T>, String> {
    trainer
        .get(key)
        .filter(|v| !v.is_null())
        .map(|v| serde_json::from_value(v.clone()).map_err(|e| format!("trainer.{key}: {e}")))
        .transpose()
}

/// What a run carries from step to step, fresh or restored from a checkpoint.
struct RunParts {
    field: NeusField<f32>,
    adam: Adam,
    state: TrainState,
    lights: LightCodes,
    frames: Option<FrameCorrections>,
    errors: Option<ErrorMap>,
}

/// A training ray drawn from one of the two pools.
struct PoolDraw {
    /// Index into the dataset's rays.
    ray: usize,
    /// Index into the pool of surface rays (`u32::MAX` for an empty ray).
    pool: u32,
    /// Weight of the ray's losses.
    weight: f32,
}

impl PoolDraw {
    fn new(ray: u32, pool: u32, weight: f32) -> Self {
        Self {
            ray: ray as usize,
            pool,
            weight,
        }
    }
}

/// A stopwatch returning the seconds since its last reading.
struct Lap(Instant);

impl Lap {
    fn next(&mut self) -> f64 {
        let now = Instant::now();
        let dt = (now - self.0).as_secs_f64();
        self.0 = now;
        dt
    }
}

/// The bounds of a ray's depth-guided shell ([`ShellLimits::half_width`]), in metres.
#[derive(Clone, Copy, Debug)]
struct ShellLimits {
    /// Narrowest half-width.
    min: f32,
    /// Widest half-width.
    max: f32,
    /// Half-width of the SDF's near band (the samples whose SDF is regressed to the depth).
    band: f32,
}

impl ShellLimits {
    /// The shell's half-width on a ray of `|n · d|` = `cos` whose depth may be off by `spread` (two
    /// standard deviations of its noise): the NeuS transition, `5 / (inv_s · cos)` within the limits
    /// (a grazing ray crosses it over a longer stretch). With noisy depth (`spread > 0`) the shell
    /// also spans:
    /// - the whole near band ([`near_band`]): the band's SDF targets carry the noise, and a part of
    ///   the band the samples leave out is shaped only by what the noisy updates of the hash grid
    ///   leak into it (on a phone-degraded room thin floaters grew there, a few centimetres in front
    ///   of the floor);
    /// - twice the spread (four standard deviations): the surface lies within three of the observed
    ///   depth on all but 0.3 % of rays, and the shell must reach past it. On a ray whose depth read
    ///   short by more than the shell's reach, no sample lies behind the surface; a thin part's
    ///   faces then fall between two samples, the ray renders empty, and its opacity term grows the
    ///   part towards the camera: noisy depth alone made the phone models fat by most of a noise σ
    ///   (docs/experiment-log.md, 2026-12-07).
    ///
    /// Exact depth keeps the narrow shell, its targets consistent.
    fn half_width(&self, inv_s: f32, cos: f32, spread: f32) -> f32 {
        let transition = (5.0 / (inv_s * cos)).clamp(self.min, self.max);
        if spread > 0.0 {
            transition
                .max(near_band(self.band, spread))
                .max(NOISY_SHELL_SPREADS * spread)
        } else {
            transition
        }
    }
}

/// How many depth-noise spreads ([`depth_spread`]) a noisy ray's shell reaches on either side of its
/// observed depth ([`ShellLimits::half_width`]).
const NOISY_SHELL_SPREADS: f32 = 2.0;

/// How far from a ray's observed distance `d` its surface may lie when the capture's depth is noisy:
/// two standard deviations of the sensor's noise there (0 for exact depth or none). The depth-guided
/// samples and the SDF's near band widen to it, so a sample the noise put in front of the true
/// surface is not taken as free space (which would carve the surface wherever the depth reads long)
/// and the samples still reach the surface wherever the depth reads short.
fn depth_spread(d: Option<f32>, noise: Option<DepthNoise>) -> f32 {
    match (d, noise) {
        (Some(d), Some(noise)) => 2.0 * noise.sigma_at(d),
        _ => 0.0,
    }
}

/// The per-frame corrections a model of `data` learns under `config` (none for a capture from a rig).
fn corrections_for(data: &Dataset, config: &TrainConfig) -> Option<FrameCorrections> {
    let device = data.device;
    let corrected = match config.frame_refinement.when {
        RefineWhen::FromCapture => Corrected {
            colour: device.auto_exposure,
            pose: device.tracked_poses,
        },
        RefineWhen::Always => Corrected {
            colour: true,
            pose: true,
        },
        RefineWhen::Never => return None,
    };
    (corrected.colour || corrected.pose).then(|| FrameCorrections::new(anchors(data), corrected))
}

/// Where each training frame's pose correction is anchored: the centroid of the surface points it
/// sees (its centre when it sees none), and its line of sight there.
fn anchors(data: &Dataset) -> Vec<FrameAnchor> {
    let frames = data.origins.len();
    let mut sum = vec![Vec3::ZERO; frames];
    let mut count = vec![0u32; frames];
    let rays = &data.rays;
    for i in 0..rays.len() {
        if rays.distance[i] > 0.0 {
            let f = rays.frame[i] as usize;
            sum[f] += data.origin(i) + rays.distance[i] * Vec3::from(rays.dir[i]);
            count[f] += 1;
        }
    }
    (0..frames)
        .map(|f| {
            let centre = Vec3::from(data.origins[f]);
            let pivot = match count[f] {
                0 => centre,
                n => sum[f] / n as f32,
            };
            FrameAnchor {
                pivot,
                sight: (pivot - centre).normalize_or_zero(),
            }
        })
        .collect()
}

/// Adds every sample's position gradient in `batch.d_points` to its frame's pose correction: the
/// surface rays' (colour, depth, opacity, SDF terms), and the empty rays' (opacity and free space:
/// the frame's silhouette) when [`crate::config::FrameRefinement::silhouettes`] put them there.
fn add_pose_grads(batch: &Batch, frames: &mut FrameCorrections) {
    for (r, &frame) in batch.ray_frame.iter().enumerate() {
        let (s, e) = (batch.offsets[r], batch.offsets[r + 1]);
        if e > batch.d_points.len() {
            break;
        }
        for i in s..e {
            frames.add_sample_grad(
                frame as usize,
                Vec3::from(batch.points[i]),
                Vec3::from(batch.d_points[i]),
            );
        }
    }
}

/// Light codes of a dataset with an augmentation.
pub fn light_codes(data: &Dataset, augmentation: &Augmentation) -> LightCodes {
    let mut names = data.light_names.clone();
    let capture = names.len();
    names.extend(augmentation.names.iter().cloned());
    LightCodes { names, capture }
}

impl Trainer<'_> {
    /// Steps until the run is finished, reporting to `progress` and writing a checkpoint to `checkpoint`
    /// every `checkpoint_every` steps (and at the end).
    pub fn run(
        &mut self,
        name: &str,
        checkpoint: Option<&Path>,
        progress: &dyn Progress,
    ) -> Result<(), TrainError> {
        progress.start(name, self.state.step, self.state.total_steps);
        let every = self.config.checkpoint_every;
        while !self.finished() {
            let loss = self.step();
            progress.step(name, self.state.step, self.state.total_steps, &loss);
            let health = self.state.health;
            if health.in_a_row >= MAX_FAULTS_IN_A_ROW {
                return Err(TrainError::Diverged {
                    model: name.to_string(),
                    step: self.state.step,
                    faults: health.in_a_row,
                    lr_scale: health.lr_scale,
                });
            }
            if progress.interrupted() {
                if let Some(dir) = checkpoint {
                    self.save(dir)?;
                }
                return Err(TrainError::Interrupted {
                    model: name.to_string(),
                    step: self.state.step,
                });
            }
            if let Some(dir) =
                checkpoint.filter(|_| every > 0 && self.state.step.is_multiple_of(every))
            {
                self.save(dir)?;
            }
        }
        if let Some(dir) = checkpoint {
            self.save(dir)?;
        }
        let last = &self.state.last;
        let faults = match self.state.health.faults {
            0 => String::new(),
            f => format!(
                ", {f} faulty steps skipped (learning rate scaled by {:e})",
                self.state.health.lr_scale
            ),
        };
        let corrections = match self.frames.as_ref().map(FrameCorrections::summary) {
            Some(c) => format!(
                ", frames corrected by up to {:.1} cm / {:.2}°, gains {:.2}–{:.2}",
                100.0 * c.max_translation_m,
                c.max_rotation_deg,
                c.gain_range[0],
                c.gain_range[1]
            ),
            None => String::new(),
        };
        progress.finish(
            name,
            &format!(
            "{} steps in {:.0} s, loss {:.4}, batch PSNR {:.2} dB, inv_s {:.0}{corrections}{faults}",
            self.state.step,
            self.state.elapsed_s,
            last.total(),
            last.psnr(),
            self.field.inv_s()
        ));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Exact depth keeps the NeuS transition's shell; noisy depth spans the near band, or twice
    /// the spread where that is wider.
    #[test]
    fn a_noisy_rays_shell_spans_its_near_band_and_twice_its_spread() {
        let limits = ShellLimits {
            min: 0.005,
            max: 0.5,
            band: 0.05,
        };
        let transition = 5.0 / (1000.0 * 0.5);
        assert_eq!(limits.half_width(1000.0, 0.5, 0.0), transition);
        assert_eq!(limits.half_width(1000.0, 0.5, 0.02), 0.05);
        assert_eq!(limits.half_width(1000.0, 0.5, 0.04), 0.08);
        assert_eq!(limits.half_width(1000.0, 0.5, 0.08), 0.16);
        assert_eq!(limits.half_width(20.0, 0.5, 0.02), 0.5);
    }
}

//! Timed training runs with their figures, for `neuroom bench train …`: one object or the background of a
//! room, trained from scratch with the configuration's budget (no checkpoints), then evaluated on the
//! held-out views and, for objects, against `meshes/<object>.ply` when the room has it.

use crate::augment::Augmentation;
use crate::config::{BudgetClock, TrainConfig};
use crate::eval::{EvalReport, evaluate, noise_psnr_ceiling};
use crate::progress::Progress;
use crate::room::{
    ModelSpec, TrainError, load_model_data, model_specs, truth_chamfer, with_threads,
};
use crate::trainer::{ModelKind, StepProfile, Trainer};
use neuroom_core::formats::read_room;
use neuroom_core::surface::Chamfer;
use serde::Serialize;
use std::path::Path;
use std::time::Instant;

/// Figures of one timed training run.
#[derive(Clone, Debug, Serialize)]
pub struct ModelBenchReport {
    /// Room name.
    pub room: String,
    /// Model name (`background` or the capture name).
    pub model: String,
    /// Object or background.
    pub kind: ModelKind,
    /// Worker threads.
    pub threads: usize,
    /// Training rays.
    pub rays: usize,
    /// Steps taken.
    pub steps: u64,
    /// Seconds in training steps, on the budget's clock.
    pub train_seconds: f64,
    /// The clock of `train_seconds` and of the budget.
    pub budget_clock: BudgetClock,
    /// Wall-clock seconds of the training steps.
    pub train_wall_seconds: f64,
    /// Seconds reading the capture.
    pub load_seconds: f64,
    /// Seconds evaluating.
    pub eval_seconds: f64,
    /// Held-out figures (PSNR, depth error, coverage, light-code check); `None` when the capture keeps
    /// no held-out views (a `holdout` of 0).
    pub held_out: Option<EvalReport>,
    /// The held-out PSNR an exact model would reach, estimated from the held-out images' own noise
    /// ([`crate::eval::noise_psnr_ceiling`]).
    pub noise_ceiling_psnr_db: Option<f64>,
    /// Chamfer distance (metres) to the ground-truth mesh, when there is one.
    pub chamfer_m: Option<Chamfer>,
    /// Learned NeuS sharpness.
    pub inv_s: f32,
    /// Mean milliseconds per step, by phase.
    pub step_profile_ms: StepProfile,
}

/// Trains and evaluates the model of object `object` (by name) of the room at `room_dir`.
pub fn bench_object(
    room_dir: &Path,
    object: &str,
    config: &TrainConfig,
    progress: &dyn Progress,
) -> Result<ModelBenchReport, TrainError> {
    let room = read_room(room_dir)?;
    let spec = model_specs(&room)
        .into_iter()
        .find(|s| s.objects.iter().any(|o| o == object))
        .ok_or_else(|| TrainError::File {
            path: room_dir.join("room.json"),
            message: format!("no object named {object:?}"),
        })?;
    bench_model(&room.name, &spec, config, progress)
}

/// Trains and evaluates the background model of the room at `room_dir`.
pub fn bench_background(
    room_dir: &Path,
    config: &TrainConfig,
    progress: &dyn Progress,
) -> Result<ModelBenchReport, TrainError> {
    let room = read_room(room_dir)?;
    let spec = model_specs(&room).remove(0);
    bench_model(&room.name, &spec, config, progress)
}

fn bench_model(
    room: &str,
    spec: &ModelSpec,
    config: &TrainConfig,
    progress: &dyn Progress,
) -> Result<ModelBenchReport, TrainError> {
    with_threads(config.threads, || {
        let augmentation = Augmentation::load(&config.env_maps)?;
        let (data, bounds, load_seconds) = load_model_data(spec, config)?;
        let mut trainer = Trainer::new(&data, &augmentation, config, spec.kind, bounds);
        let wall = Instant::now();
        trainer.run(&spec.name, None, progress)?;
        let train_wall_seconds = wall.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let fc = trainer.field.config();
        let field_bounds = crate::dataset::Aabb {
            min: fc.bounds_min,
            max: fc.bounds_max,
        };
        let held_out = (!data.held_out.is_empty()).then(|| {
            evaluate(
                &trainer.field,
                &data.held_out,
                &field_bounds,
                &augmentation,
                trainer.light_codes().capture,
            )
        });
        let chamfer_m = truth_chamfer(spec, &trainer.field, &field_bounds, None)?;
        Ok(ModelBenchReport {
            room: room.to_string(),
            model: spec.name.clone(),
            kind: spec.kind,
            threads: rayon::current_num_threads(),
            rays: data.rays.len(),
            steps: trainer.state.step,
            train_seconds: trainer.state.elapsed_s,
            budget_clock: config.budget_clock,
            train_wall_seconds,
            load_seconds,
            eval_seconds: t0.elapsed().as_secs_f64(),
            held_out,
            noise_ceiling_psnr_db: noise_psnr_ceiling(&data.held_out),
            chamfer_m,
            inv_s: trainer.field.inv_s(),
            step_profile_ms: mean_ms(&trainer.state.profile),
        })
    })
}

/// Per-step means of a profile, in milliseconds.
fn mean_ms(p: &StepProfile) -> StepProfile {
    let k = 1e3 / p.steps.max(1) as f64;
    StepProfile {
        sample: p.sample * k,
        forward: p.forward * k,
        render: p.render * k,
        backward: p.backward * k,
        eikonal: p.eikonal * k,
        adam: p.adam * k,
        steps: p.steps,
    }
}

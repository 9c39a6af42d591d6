//! Training a room's models (the offline stage), with the budgets a user picks on the command line.

use std::path::Path;

/// The arithmetic of the fields' network products (`TrainOptions::mlp_precision`).
pub use neuroom_field::kernel::Precision as MlpPrecision;
use neuroom_identify::TrainSettings;
pub use neuroom_train::config::RefineWhen;

pub use neuroom_train::losses::LossParts;
pub use neuroom_train::progress::{
    Bar as TrainBar, Progress as TrainProgress, Quiet as TrainQuiet,
};
pub use neuroom_train::{Manifest, TrainConfig, TrainSummary, read_manifest};

/// Budget overrides on top of [`TrainConfig::default`].
#[derive(Clone, Debug, Default)]
pub struct TrainOptions {
    /// Most steps per object model.
    pub object_steps: Option<u64>,
    /// Most steps for the background model.
    pub background_steps: Option<u64>,
    /// Wall-clock budget per object model, seconds.
    pub object_seconds: Option<f64>,
    /// Wall-clock budget of the background model, seconds.
    pub background_seconds: Option<f64>,
    /// Rays per step of an object model (default: [`TrainConfig::default`]'s). Whether smaller
    /// batches over more steps learn more depends on the model (docs/experiment-log.md, 2026-12-04).
    pub object_batch_rays: Option<usize>,
    /// Rays per step of the background model.
    pub background_batch_rays: Option<usize>,
    /// Worker threads (0 = all cores).
    pub threads: usize,
    /// How many models train at once, each on its share of the threads (0 = one per thread while
    /// models are left); the models are the same whatever it is.
    pub models_at_once: usize,
    /// Seed of sampling and initialisation.
    pub seed: Option<u64>,
    /// Count the budgets in CPU seconds per worker thread (see [`neuroom_train::BudgetClock::Cpu`]).
    pub cpu_clock: bool,
    /// Wall-clock budget of the identification network, seconds (0 = do not build it). By default it
    /// is built, for [`TrainSettings::default`]'s seconds, only when locate's default detector needs
    /// it ([`DetectorChoice::needs_network`](crate::locate::DetectorChoice::needs_network)).
    pub identify_seconds: Option<f64>,
    /// Train only the models of these names (`background` or an object capture's name); empty: all.
    /// Each model is an independent job: the manifest lists every model finished so far, whichever
    /// call finished it, and is complete once all are there.
    pub only: Vec<String>,
    /// Which per-frame corrections (colour gains, poses) the models learn.
    pub frame_corrections: RefineWhen,
    /// Arithmetic of the fields' network products.
    pub mlp_precision: MlpPrecision,
}

impl TrainOptions {
    /// Step budgets only, a fixed seed and thread count, and no identification network: what the
    /// benchmarks train with (the validation suite, the baseline cases), so the same options give the
    /// same models on any load.
    pub fn steps_only(object_steps: u64, background_steps: u64, seed: u64, threads: usize) -> Self {
        Self {
            object_steps: Some(object_steps),
            background_steps: Some(background_steps),
            threads,
            seed: Some(seed),
            identify_seconds: Some(0.0),
            ..Self::default()
        }
    }

    /// The training configuration these options give. Budgets are steps unless a time budget is given:
    /// a model then trains exactly its steps, whatever the machine's load, and the same options give the
    /// same models. A time budget given alone ends the run by the clock; given with steps, whichever
    /// ends first.
    pub fn config(&self) -> TrainConfig {
        let mut c = TrainConfig::default();
        let budget =
            |b: &mut neuroom_train::ModelBudget, steps: Option<u64>, seconds: Option<f64>| {
                b.time_budget_s = seconds;
                b.steps = match (steps, seconds) {
                    (Some(s), _) => s,
                    (None, Some(_)) => neuroom_train::config::TIME_BUDGET_MAX_STEPS,
                    (None, None) => b.steps,
                };
            };
        budget(&mut c.object, self.object_steps, self.object_seconds);
        budget(
            &mut c.background,
            self.background_steps,
            self.background_seconds,
        );
        if let Some(rays) = self.object_batch_rays {
            c.object.batch_rays = rays;
        }
        if let Some(rays) = self.background_batch_rays {
            c.background.batch_rays = rays;
        }
        if let Some(seed) = self.seed {
            c.seed = seed;
        }
        c.threads = self.threads;
        c.models_at_once = self.models_at_once;
        if self.cpu_clock {
            c.budget_clock = neuroom_train::BudgetClock::Cpu;
        }
        c.frame_refinement.when = self.frame_corrections;
        c.mlp_precision = self.mlp_precision;
        c
    }
}

/// The configuration fields left out of [`TrainConfig`]'s serialised form while they hold their
/// default: `neuroom bench train --set` may still set them ([`crate::overrides::with_overrides`]).
pub const OPTIONAL_KEYS: &[&str] = &[
    "frame_refinement",
    "mlp_precision",
    "ray_choice",
    "unobserved_samples",
];

/// The names of the models a room needs (`background` first, then one per object capture): what
/// `--only` takes.
pub fn model_names(room: &neuroom_core::formats::Room) -> Vec<String> {
    neuroom_train::room::model_specs(room)
        .into_iter()
        .map(|spec| spec.name)
        .collect()
}

/// Trains (or resumes) every model of the room at `room` into `models/<room name>/`. Every file of the
/// room and every environment map is decoded and checked first, so a bad file fails in seconds, not after
/// hours of training.
pub fn train_room(
    room: &Path,
    models: &Path,
    options: &TrainOptions,
    progress: &dyn TrainProgress,
) -> anyhow::Result<TrainSummary> {
    let config = options.config();
    crate::inspect::inspect_room_with(room, &config.env_maps)?;
    let summary = neuroom_train::train_room(room, models, &config, &options.only, progress)?;
    if summary.manifest.complete {
        build_locate_database(&summary.dir, progress);
        let mut settings = TrainSettings::default();
        let used = crate::locate::LocateConfig::default()
            .detection
            .needs_network();
        settings.seconds =
            (options.identify_seconds).unwrap_or(if used { settings.seconds } else { 0.0 });
        if let Some(seed) = options.seed {
            settings.seed = seed;
        }
        if settings.seconds > 0.0 {
            build_identify_network(room, &summary.dir, &settings, progress)?;
        }
    }
    Ok(summary)
}

/// Trains the identification network once the localization database is there (kept when it is already
/// built; resumed from its checkpoint when interrupted).
fn build_identify_network(
    room: &Path,
    dir: &Path,
    settings: &TrainSettings,
    progress: &dyn TrainProgress,
) -> anyhow::Result<()> {
    if crate::identify::network_path(dir).exists() || !crate::locate::database_path(dir).exists() {
        return Ok(());
    }
    let total = settings.seconds.ceil() as u64;
    let stage = "identify network";
    progress.start(stage, 0, total);
    let network = crate::identify::build_identify_network(room, dir, settings, &mut |tick| {
        progress.note(
            stage,
            tick.seconds as u64,
            total,
            &format!("step {} loss {:.4}", tick.steps, tick.loss),
        );
    })?;
    progress.finish(
        stage,
        &match network {
            Some(network) => describe_network(&network),
            None => "no object model to identify".to_string(),
        },
    );
    Ok(())
}

/// One line describing a trained identification network.
pub fn describe_network(network: &neuroom_identify::Network) -> String {
    let Some(report) = &network.report else {
        return format!("{} classes", network.config.classes);
    };
    let losses = &report.log.losses;
    let first = losses.first().map_or(f32::NAN, |l| l.1);
    let last = losses.last().map_or(f32::NAN, |l| l.1);
    format!(
        "{} steps in {:.0} s, loss {first:.3} → {last:.3}; held-out pixels {:.1} % right, objects: \
         recall {:.1} %, precision {:.1} %",
        report.log.steps,
        report.log.seconds,
        100.0 * report.accuracy.pixel,
        100.0 * report.accuracy.object_recall,
        100.0 * report.accuracy.object_precision
    )
}

/// Renders the camera-localization database of `neuroom locate` once every model is trained (kept when
/// it is already there). A room the database cannot cover (e.g. too small for its camera grid) is reported
/// on the progress line and left to `neuroom locate`, which says why: the models themselves are fine.
fn build_locate_database(dir: &Path, progress: &dyn TrainProgress) {
    if crate::locate::database_path(dir).exists() {
        return;
    }
    let start = std::time::Instant::now();
    let stage = "locate database";
    progress.start(stage, 0, 0);
    let built = crate::locate::build_locate_database(
        dir,
        &neuroom_panorama::database::DatabaseConfig::default(),
        &mut |_, _| {},
    );
    progress.finish(
        stage,
        &match built {
            Ok(db) => format!(
                "{} panoramas of the empty room in {:.0} s",
                db.entries.len(),
                start.elapsed().as_secs_f64()
            ),
            Err(e) => format!("not built: {e:#}"),
        },
    );
}

/// One line describing a trained model and its held-out figures.
pub fn describe_model(m: &neuroom_train::ModelEntry) -> String {
    let eval = m
        .stats
        .eval
        .as_ref()
        .map_or("not evaluated".to_string(), |e| {
            format!(
                "held-out PSNR {:.2} dB, median depth error {:.1} mm, coverage {:.0} % ({} views), \
                 light codes [{}]",
                e.psnr_db,
                e.median_depth_error_m * 1000.0,
                e.coverage * 100.0,
                e.views,
                light_code_gains(&e.light_codes)
            )
        });
    let chamfer = m
        .stats
        .chamfer_m
        .map(|c| format!(", Chamfer {:.1} mm", c.mean * 1000.0))
        .unwrap_or_default();
    format!(
        "{:<14} {} steps in {:.0} s, inv_s {:.0}: {eval}{chamfer}",
        m.name, m.stats.steps, m.stats.train_seconds, m.stats.inv_s
    )
}

/// The PSNR gain of each augmentation map's light code over the capture's code, e.g. `studio +7.9 dB`.
pub(crate) fn light_code_gains(checks: &[neuroom_train::eval::LightCodeCheck]) -> String {
    let gains: Vec<String> = checks
        .iter()
        .map(|c| {
            format!(
                "{} {:+.1} dB",
                c.name,
                c.psnr_with_code_db - c.psnr_with_code_0_db
            )
        })
        .collect();
    gains.join(", ")
}

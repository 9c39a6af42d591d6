//! The baseline check: fast cases (the `tiny` and `studio` presets) run end to end — the room made,
//! trained with step budgets, every test panorama located — at fixed seeds, step budgets and thread
//! count, and their figures compared with the records committed under `bench/figures/`. A change that
//! moves what the code produces fails the check until its record is measured again
//! (`neuroom bench baseline CASE --record FILE`) and committed with it.

use std::path::Path;

use serde::{Deserialize, Serialize};

use crate::figures::{FigureRecord, LocateFigures, ModelFigures};
use crate::locate::{LocateConfig, PanoramaScore, bench_locate};
use crate::train::{TrainOptions, TrainProgress, train_room};

/// One fast case: a preset room and the budgets it is trained with.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaselineCase {
    /// The case's name (the preset's).
    pub name: String,
    /// Seed of the room and of training.
    pub seed: u64,
    /// Training steps per object model.
    pub object_steps: u64,
    /// Training steps of the background model.
    pub background_steps: u64,
    /// Worker threads of training and locate (the models do not depend on it; locate's figures may).
    pub threads: usize,
}

/// The names of the baseline cases.
pub const BASELINE_CASES: [&str; 2] = ["tiny", "studio"];

impl BaselineCase {
    /// The case of that name: the preset with short step budgets (a few minutes on 2 cores).
    pub fn named(name: &str) -> Option<Self> {
        BASELINE_CASES.contains(&name).then(|| Self {
            name: name.into(),
            seed: 0,
            object_steps: 300,
            background_steps: 300,
            threads: 2,
        })
    }

    /// The file name of the case's record under `bench/figures/`: numbered after the other rows, in
    /// the order of [`BASELINE_CASES`].
    pub fn record_name(&self) -> String {
        let order = BASELINE_CASES.iter().position(|c| *c == self.name);
        format!("{}-baseline-{}.json", 90 + order.unwrap_or(0), self.name)
    }

    /// The training options of the case: steps only, no identification network.
    pub fn options(&self) -> TrainOptions {
        let (objects, background) = (self.object_steps, self.background_steps);
        TrainOptions::steps_only(objects, background, self.seed, self.threads)
    }
}

/// Runs `case` in `work` (the room in `work/room`, its models in `work/models`; both reused when
/// there) and returns its figures as a record measured by `command`. `each` sees every panorama's score.
pub fn run_baseline(
    case: &BaselineCase,
    work: &Path,
    command: String,
    progress: &dyn TrainProgress,
    each: &mut (dyn FnMut(&PanoramaScore) + Send),
) -> anyhow::Result<FigureRecord> {
    let room = work.join("room");
    if !room.join("room.json").is_file() {
        crate::synth::synthesize(
            &case.name,
            &room,
            case.seed,
            None,
            &[],
            crate::synth::CapturePlacement::Isolated,
            &mut |_| {},
        )?;
    }
    let trained = train_room(&room, &work.join("models"), &case.options(), progress)?;
    anyhow::ensure!(
        trained.manifest.complete,
        "{}: training stopped before every model was done",
        trained.dir.display()
    );
    let config = LocateConfig::default();
    let (_, mean) = neuroom_train::room::with_threads(case.threads, || {
        bench_locate(&room, &trained.dir, &config, None, None, &mut |s| each(s))
    })?;
    let mut record = FigureRecord::measured_now(
        &format!(
            "{} room (CI baseline: {} / {} steps, initial poses)",
            case.name, case.object_steps, case.background_steps
        ),
        command,
        LocateFigures::from_locate_mean(&mean),
    );
    record.models = trained
        .manifest
        .models
        .iter()
        .map(|m| ModelFigures {
            name: m.name.clone(),
            steps: m.stats.steps,
            psnr_db: m.stats.eval.as_ref().map(|e| e.psnr_db),
            chamfer_mm: m.stats.chamfer_m.map(|c| 1000.0 * f64::from(c.mean)),
        })
        .collect();
    Ok(record)
}

/// How far a figure may move before the baseline check fails. On one machine with the same thread
/// count every figure repeats exactly (step budgets, fixed seeds), and CPUs with AVX-512 or AVX2 + FMA
/// train the same weights; another CPU may round sums differently (no fused multiply–add, libm), and
/// training carries those last bits into the weights. The bounds
/// admit that drift and stay well below what a change that matters moves (one object placed
/// elsewhere moves a two-object room's IoU by tens of points).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BaselineTolerance {
    /// Mean IoU, percentage points.
    pub iou_points: f64,
    /// Rotation errors, degrees.
    pub angle_deg: f64,
    /// Position errors, cm.
    pub position_cm: f64,
    /// Precision, recall and the share placed within 20 cm.
    pub share: f64,
    /// Camera rotation error, degrees.
    pub camera_deg: f64,
    /// Held-out PSNR, dB.
    pub psnr_db: f64,
    /// Chamfer distance, mm.
    pub chamfer_mm: f64,
}

impl Default for BaselineTolerance {
    fn default() -> Self {
        Self {
            iou_points: 2.0,
            angle_deg: 2.0,
            position_cm: 1.0,
            share: 0.05,
            camera_deg: 0.2,
            psnr_db: 0.2,
            chamfer_mm: 0.5,
        }
    }
}

/// A figure that moved beyond its tolerance.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct BaselineMismatch {
    /// Which figure.
    pub figure: String,
    /// The committed value (`None`: absent).
    pub expected: Option<f64>,
    /// The value measured now (`None`: absent).
    pub measured: Option<f64>,
    /// How far it may move.
    pub tolerance: f64,
}

/// The figures of `measured` that differ from `expected` by more than `tolerance` (NaN equals NaN: a
/// mean over no found object).
pub fn compare_baseline(
    expected: &FigureRecord,
    measured: &FigureRecord,
    tolerance: &BaselineTolerance,
) -> Vec<BaselineMismatch> {
    let (e, m, t) = (&expected.figures, &measured.figures, tolerance);
    let mut checks = vec![
        (
            "panoramas",
            Some(e.panoramas as f64),
            Some(m.panoramas as f64),
            0.0,
        ),
        (
            "IoU (%)",
            Some(e.iou_percent),
            Some(m.iou_percent),
            t.iou_points,
        ),
        ("ARE (°)", Some(e.are_deg), Some(m.are_deg), t.angle_deg),
        (
            "ARE up to symmetry (°)",
            e.are_up_to_symmetry_deg,
            m.are_up_to_symmetry_deg,
            t.angle_deg,
        ),
        ("APE (cm)", Some(e.ape_cm), Some(m.ape_cm), t.position_cm),
        ("precision", Some(e.precision), Some(m.precision), t.share),
        ("recall", Some(e.recall), Some(m.recall), t.share),
        (
            "placed within 20 cm",
            e.placed_share,
            m.placed_share,
            t.share,
        ),
        (
            "camera (cm)",
            e.camera_position_error_cm,
            m.camera_position_error_cm,
            t.position_cm,
        ),
        (
            "camera (°)",
            e.camera_rotation_error_deg,
            m.camera_rotation_error_deg,
            t.camera_deg,
        ),
    ]
    .into_iter()
    .map(|(name, a, b, tol)| (name.to_string(), a, b, tol))
    .collect::<Vec<_>>();
    let model = |name: &str| measured.models.iter().find(|m| m.name == name);
    for want in &expected.models {
        let got = model(&want.name);
        let psnr = got.and_then(|g| g.psnr_db);
        let chamfer = got.and_then(|g| g.chamfer_mm);
        checks.push((
            format!("{} PSNR (dB)", want.name),
            want.psnr_db,
            psnr,
            t.psnr_db,
        ));
        checks.push((
            format!("{} Chamfer (mm)", want.name),
            want.chamfer_mm,
            chamfer,
            t.chamfer_mm,
        ));
    }
    checks
        .into_iter()
        .filter(|(_, a, b, tol)| !within(*a, *b, *tol))
        .map(|(figure, expected, measured, tolerance)| BaselineMismatch {
            figure,
            expected,
            measured,
            tolerance,
        })
        .collect()
}

fn within(expected: Option<f64>, measured: Option<f64>, tolerance: f64) -> bool {
    match (expected, measured) {
        (Some(a), Some(b)) if a.is_nan() || b.is_nan() => a.is_nan() && b.is_nan(),
        (Some(a), Some(b)) => (a - b).abs() <= tolerance,
        (None, None) => true,
        _ => false,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(iou: f64, psnr: f64) -> FigureRecord {
        let mut r = FigureRecord::measured_now(
            "tiny",
            "neuroom bench baseline tiny".into(),
            LocateFigures {
                panoramas: 4,
                iou_percent: iou,
                are_deg: f64::NAN,
                ..LocateFigures::default()
            },
        );
        r.models = vec![ModelFigures {
            name: "vase".into(),
            steps: 300,
            psnr_db: Some(psnr),
            chamfer_mm: None,
        }];
        r
    }

    #[test]
    fn figures_within_their_tolerance_pass_and_others_are_named() {
        let t = BaselineTolerance::default();
        assert!(compare_baseline(&record(70.0, 25.0), &record(71.5, 25.1), &t).is_empty());
        let moved = compare_baseline(&record(70.0, 25.0), &record(60.0, 24.0), &t);
        let names: Vec<&str> = moved.iter().map(|m| m.figure.as_str()).collect();
        assert_eq!(names, ["IoU (%)", "vase PSNR (dB)"]);
    }

    #[test]
    fn a_model_missing_from_the_measurement_fails() {
        let mut measured = record(70.0, 25.0);
        measured.models.clear();
        let moved = compare_baseline(
            &record(70.0, 25.0),
            &measured,
            &BaselineTolerance::default(),
        );
        assert_eq!(moved.len(), 1);
        assert_eq!(moved[0].measured, None);
    }

    #[test]
    fn only_the_fast_presets_are_cases() {
        assert!(BaselineCase::named("tiny").is_some());
        assert!(BaselineCase::named("bedroom").is_none());
        let studio = BaselineCase::named("studio").unwrap();
        assert_eq!(studio.record_name(), "91-baseline-studio.json");
    }
}

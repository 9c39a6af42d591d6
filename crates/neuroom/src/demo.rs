//! `neuroom demo`: the whole mission on the embedded default, in one go — make a small synthetic room with
//! ground truth, check it, learn its models, locate the objects in its test panoramas (camera, objects,
//! holistic fit), evaluate them against the truth, render a tour and an edit of the solved room, and write
//! the report and the glTF export. Every stage keeps its outputs, so an interrupted demo picks up where it
//! stopped.

use std::cell::RefCell;
use std::path::{Path, PathBuf};
use std::time::Instant;

use neuroom_export::mesh::MeshDetail;
use neuroom_fit::{FitConfig, IterationLog};
use serde::Serialize;

use crate::eval::{EvalOptions, Evaluation, evaluate};
use crate::export::{ExportOptions, export};
use crate::inspect::{RoomReport, inspect_room};
use crate::locate::{LocateConfig, LocateProgress, LocateStep, locate, test_panoramas};
use crate::synth::{CapturePlacement, StageProgress, synthesize};
use crate::tour::{Generated, Lens, SequenceOutputs, TourPath, tour};
use crate::train::{TrainOptions, TrainProgress, TrainSummary, train_room};
use crate::view::ViewCamera;

/// How big a demo to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DemoSize {
    /// The `studio` room (three objects), short training, one panorama: about three minutes.
    Quick,
    /// The `bedroom` room, under a minute of training per object model and two for the room, two
    /// panoramas (one arrangement under both lightings).
    Full,
}

/// Where the demo writes and how big it is.
#[derive(Clone, Debug)]
pub struct DemoConfig {
    /// Output folder: `room/`, `models/`, `solved/`, `tour/`, `edit/` and the report go inside.
    pub out: PathBuf,
    /// Demo size.
    pub size: DemoSize,
    /// Seed of the synthetic room and of training.
    pub seed: u64,
}

/// Where the demo's outputs are.
#[derive(Clone, Debug, Serialize)]
pub struct DemoOutputs {
    /// The synthetic room folder.
    pub room: PathBuf,
    /// The trained models.
    pub models: PathBuf,
    /// The solved arrangements, one per located panorama.
    pub solved: Vec<PathBuf>,
    /// The tour of the first solved room (animated GIF; its frames beside it).
    pub tour: PathBuf,
    /// The edited arrangement and its render.
    pub edit: (PathBuf, PathBuf),
    /// The HTML report of the first solved room.
    pub report: PathBuf,
    /// Its glTF export.
    pub gltf: PathBuf,
}

/// What the demo made and measured.
#[derive(Clone, Debug, Serialize)]
pub struct DemoSummary {
    /// The room's check.
    pub report: RoomReport,
    /// The trained models.
    pub training: TrainSummary,
    /// The solved arrangements against the truth.
    pub evaluation: Evaluation,
    /// Where everything went.
    pub outputs: DemoOutputs,
    /// Seconds per stage, in order.
    pub seconds: Vec<(String, f64)>,
}

/// Progress of the demo's stages.
pub trait DemoProgress {
    /// A stage starts.
    fn stage(&mut self, name: &str);
    /// Progress of the synthetic room.
    fn synth(&mut self, p: StageProgress);
    /// Progress of training.
    fn train(&self) -> &dyn TrainProgress;
    /// `done` of `total` steps of the current stage's `label` (fit iterations, frames).
    fn count(&mut self, label: &str, done: usize, total: usize);
}

/// The demo's timer: stage names with their durations.
struct Stages<'a> {
    progress: &'a mut dyn DemoProgress,
    seconds: Vec<(String, f64)>,
    current: Option<(String, Instant)>,
}

impl<'a> Stages<'a> {
    fn begin(&mut self, name: &str) {
        self.end();
        self.progress.stage(name);
        self.current = Some((name.to_string(), Instant::now()));
    }

    fn end(&mut self) {
        if let Some((name, start)) = self.current.take() {
            self.seconds.push((name, start.elapsed().as_secs_f64()));
        }
    }
}

/// Runs the demo.
pub fn run(config: &DemoConfig, progress: &mut dyn DemoProgress) -> anyhow::Result<DemoSummary> {
    let mut stages = Stages {
        progress,
        seconds: Vec::new(),
        current: None,
    };
    let room = config.out.join("room");
    stages.begin("making the synthetic room (ground truth)");
    if !room.join("room.json").exists() {
        let preset = match config.size {
            DemoSize::Quick => "studio",
            DemoSize::Full => "bedroom",
        };
        let p = &mut *stages.progress;
        synthesize(
            preset,
            &room,
            config.seed,
            None,
            &[],
            CapturePlacement::Isolated,
            &mut |s| p.synth(s),
        )?;
    }
    stages.begin("checking every file of the room");
    let report = inspect_room(&room)?;
    stages.begin("learning the room's neural models");
    let training = train_room(
        &room,
        &config.out.join("models"),
        &train_options(config),
        stages.progress.train(),
    )?;
    let models = training.dir.clone();
    stages.begin("locating the objects in the test panoramas");
    let solved = locate_panoramas(config, &room, &models, stages.progress)?;
    stages.begin("evaluating against the ground truth");
    let evaluation = evaluate(
        &room,
        &solved,
        &EvalOptions {
            models: Some(models.clone()),
            render_width: eval_width(config),
        },
        &mut |_| {},
    )?;
    let first = &solved[0];
    stages.begin("rendering a tour of the solved room");
    let tour = render_tour(config, &models, first, stages.progress)?;
    stages.begin("editing the solved room");
    let edit = edit_room(config, &models, first)?;
    stages.begin("writing the report and the glTF export");
    let (report_html, gltf) = export_room(config, &room, &models, first)?;
    stages.end();
    Ok(DemoSummary {
        report,
        training,
        evaluation,
        outputs: DemoOutputs {
            room,
            models,
            solved,
            tour,
            edit,
            report: report_html,
            gltf,
        },
        seconds: stages.seconds,
    })
}

/// Training budgets for the demo size, in steps so that the demo prints the same figures on every run
/// and machine (with the same thread count); calibrated on 2 cores (docs/benchmarks.md, "The demo").
/// The identification network follows `neuroom train`'s default: built only when the locate default
/// the demo uses needs it.
fn train_options(config: &DemoConfig) -> TrainOptions {
    match config.size {
        // Three object models and the room in about 75 s of steps; held-out evaluation adds ~50 s.
        DemoSize::Quick => TrainOptions {
            object_steps: Some(300),
            background_steps: Some(300),
            seed: Some(config.seed),
            ..TrainOptions::default()
        },
        // Seven object models and the room, trained side by side, with their evaluations and the
        // localization database, within the whole demo's 15 minutes on 2 cores (docs/benchmarks.md,
        // "The demo"); `neuroom train` uses the full budgets.
        DemoSize::Full => TrainOptions {
            object_steps: Some(FULL_OBJECT_STEPS),
            background_steps: Some(FULL_BACKGROUND_STEPS),
            seed: Some(config.seed),
            ..TrainOptions::default()
        },
    }
}

/// Steps per object model of the full demo.
const FULL_OBJECT_STEPS: u64 = 800;
/// Steps of the full demo's room model.
const FULL_BACKGROUND_STEPS: u64 = 900;

/// How many test panoramas the demo locates.
fn panorama_count(config: &DemoConfig) -> usize {
    match config.size {
        DemoSize::Quick => 1,
        DemoSize::Full => 2,
    }
}

/// Width the evaluation re-renders panoramas at.
fn eval_width(config: &DemoConfig) -> u32 {
    match config.size {
        DemoSize::Quick => 256,
        DemoSize::Full => 512,
    }
}

/// The holistic fit after locate: the refinement setting; `--quick` halves its iterations (its initial
/// poses are already within about a centimetre, and the whole demo must stay under 3 minutes).
fn fit_config(config: &DemoConfig) -> FitConfig {
    let fit = FitConfig::refinement();
    match config.size {
        DemoSize::Quick => FitConfig {
            pose_iterations: fit.pose_iterations / 2,
            appearance_iterations: fit.appearance_iterations / 2,
            ..fit
        },
        DemoSize::Full => fit,
    }
}

/// Locates the first test panoramas (camera, objects, holistic fit) into `solved/`; already solved ones
/// are kept.
fn locate_panoramas(
    config: &DemoConfig,
    room: &Path,
    models: &Path,
    progress: &mut dyn DemoProgress,
) -> anyhow::Result<Vec<PathBuf>> {
    let dir = config.out.join("solved");
    let fit = fit_config(config);
    let total = fit.pose_iterations + fit.appearance_iterations;
    let mut solved = Vec::new();
    for (panorama, _) in test_panoramas(room)?
        .into_iter()
        .take(panorama_count(config))
    {
        let stem = panorama
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let out = dir.join(format!("{stem}.json"));
        if !out.exists() {
            std::fs::create_dir_all(&dir)?;
            let (locating, fitting) = (format!("{stem}: locate"), format!("{stem}: fit"));
            // Both reports go to the one display, one after the other.
            let shown = RefCell::new(&mut *progress);
            let mut stage =
                |step: LocateStep| shown.borrow_mut().count(&locating, step.done, step.total);
            let mut each =
                |log: &IterationLog| shown.borrow_mut().count(&fitting, log.iteration + 1, total);
            locate(
                room,
                models,
                &crate::locate::LocateInput {
                    images: std::slice::from_ref(&panorama),
                    intrinsics: None,
                    search_views: None,
                },
                &out,
                &LocateConfig::default(),
                Some(&fit),
                LocateProgress {
                    stage: &mut stage,
                    fit: &mut each,
                },
            )?;
        }
        solved.push(out);
    }
    Ok(solved)
}

/// An orbit through the solved room, as frames and an animated GIF.
fn render_tour(
    config: &DemoConfig,
    models: &Path,
    solved: &Path,
    progress: &mut dyn DemoProgress,
) -> anyhow::Result<PathBuf> {
    let gif = config.out.join("tour").join("orbit.gif");
    if !gif.exists() {
        let (frames, lens) = match config.size {
            DemoSize::Quick => (8, (160, 120)),
            DemoSize::Full => (16, (256, 192)),
        };
        let lens = Lens::Pinhole {
            width: lens.0,
            height: lens.1,
            fov_deg: 75.0,
        };
        tour(
            models,
            solved,
            &TourPath::Generated(Generated::Orbit(frames)),
            &lens,
            &SequenceOutputs::beside(&gif, None, 8.0),
            &mut |done, total| progress.count("frames", done, total),
        )?;
    }
    Ok(gif)
}

/// Turns the first object, moves the second and takes the last one out, settles what moved, and renders
/// the edited panorama.
fn edit_room(
    config: &DemoConfig,
    models: &Path,
    solved: &Path,
) -> anyhow::Result<(PathBuf, PathBuf)> {
    let dir = config.out.join("edit");
    let out = dir.join("edited.json");
    let png = out.with_extension("png");
    if !png.exists() {
        std::fs::create_dir_all(&dir)?;
        let arrangement = neuroom_core::formats::read_arrangement(solved)?;
        let ids: Vec<u16> = arrangement.objects.iter().map(|o| o.id).collect();
        let edit_file = dir.join("edit.json");
        std::fs::write(&edit_file, serde_json::to_vec_pretty(&demo_edits(&ids))?)?;
        let width = eval_width(config);
        crate::edit::edit_arrangement(
            models,
            solved,
            &edit_file,
            &out,
            Some(&ViewCamera::Panorama { width }),
        )?;
    }
    Ok((out, png))
}

/// The demo's edit file for objects `ids` (an edit file as `neuroom edit` reads it).
fn demo_edits(ids: &[u16]) -> serde_json::Value {
    let mut edits = Vec::new();
    if let Some(first) = ids.first() {
        edits.push(serde_json::json!({"op": "rotate", "object": first, "yaw_deg": 30.0}));
    }
    if let Some(second) = ids.get(1) {
        edits.push(serde_json::json!({"op": "move", "object": second, "by": [0.3, 0.0, 0.0]}));
    }
    if ids.len() > 2 {
        edits.push(serde_json::json!({"op": "remove", "object": ids[ids.len() - 1]}));
    }
    serde_json::json!({ "edits": edits })
}

/// The HTML report and glTF export of the first solved room, against its ground truth.
fn export_room(
    config: &DemoConfig,
    room: &Path,
    models: &Path,
    solved: &Path,
) -> anyhow::Result<(PathBuf, PathBuf)> {
    let report = config.out.join("report.html");
    let gltf = config.out.join("room.glb");
    let arrangement = neuroom_core::formats::read_arrangement(solved)?;
    let truth = room
        .join("panoramas")
        .join(&arrangement.image)
        .with_extension("json");
    let options = ExportOptions {
        gltf: Some(gltf.clone()),
        report: Some(report.clone()),
        truth: Some(truth),
        room: Some(room.to_path_buf()),
        panorama: Some(room.join("panoramas").join(&arrangement.image)),
        detail: MeshDetail::default(),
        render_width: eval_width(config),
        views: 2,
        ..ExportOptions::default()
    };
    export(models, solved, &options, &mut |_| {})?;
    Ok((report, gltf))
}

/// The default output folder of the demo.
pub fn default_out() -> &'static Path {
    Path::new("neuroom-demo")
}

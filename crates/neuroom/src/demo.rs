//! `neuroom demo`: the mission on the embedded default, in one go — make a small synthetic room with
//! ground truth, check it, and learn its models — printing where everything went and the figures.
//!
//! The later stages of the mission (locating objects in the test panoramas, evaluation, touring, editing,
//! the report) join this pipeline as they land; each stage is resumable, so an interrupted demo picks up
//! where it stopped.

use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::inspect::{RoomReport, inspect_room};
use crate::synth::{Progress as SynthProgress, synthesize};
use crate::train::{TrainOptions, TrainProgress, TrainSummary, train_room};

/// How big a demo to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DemoSize {
    /// The `tiny` room and short training: a few minutes.
    Quick,
    /// The `bedroom` room, one minute of training per object model and two for the room.
    Full,
}

/// Where the demo writes and how big it is.
#[derive(Clone, Debug)]
pub struct DemoConfig {
    /// Output folder: `room/` and `models/` go inside.
    pub out: PathBuf,
    /// Demo size.
    pub size: DemoSize,
    /// Seed of the synthetic room and of training.
    pub seed: u64,
}

/// What the demo made.
#[derive(Clone, Debug, Serialize)]
pub struct DemoSummary {
    /// The synthetic room folder.
    pub room: PathBuf,
    /// The room's check.
    pub report: RoomReport,
    /// The trained models.
    pub training: TrainSummary,
}

/// Progress of the demo's stages.
pub trait DemoProgress {
    /// A stage starts.
    fn stage(&mut self, name: &str);
    /// Progress of the synthetic room.
    fn synth(&mut self, p: SynthProgress);
    /// Progress of training.
    fn train(&self) -> &dyn TrainProgress;
}

/// Runs the demo.
pub fn run(config: &DemoConfig, progress: &mut dyn DemoProgress) -> anyhow::Result<DemoSummary> {
    let room = config.out.join("room");
    progress.stage("making the synthetic room (ground truth)");
    if !room.join("room.json").exists() {
        let preset = match config.size {
            DemoSize::Quick => "tiny",
            DemoSize::Full => "bedroom",
        };
        synthesize(preset, &room, config.seed, None, &[], &mut |p| {
            progress.synth(p)
        })?;
    }
    progress.stage("checking every file of the room");
    let report = inspect_room(&room)?;
    progress.stage("learning the room's neural models");
    let training = train_room(
        &room,
        &config.out.join("models"),
        &train_options(config),
        progress.train(),
    )?;
    Ok(DemoSummary {
        room,
        report,
        training,
    })
}

/// Training budgets for the demo size.
fn train_options(config: &DemoConfig) -> TrainOptions {
    match config.size {
        DemoSize::Quick => TrainOptions {
            object_steps: Some(300),
            background_steps: Some(300),
            object_seconds: Some(30.0),
            background_seconds: Some(45.0),
            seed: Some(config.seed),
            ..TrainOptions::default()
        },
        // Seven object models and the room in about ten minutes on 2 cores; `neuroom train` uses the full
        // budgets (5 minutes per object, 10 for the room).
        DemoSize::Full => TrainOptions {
            object_seconds: Some(60.0),
            background_seconds: Some(120.0),
            seed: Some(config.seed),
            ..TrainOptions::default()
        },
    }
}

/// The default output folder of the demo.
pub fn default_out() -> &'static Path {
    Path::new("neuroom-demo")
}

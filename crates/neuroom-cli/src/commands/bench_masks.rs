//! `neuroom bench masks ROOM`: automatic object masks against a room's true ones.

use std::path::PathBuf;

use neuroom::masks::{bench_background_models, bench_masks};
use neuroom::suite::SuiteTraining;
use neuroom::train::TrainBar;

/// The arguments of `bench masks`.
#[derive(clap::Args)]
pub struct MasksArgs {
    /// The room folder (objects captured in the room: `neuroom synth --objects-in-room`, or a suite
    /// room's `in_room/`).
    room: PathBuf,
    /// A model folder with the room's background model; default: trained with
    /// `--background-steps` into `--cache`.
    #[arg(long)]
    models: Option<PathBuf>,
    /// Where the background model is trained when `--models` is not given.
    #[arg(long, default_value = "suite-models")]
    cache: PathBuf,
    /// Training steps of the background model when it is trained here.
    #[arg(long, default_value_t = SuiteTraining::default().background_steps)]
    background_steps: u64,
    /// Worker threads of that training (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Also print the report as one JSON object.
    #[arg(long)]
    json: bool,
}

/// Runs the benchmark.
pub fn run(a: &MasksArgs) -> anyhow::Result<()> {
    let room = neuroom::read_room(&a.room)?;
    let models = match &a.models {
        Some(m) => m.clone(),
        None => bench_background_models(
            &a.room,
            &a.cache,
            a.background_steps,
            a.threads,
            &TrainBar::default(),
        )?,
    };
    let report = bench_masks(&room, &models, &mut |note| println!("== {note}"))?;
    for o in &report.objects {
        println!(
            "{:<16} IoU {:.4}  ({} frames, tolerance {:.1} mm)",
            o.name, o.iou, o.frames, o.tolerance_mm
        );
    }
    println!(
        "mean IoU {:.4}, worst {:.4} ({} objects)",
        report.mean_iou,
        report.worst_iou,
        report.objects.len()
    );
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    }
    Ok(())
}

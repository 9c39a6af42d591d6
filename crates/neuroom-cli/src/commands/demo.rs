//! `neuroom demo`: the whole pipeline on the embedded default room.

use std::path::PathBuf;

use neuroom::demo::{DemoConfig, DemoProgress, DemoSize};
use neuroom::synth::StageProgress;
use neuroom::train::{TrainBar, TrainProgress};

use crate::progress::StageBars;

/// Run the whole mission on the embedded default: make a synthetic room with ground truth, check it, learn
/// its models, locate the objects in its test panoramas, evaluate them, render a tour and an edit, and
/// write the report and a glTF export; then print where the outputs are and the metrics table.
/// Resumable: run it again after an interruption.
///
/// Examples:
///   `neuroom demo`                            (the bedroom, about 15 minutes on 2 cores)
///   `neuroom demo --quick --out quick-demo`   (the 3-object studio room, about 3 minutes)
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Output folder.
    #[arg(long, default_value = neuroom::demo::default_out().as_os_str())]
    out: PathBuf,
    /// The small version: a tiny room and short training (a few minutes).
    #[arg(long)]
    quick: bool,
    /// Seed of the room and of training.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Print the summary (room check, models, evaluation, outputs, seconds per stage) as JSON.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    record: super::record_args::RecordArgs,
}

/// Terminal progress for the demo's stages.
struct Terminal {
    bars: StageBars,
    train: TrainBar,
}

impl DemoProgress for Terminal {
    fn stage(&mut self, name: &str) {
        self.bars.finish();
        eprintln!("== {name}");
    }

    fn synth(&mut self, p: StageProgress) {
        self.bars.update(p.stage, p.done as u64, p.total as u64);
    }

    fn train(&self) -> &dyn TrainProgress {
        &self.train
    }

    fn count(&mut self, label: &str, done: usize, total: usize) {
        self.bars.update(label, done as u64, total as u64);
    }
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let config = DemoConfig {
        out: args.out,
        size: if args.quick {
            DemoSize::Quick
        } else {
            DemoSize::Full
        },
        seed: args.seed,
    };
    let mut terminal = Terminal {
        bars: StageBars::new(),
        train: TrainBar::default(),
    };
    let summary = neuroom::demo::run(&config, &mut terminal)?;
    terminal.bars.finish();
    let label = if args.quick {
        "studio, `neuroom demo --quick`"
    } else {
        "bedroom, `neuroom demo`"
    };
    let figures = neuroom::figures::LocateFigures::from_evaluation(&summary.evaluation);
    args.record.write(args.record.record(label, figures))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
        return Ok(());
    }
    print!("{}", summary.report);
    println!("models in {}:", summary.training.dir.display());
    for m in &summary.training.manifest.models {
        println!("  {}", neuroom::train::describe_model(m));
    }
    println!("\nsolved panoramas against the ground truth:");
    print!("{}", neuroom::eval::table(&summary.evaluation));
    let o = &summary.outputs;
    println!("\noutputs:");
    println!("  solved arrangements  {}", join(&o.solved));
    println!("  tour                 {}", o.tour.display());
    println!(
        "  edit                 {} (render {})",
        o.edit.0.display(),
        o.edit.1.display()
    );
    println!("  report               {}", o.report.display());
    println!("  glTF                 {}", o.gltf.display());
    let total: f64 = summary.seconds.iter().map(|(_, s)| s).sum();
    println!("\ntime per stage ({total:.0} s in all):");
    for (stage, seconds) in &summary.seconds {
        println!("  {seconds:7.1} s  {stage}");
    }
    Ok(())
}

fn join(paths: &[PathBuf]) -> String {
    paths
        .iter()
        .map(|p| p.display().to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

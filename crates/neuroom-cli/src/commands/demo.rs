//! `neuroom demo`: the whole pipeline on the embedded default room.

use std::path::PathBuf;

use neuroom::demo::{DemoConfig, DemoProgress, DemoSize};
use neuroom::synth::Progress as SynthProgress;
use neuroom::train::{TrainBar, TrainProgress};

use crate::progress::StageBars;

/// Run the mission on the embedded default: make a synthetic room with ground truth, check it, learn its
/// models, and print the figures. Resumable: run it again after an interruption.
///
/// Example: `neuroom demo --quick --out neuroom-demo`
#[derive(clap::Args)]
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

    fn synth(&mut self, p: SynthProgress) {
        self.bars.update(p.stage, p.done as u64, p.total as u64);
    }

    fn train(&self) -> &dyn TrainProgress {
        &self.train
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
    print!("{}", summary.report);
    println!("models in {}:", summary.training.dir.display());
    for m in &summary.training.manifest.models {
        println!("  {}", neuroom::train::describe_model(m));
    }
    Ok(())
}

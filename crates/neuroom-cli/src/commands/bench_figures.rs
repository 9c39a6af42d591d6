//! `neuroom bench table` and `neuroom bench baseline`: the README's results and training tables made
//! from the figure records under `bench/figures/` and `bench/training/`, and the fast cases whose
//! records CI checks.

use std::path::PathBuf;

use neuroom::baseline::{BaselineCase, BaselineTolerance, compare_baseline, run_baseline};
use neuroom::figures::{
    FigureRecord, RESULTS_TABLE, invocation, read_records, results_table, update_readme,
};
use neuroom::train::TrainBar;
use neuroom::training_figures::{TRAINING_TABLE, read_training_records, training_table};

use super::record_args::RecordArgs;

/// The options of `neuroom bench table`.
#[derive(clap::Args)]
pub struct TableArgs {
    /// The folder of figure records (`bench locate`, `bench baseline`, `demo`).
    #[arg(default_value = "bench/figures")]
    figures: PathBuf,
    /// The folder of training figure records (`bench train`).
    #[arg(long, default_value = "bench/training")]
    training: PathBuf,
    /// Put the tables into this README, each between its two markers, instead of printing them.
    #[arg(long)]
    readme: Option<PathBuf>,
    /// With `--readme`: change nothing, fail when the README's tables are not the ones the records
    /// give.
    #[arg(long, requires = "readme")]
    check: bool,
}

/// The options of `neuroom bench baseline`.
#[derive(clap::Args)]
pub struct BaselineArgs {
    /// The case: `tiny` or `studio`.
    #[arg(value_parser = clap::builder::PossibleValuesParser::new(neuroom::baseline::BASELINE_CASES))]
    case: String,
    /// Working folder for the room and its models (kept, so a second run only locates; models it
    /// holds from another budget are refused: remove the folder after changing the budgets).
    #[arg(long, default_value = "baseline-work")]
    work: PathBuf,
    /// Compare the figures with this committed record and fail when one moved beyond its tolerance.
    #[arg(long, value_name = "FILE")]
    check: Option<PathBuf>,
    #[command(flatten)]
    record: RecordArgs,
}

/// `neuroom bench table`.
pub fn table(args: &TableArgs) -> anyhow::Result<()> {
    let tables = [
        (RESULTS_TABLE, results_table(&read_records(&args.figures)?)),
        (
            TRAINING_TABLE,
            training_table(&read_training_records(&args.training)?),
        ),
    ];
    let Some(path) = &args.readme else {
        for (_, table) in &tables {
            println!("{table}");
        }
        return Ok(());
    };
    let changed = update_readme(path, &tables, !args.check)?;
    let sources = format!("{} and {}", args.figures.display(), args.training.display());
    if args.check {
        anyhow::ensure!(
            !changed,
            "{}: the tables are not the ones {sources} give; run `neuroom bench table --readme {}`",
            path.display(),
            path.display()
        );
        println!("{}: the tables match the records", path.display());
    } else {
        println!("{}: tables written from {sources}", path.display());
    }
    Ok(())
}

/// `neuroom bench baseline`.
pub fn baseline(args: &BaselineArgs) -> anyhow::Result<()> {
    let case = BaselineCase::named(&args.case)
        .ok_or_else(|| anyhow::anyhow!("no baseline case `{}`", args.case))?;
    let measured = run_baseline(
        &case,
        &args.work.join(&case.name),
        invocation(),
        &TrainBar::default(),
        &mut |s| {
            println!(
                "{}: camera {:.2} cm {:.3}°, P {:.2} R {:.2}, IoU {:.1} %, APE {:.1} cm",
                s.panorama,
                s.camera_position_error_cm,
                s.camera_rotation_error_deg,
                s.objects.precision,
                s.objects.recall,
                s.objects.mean_iou_percent.unwrap_or(0.0),
                s.objects.mean_position_error_cm.unwrap_or(f64::NAN),
            )
        },
    )?;
    println!("{}", serde_json::to_string_pretty(&measured)?);
    args.record.write(measured.clone())?;
    let Some(path) = &args.check else {
        return Ok(());
    };
    let expected = FigureRecord::read(path)?;
    let moved = compare_baseline(&expected, &measured, &BaselineTolerance::default());
    for m in &moved {
        println!(
            "moved: {}: committed {:?}, measured {:?} (tolerance {})",
            m.figure, m.expected, m.measured, m.tolerance
        );
    }
    anyhow::ensure!(
        moved.is_empty(),
        "{}: {} figures moved",
        path.display(),
        moved.len()
    );
    println!("{}: every figure within its tolerance", path.display());
    Ok(())
}

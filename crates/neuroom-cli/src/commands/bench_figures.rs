//! `neuroom bench table` and `neuroom bench baseline`: the README's results table made from the figure
//! records under `bench/figures/`, and the fast cases whose records CI checks.

use std::path::PathBuf;

use neuroom::baseline::{BaselineCase, BaselineTolerance, compare_baseline, run_baseline};
use neuroom::figures::{FigureRecord, invocation, read_records, results_table, update_readme};
use neuroom::train::TrainBar;

use super::record_args::RecordArgs;

/// The options of `neuroom bench table`.
#[derive(clap::Args)]
pub struct TableArgs {
    /// The folder of figure records.
    #[arg(default_value = "bench/figures")]
    figures: PathBuf,
    /// Put the table into this README, between its two figure markers, instead of printing it.
    #[arg(long)]
    readme: Option<PathBuf>,
    /// With `--readme`: change nothing, fail when the README's table is not the one the records give.
    #[arg(long, requires = "readme")]
    check: bool,
}

/// The options of `neuroom bench baseline`.
#[derive(clap::Args)]
pub struct BaselineArgs {
    /// The case: `tiny` or `studio`.
    #[arg(value_parser = clap::builder::PossibleValuesParser::new(neuroom::baseline::BASELINE_CASES))]
    case: String,
    /// Working folder for the room and its models (kept, so a second run only locates).
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
    let table = results_table(&read_records(&args.figures)?);
    let Some(path) = &args.readme else {
        print!("{table}");
        return Ok(());
    };
    let changed = update_readme(path, &table, !args.check)?;
    if args.check {
        anyhow::ensure!(
            !changed,
            "{}: the results table is not the one {} gives; run `neuroom bench table --readme {}`",
            path.display(),
            args.figures.display(),
            path.display()
        );
        println!("{}: the results table matches the records", path.display());
    } else {
        println!(
            "{}: results table written from {}",
            path.display(),
            args.figures.display()
        );
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

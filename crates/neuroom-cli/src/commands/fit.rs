//! `neuroom fit MODELS PANORAMA --init INIT.json -o OUT.json`: the holistic optimisation.

use std::path::PathBuf;

use neuroom::fit::FitConfig;

use crate::progress::StageBars;

/// Solve object poses, tone adjusters and light codes that explain a panorama, starting from initial poses
/// (an arrangement with the camera), through the trained room under physical constraints. Writes the
/// solved arrangement, `<OUT stem>.fit.json` (losses per iteration, relations, timings) and before/after
/// renders beside it.
///
/// Example: `neuroom fit models/bedroom rooms/bedroom/panoramas/bedroom_a0_l0.png --init init.json
/// --room rooms/bedroom -o solved.json`
#[derive(clap::Args)]
pub struct Args {
    /// A room's model folder (as written by `neuroom train`).
    models: PathBuf,
    /// The equirectangular panorama (width = 2 × height).
    panorama: PathBuf,
    /// Initial arrangement: the panorama camera and initial object poses (docs/formats.md arrangement).
    #[arg(long)]
    init: PathBuf,
    /// The room folder, whose room.json relation hints seed the relations.
    #[arg(long)]
    room: Option<PathBuf>,
    /// Output arrangement JSON.
    #[arg(short, long)]
    out: PathBuf,
    /// Pose iterations (stage 1).
    #[arg(long)]
    pose_iterations: Option<usize>,
    /// Light code and tone iterations with poses frozen (stage 2).
    #[arg(long)]
    appearance_iterations: Option<usize>,
    /// Rays per iteration.
    #[arg(long)]
    rays: Option<usize>,
    #[command(flatten)]
    light: super::search_args::ObjectLightArgs,
    /// Afterwards put each object back at its initial pose where the object search's colour model says
    /// that explains the panorama better, as `neuroom locate` checks its own fit (needs `--room`).
    #[arg(long, requires = "room")]
    check: bool,
    /// Refine initial poses that `neuroom locate --no-fit` found, as `neuroom locate`'s own fit does: no
    /// render-and-compare search of each object's position and yaw before stage 1, and smaller steps.
    #[arg(long)]
    no_search: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut config = if args.no_search {
        FitConfig::refinement()
    } else {
        FitConfig::default()
    };
    config.pose_iterations = args.pose_iterations.unwrap_or(config.pose_iterations);
    config.appearance_iterations = args
        .appearance_iterations
        .unwrap_or(config.appearance_iterations);
    config.rays = args.rays.unwrap_or(config.rays);
    let total = (config.pose_iterations + config.appearance_iterations) as u64;
    let mut bars = StageBars::new();
    let (outputs, report) = neuroom::fit::fit_panorama(
        &args.models,
        &neuroom::fit::FitInput {
            panorama: &args.panorama,
            init: &args.init,
            room: args.room.as_deref(),
            object_light: args.light.object_light.as_deref(),
            check: args.check,
        },
        &args.out,
        &config,
        &mut |log| bars.update("fit", log.iteration as u64 + 1, total),
    )?;
    bars.finish();
    let last = report.log.last();
    println!(
        "wrote {} ({} objects; final loss {:.5}); report {}, renders {} and {}",
        outputs.arrangement.display(),
        report.objects.len(),
        last.map_or(f64::NAN, |l| l.total() as f64),
        outputs.report.display(),
        outputs.before.display(),
        outputs.after.display()
    );
    if report.faulty_steps > 0 {
        eprintln!(
            "warning: {} steps with non-finite losses or gradients were skipped",
            report.faulty_steps
        );
    }
    for w in &report.warnings {
        eprintln!("warning: {w}");
    }
    Ok(())
}

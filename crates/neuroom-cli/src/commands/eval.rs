//! `neuroom eval ROOM ARRANGEMENT…`: the paper's table for solved arrangements against the ground truth.

use std::path::PathBuf;

use neuroom::eval::{EvalOptions, evaluate, table};

/// Score solved arrangements of a room's test panoramas against their ground truth (the arrangement
/// JSON beside each panorama in `ROOM/panoramas/`): 3D IoU, rotation error (ARE), position error (APE),
/// identification precision and recall, the camera's error, and, with `--models`, PSNR / SSIM / LPIPS of
/// the solved scene re-rendered from the panorama camera. LPIPS needs the AlexNet weights that
/// `python3 tools/setup_lpips.py` installs; without them that column stays empty.
///
/// Examples:
///   `neuroom eval rooms/bedroom solved/bedroom_a0_l0.json solved/bedroom_a0_l1.json`
///   `neuroom eval rooms/bedroom solved/*.json --models models/bedroom --json`
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// Room folder (holding room.json and panoramas/ with the ground truth).
    room: PathBuf,
    /// Solved arrangements (as `neuroom locate` or `neuroom fit` write them).
    #[arg(required = true)]
    arrangements: Vec<PathBuf>,
    /// The room's model folder: re-render each solved scene and compare it with its panorama.
    #[arg(long)]
    models: Option<PathBuf>,
    /// Width the re-rendered panorama is compared at (must divide the panorama's width).
    #[arg(long, default_value_t = 512)]
    width: u32,
    /// Print the evaluation as JSON instead of the table.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.width >= 2 && args.width.is_multiple_of(2),
        "--width must be even and at least 2"
    );
    let options = EvalOptions {
        models: args.models,
        render_width: args.width,
    };
    let evaluation = evaluate(&args.room, &args.arrangements, &options, &mut |path| {
        eprintln!("evaluating {}", path.display())
    })?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&evaluation)?);
    } else {
        print!("{}", table(&evaluation));
    }
    Ok(())
}

//! `neuroom relight MODELS ARRANGEMENT --from A --to B --frames N -o out.gif`: blend two lightings.

use std::path::PathBuf;

use neuroom::relight::{Blend, LightSpec};
use neuroom::tour::SequenceOutputs;

use super::pinhole::PinholeArgs;
use crate::progress::StageBars;

/// Render a sequence blending two lightings of a solved room: light codes and tone adjusters are
/// interpolated linearly from `--from` to `--to`. A lighting is a light code index (`0`), a light code
/// name from the model manifest (`capture`, `apartment`, `lobby`, `studio` for rooms lit by the
/// default maps), or `solved` (the fit's codes and tones). Writes PNG frames and a looping GIF.
///
/// Examples:
///   `neuroom relight models/bedroom solved.json --from solved --to studio --frames 24 -o relight.gif`
///   `neuroom relight models/bedroom arr.json --from 0 --to lobby --frames 12 -o day.gif --eye 1,1,1.6 --look-at 3,2,0.8`
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// A room's model folder (as written by `neuroom train`).
    models: PathBuf,
    /// Arrangement JSON placing the objects (a fit's output carries the solved lighting).
    arrangement: PathBuf,
    /// Lighting of the first frame: index, name or `solved`.
    #[arg(long)]
    from: LightSpec,
    /// Lighting of the last frame: index, name or `solved`.
    #[arg(long)]
    to: LightSpec,
    /// Number of frames, both ends included.
    #[arg(long, default_value_t = 24)]
    frames: usize,
    /// Output GIF.
    #[arg(short, long)]
    out: PathBuf,
    /// Folder of the PNG frames (default: `<out stem>_frames` beside the GIF).
    #[arg(long)]
    frames_dir: Option<PathBuf>,
    /// Frames per second of the GIF.
    #[arg(long, default_value_t = 12.0)]
    fps: f64,
    /// Image width (panorama height is half of it).
    #[arg(long, default_value_t = 512)]
    width: u32,
    #[command(flatten)]
    pinhole: PinholeArgs,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let camera = args.pinhole.camera(args.width, None);
    let outputs = SequenceOutputs::beside(&args.out, args.frames_dir.as_deref(), args.fps);
    let blend = Blend {
        from: args.from,
        to: args.to,
        frames: args.frames,
    };
    let mut bars = StageBars::new();
    let frames = neuroom::relight::relight(
        &args.models,
        &args.arrangement,
        &blend,
        &camera,
        &outputs,
        &mut |done, total| bars.update("relighting", done as u64, total as u64),
    )?;
    bars.finish();
    println!(
        "wrote {} frames to {} and {}",
        frames.len(),
        outputs.frames.display(),
        outputs.gif.display()
    );
    Ok(())
}

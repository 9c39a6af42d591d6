//! `neuroom synth`: write a ground-truth synthetic room.

use std::path::PathBuf;

use neuroom::synth::CapturePlacement;

use crate::progress::StageBars;

/// Generate a synthetic room with ground truth (captures, test panoramas, arrangements, meshes).
///
/// Example: `neuroom synth --preset bedroom --out rooms/bedroom --seed 7`
#[derive(clap::Args)]
pub struct Args {
    /// Preset: tiny, studio, bedroom, living or office.
    #[arg(long, default_value = "tiny")]
    preset: String,
    /// Output room folder (created; files in it are replaced).
    #[arg(long)]
    out: PathBuf,
    /// Random seed: the same seed gives byte-identical files.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// A Sweet Home 3D furniture catalog folder (e.g. from the Debian package sweethome3d-furniture).
    #[arg(long)]
    furniture: Option<PathBuf>,
    /// HDR environment maps (.hdr, .exr, .exr.js) for ambient light; default: the vendored ones.
    #[arg(long)]
    hdri: Vec<PathBuf>,
    /// Capture each object standing in the middle of the empty room, under the room's light, as a
    /// phone scan of it would be (true masks tell it from the room; `neuroom bench masks` makes
    /// them without), instead of alone.
    #[arg(long)]
    objects_in_room: bool,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut bars = StageBars::new();
    let summary = neuroom::synth::synthesize(
        &args.preset,
        &args.out,
        args.seed,
        args.furniture.as_deref(),
        &args.hdri,
        if args.objects_in_room {
            CapturePlacement::InRoom
        } else {
            CapturePlacement::Isolated
        },
        &mut |p| bars.update(p.stage, p.done as u64, p.total as u64),
    )?;
    bars.finish();
    if args.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        println!(
            "wrote room `{}` to {}: {} objects ({} models), {} capture views, {} panoramas, {:.1} s",
            summary.name,
            summary.room.display(),
            summary.objects,
            summary.object_captures,
            summary.capture_frames,
            summary.panoramas,
            summary.seconds.get("total").copied().unwrap_or(f64::NAN)
        );
    }
    Ok(())
}

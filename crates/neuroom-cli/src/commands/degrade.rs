//! `neuroom degrade ROOM --phone --out DIR`: a copy of a room whose captures look as a phone took them.

use std::path::PathBuf;

use crate::progress::StageBars;

/// Write a copy of a room whose captures look as a phone delivers them: LiDAR depth on a 256 × 192
/// grid over the frame's view with centimetre noise and holes on edges, poses off by 1–2 cm and 0.5–1°,
/// every frame exposed (±½ stop) and white-balanced on its own, 30 % of them blurred by motion, all
/// through JPEG 85. Panoramas, ground truth and meshes are copied unchanged. The same seed writes
/// the same files.
///
/// Example: `neuroom degrade rooms/bedroom --phone --out rooms/bedroom-phone`
#[derive(clap::Args)]
pub struct Args {
    /// The room folder to copy.
    room: PathBuf,
    /// Degrade as a phone would (the one degradation there is).
    #[arg(long, required = true)]
    phone: bool,
    /// The new room folder.
    #[arg(long)]
    out: PathBuf,
    /// Seed of the draws.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    debug_assert!(args.phone);
    let mut bars = StageBars::new();
    let degraded =
        neuroom::degrade::degrade_room(&args.room, &args.out, args.seed, &mut |d, t| {
            bars.update("degrade", d as u64, t as u64)
        })?;
    bars.finish();
    println!(
        "wrote {}: {} captures, {} frames as a phone takes them",
        degraded.room.display(),
        degraded.captures,
        degraded.frames
    );
    Ok(())
}

//! `neuroom masks ROOM --models DIR --object NAME`: an object's capture masked without annotation.

use std::path::PathBuf;

use neuroom::masks::{WorldBox, write_capture_masks};

/// Mask an object's capture without annotation: the object was scanned standing in its room (the
/// capture's poses in the room's world, as `neuroom synth --objects-in-room` writes them or an
/// import of a scan registered to the room), and the room's trained empty-room model says which
/// pixels are the room. The object is what stands in front of the room's surface inside `--box`
/// (or the box the free-space points propose), cleaned up across views. The masks go to the
/// capture's `masks/auto-*.png`, transforms.json names them; existing masks are replaced.
///
/// Example: `neuroom masks rooms/studio --models models/studio --object chair --box 1,1,0,2,2,1`
#[derive(clap::Args)]
pub struct Args {
    /// The room folder.
    room: PathBuf,
    /// A model folder with the room's background model (`neuroom train ROOM --only background`).
    #[arg(long)]
    models: PathBuf,
    /// The object (its name in room.json) whose capture to mask.
    #[arg(long)]
    object: String,
    /// The object's box in the room's world, two corners in metres: `x0,y0,z0,x1,y1,z1`.
    #[arg(long, value_parser = WorldBox::parse)]
    r#box: Option<WorldBox>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let room = neuroom::read_room(&args.room)?;
    let written = write_capture_masks(&room, &args.models, &args.object, args.r#box)?;
    let [lo, hi] = written.bounds;
    println!(
        "masked {} frames of {}: {:.1} % of the pixels on `{}`, box [{:.2}, {:.2}, {:.2}]–[{:.2}, {:.2}, {:.2}] m, tolerance {:.1} mm",
        written.frames,
        written.capture.display(),
        written.coverage * 100.0,
        args.object,
        lo[0],
        lo[1],
        lo[2],
        hi[0],
        hi[1],
        hi[2],
        written.tolerance_mm
    );
    Ok(())
}

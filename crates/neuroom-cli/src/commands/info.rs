//! `neuroom info ROOM`: decode and check every file of a room.

use std::path::PathBuf;

/// Decode and check every file of a room (room.json, captures, panoramas, meshes) and print what was found.
///
/// Example: `neuroom info ../shared/data/blender-lite`
#[derive(clap::Args)]
pub struct Args {
    /// Room folder (holding room.json) or the room.json file itself.
    room: PathBuf,
    /// Print the report as JSON instead of text.
    #[arg(long)]
    json: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let report = neuroom::inspect_room(&args.room)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print!("{report}");
    }
    Ok(())
}

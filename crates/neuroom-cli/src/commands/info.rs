//! `neuroom info ROOM`: decode and check every file of a room.

use std::path::PathBuf;

/// Decode and check every file of a room (room.json, every capture frame with its depth and mask, panoramas
/// with their side files, meshes, and the environment maps training uses) and print what was found and any
/// warning (conversions made, files nothing refers to). A bad file ends it with exit code 2 and a message
/// naming the file.
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

//! `neuroom edit MODELS ARRANGEMENT EDIT.json -o OUT.json`: move, rotate, remove or insert objects,
//! settle them onto their support and render the result.

use std::path::PathBuf;

use super::pinhole::PinholeArgs;

/// Edit an arrangement: move, rotate, remove objects, insert objects of this room's models or of
/// another room's model folder. Moved, turned and inserted objects are dropped along −z onto the floor
/// or the object under them (or lifted out of one they sink into). Writes the edited arrangement and
/// renders it to `<OUT stem>.png` (a panorama from the arrangement's camera, or a pinhole view).
///
/// The edit file:
///   `{ "edits": [ { "op": "move", "object": "chair", "to": [2.0, 1.5] },`
///   `             { "op": "move", "object": 3, "by": [0.2, 0, 0] },`
///   `             { "op": "rotate", "object": "desk", "yaw_deg": 90 },`
///   `             { "op": "remove", "object": "picture" },`
///   `             { "op": "insert", "model": "chair", "at": [1.0, 2.0], "yaw_deg": 30 },`
///   `             { "op": "insert", "model": "stool", "models": "../models/kitchen", "at": [2, 1] } ],`
///   `  "settle": true }`
///
/// Example:
///   `neuroom edit models/bedroom solved.json edit.json -o edited.json --width 512`
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// A room's model folder (as written by `neuroom train`).
    models: PathBuf,
    /// The arrangement to edit.
    arrangement: PathBuf,
    /// The edit file (JSON, see above).
    edit: PathBuf,
    /// Output arrangement JSON; the render goes beside it as `<stem>.png`.
    #[arg(short, long)]
    out: PathBuf,
    /// Render width (panorama height is half of it).
    #[arg(long, default_value_t = 512)]
    width: u32,
    #[command(flatten)]
    pinhole: PinholeArgs,
    /// Do not render the result.
    #[arg(long)]
    no_render: bool,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let camera = args.pinhole.camera(args.width, None);
    let camera = (!args.no_render).then_some(&camera);
    let out = neuroom::edit::edit_arrangement(
        &args.models,
        &args.arrangement,
        &args.edit,
        &args.out,
        camera,
    )?;
    for (id, dz) in &out.settled {
        println!("object {id}: settled by {:+.1} cm", 100.0 * dz);
    }
    println!("wrote {}", out.arrangement.display());
    if let Some(png) = out.render {
        println!("wrote {}", png.display());
    }
    Ok(())
}

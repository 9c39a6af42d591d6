//! `neuroom import FORMAT SRC --room DIR --name NAME`: a phone app's recording into a room folder.

use std::path::PathBuf;

use neuroom::import::{CaptureFormat, FrameSize, ImportOptions, WorldUp, import_capture};

use crate::progress::StageBars;

/// Import a recording of a capture app into a room folder as `captures/NAME/` (neuroom's capture
/// format: frames, depth, poses in a z-up world in metres). The empty room's recording, imported
/// as `--name background`, becomes the room's background (room.json is made when missing).
/// docs/capture.md says how to record with each app.
///
/// Example: `neuroom import stray scans/8f3a2c1b4d --room rooms/office --name background`
#[derive(clap::Args)]
pub struct Args {
    /// The recording's format: `nerfstudio` (a folder `ns-process-data` wrote: Polycam, Record3D,
    /// Metashape, COLMAP), `stray` (Stray Scanner) or `3d-scanner-app` (its raw "All Data" export).
    format: Format,
    /// The recording's folder.
    src: PathBuf,
    /// The room folder (created when missing).
    #[arg(long)]
    room: PathBuf,
    /// The capture's name: `background` for the empty room, else the object's.
    #[arg(long)]
    name: String,
    /// Width of the written frames in pixels (narrower recordings keep theirs).
    #[arg(long, default_value_t = ImportOptions::default().size.max_width)]
    width: u32,
    /// At most this many frames, evenly spread over the recording.
    #[arg(long, default_value_t = ImportOptions::default().max_frames)]
    max_frames: usize,
    /// The recording's up axis: `y` (ARKit), `z`, or `auto` (from the cameras). Default: the
    /// format's (`y` for Stray Scanner and 3D Scanner App, `auto` for nerfstudio data).
    #[arg(long)]
    up: Option<Up>,
    /// Metres per unit of the recording (a COLMAP reconstruction has its own scale).
    #[arg(long, default_value_t = 1.0)]
    scale: f64,
    /// Keep LiDAR depth of at least this confidence (0 low, 1 medium, 2 high).
    #[arg(long, default_value_t = ImportOptions::default().min_confidence)]
    min_confidence: u8,
}

/// The recording formats, as the command line names them.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    Nerfstudio,
    Stray,
    #[value(name = "3d-scanner-app")]
    ScannerApp,
}

/// Up axes, as the command line names them.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Up {
    Y,
    Z,
    Auto,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let format = match args.format {
        Format::Nerfstudio => CaptureFormat::Nerfstudio,
        Format::Stray => CaptureFormat::Stray,
        Format::ScannerApp => CaptureFormat::ScannerApp,
    };
    let options = ImportOptions {
        size: FrameSize {
            max_width: args.width,
        },
        max_frames: args.max_frames,
        up: args.up.map(|u| match u {
            Up::Y => WorldUp::Y,
            Up::Z => WorldUp::Z,
            Up::Auto => WorldUp::Auto,
        }),
        scale: args.scale,
        min_confidence: args.min_confidence,
    };
    let mut bars = StageBars::new();
    let imported = import_capture(
        format,
        &args.src,
        &args.room,
        &args.name,
        &options,
        &mut |done, total| bars.update("import", done as u64, total as u64),
    )?;
    bars.finish();
    println!(
        "wrote {}: {} frames, {} with depth{}",
        imported.dir.display(),
        imported.frames,
        imported.with_depth,
        if imported.background {
            "; room.json names it the room's background"
        } else {
            ""
        }
    );
    Ok(())
}

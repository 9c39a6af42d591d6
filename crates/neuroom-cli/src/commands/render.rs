//! `neuroom render MODELS ARRANGEMENT -o out.png`: render a trained room as an arrangement places it,
//! from one camera or along a camera path (a tour).

use std::path::PathBuf;

use neuroom::tour::{Generated, Lens, SequenceOutputs, TourPath};

use super::pinhole::PinholeArgs;
use crate::progress::StageBars;

/// Render a room's trained models placed by an arrangement, as a panorama from its camera or from any
/// pinhole viewpoint; optionally also the depth and the instance mask. With `--path`, `--orbit` or
/// `--walk` it renders a tour instead: numbered PNG frames and an animated GIF (`-o`). The solved
/// lighting and tone of a fit's arrangement (and of the `.fit.json` beside it) are applied.
///
/// Examples:
///   `neuroom render models/bedroom rooms/bedroom/panoramas/bedroom_a0_l0.json -o pano.png --width 512`
///   `neuroom render models/bedroom arr.json -o view.png --eye 1,1,1.6 --look-at 3,2,0.8 --fov 70`
///   `neuroom render models/bedroom solved.json --orbit 36 -o tour.gif --width 320`
///   `neuroom render models/bedroom solved.json --walk 48 --panorama -o walk.gif --width 512`
///   `neuroom render models/bedroom solved.json --path path.json -o path.gif`
///   (path.json: `[{"eye": [1, 1, 1.6], "look_at": [3, 2, 0.8]}, {"camera_to_world": [[…4 rows…]]}]`)
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// A room's model folder (as written by `neuroom train`: holds manifest.json).
    models: PathBuf,
    /// Arrangement JSON (docs/formats.md): where each object stands and the panorama camera.
    arrangement: PathBuf,
    /// Output colour PNG.
    #[arg(short, long)]
    out: PathBuf,
    /// Also write the depth (16-bit PNG, millimetres) here.
    #[arg(long)]
    depth: Option<PathBuf>,
    /// Also write the instance mask here.
    #[arg(long)]
    mask: Option<PathBuf>,
    /// Image width (panorama height is half of it).
    #[arg(long, default_value_t = 512)]
    width: u32,
    /// Pinhole image height (default: 3/4 of the width).
    #[arg(long)]
    height: Option<u32>,
    #[command(flatten)]
    pinhole: PinholeArgs,
    /// Tour along the camera poses of this JSON file; `-o` is then the GIF.
    #[arg(long, conflicts_with_all = ["orbit", "walk", "eye"])]
    path: Option<PathBuf>,
    /// Tour: N frames circling the room's centre, looking across it.
    #[arg(long, value_name = "N", conflicts_with_all = ["walk", "eye"])]
    orbit: Option<usize>,
    /// Tour: N frames walking a loop around the room, looking ahead.
    #[arg(long, value_name = "N", conflicts_with = "eye")]
    walk: Option<usize>,
    /// Tour frames as panoramas instead of pinhole views.
    #[arg(long)]
    panorama: bool,
    /// Folder of the tour's PNG frames (default: `<out stem>_frames` beside the GIF).
    #[arg(long)]
    frames: Option<PathBuf>,
    /// Frames per second of the tour's GIF.
    #[arg(long, default_value_t = 12.0)]
    fps: f64,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    if let Some(path) = tour_path(&args) {
        return run_tour(&args, &path);
    }
    let camera = args.pinhole.camera(args.width, args.height);
    let view = neuroom::view::render_arrangement(&args.models, &args.arrangement, &camera)?;
    neuroom::view::write_view(
        &view,
        &args.out,
        args.depth.as_deref(),
        args.mask.as_deref(),
    )?;
    println!(
        "wrote {} ({}×{})",
        args.out.display(),
        view.rgb.width,
        view.rgb.height
    );
    Ok(())
}

/// The tour asked for, if any.
fn tour_path(args: &Args) -> Option<TourPath> {
    if let Some(p) = &args.path {
        return Some(TourPath::File(p.clone()));
    }
    args.orbit
        .map(Generated::Orbit)
        .or(args.walk.map(Generated::Walk))
        .map(TourPath::Generated)
}

/// Renders a tour with a progress bar.
fn run_tour(args: &Args, path: &TourPath) -> anyhow::Result<()> {
    let lens = if args.panorama {
        Lens::Panorama { width: args.width }
    } else {
        Lens::Pinhole {
            width: args.width,
            height: args.height.unwrap_or(args.width * 3 / 4),
            fov_deg: args.pinhole.fov,
        }
    };
    let outputs = SequenceOutputs::beside(&args.out, args.frames.as_deref(), args.fps);
    let mut bars = StageBars::new();
    let n = neuroom::tour::tour(
        &args.models,
        &args.arrangement,
        path,
        &lens,
        &outputs,
        &mut |done, total| bars.update("rendering the tour", done as u64, total as u64),
    )?;
    bars.finish();
    println!(
        "wrote {n} frames to {} and {}",
        outputs.frames.display(),
        outputs.gif.display()
    );
    Ok(())
}

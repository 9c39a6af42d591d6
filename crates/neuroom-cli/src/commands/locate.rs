//! `neuroom locate ROOM MODELS PANORAMA -o ARRANGEMENT.json`: camera, objects and poses from a bare
//! panorama (or a photo with `--intrinsics`).

use std::cell::RefCell;
use std::path::PathBuf;

use neuroom::fit::{FitConfig, IterationLog};
use neuroom::locate::{LocateConfig, LocateProgress, LocateStep};

use crate::progress::StageBars;

/// Find the camera of a panorama in a trained room, find and identify the objects it shows with their
/// initial poses, then solve poses, tone and light codes by the holistic fit. Writes the arrangement
/// (docs/formats.md, with the camera), the initial one beside it (`<OUT stem>.init.json`) and the fit's report
/// and renders. The first run on a model folder builds its localization database (`locate.safetensors`).
/// A photo taken by a level camera works too, given its intrinsics: it is located and its objects
/// found within its field of view. Several images are several views of one arrangement: each is
/// located on its own and their objects are merged. (The holistic fit takes one panorama; other input
/// gets the initial poses.)
///
/// Example: `neuroom locate rooms/bedroom models/bedroom rooms/bedroom/panoramas/bedroom_a0_l0.png
/// -o arrangement.json`; for a photo: `neuroom locate rooms/bedroom models/bedroom photo.png
/// --intrinsics camera.json -o arrangement.json` with camera.json
/// `{"w": 640, "h": 480, "fl_x": 320, "fl_y": 320, "cx": 320, "cy": 240}`; for several photos of one
/// arrangement: `neuroom locate rooms/bedroom models/bedroom a.png b.png c.png --intrinsics
/// camera.json -o arrangement.json`
#[derive(clap::Args)]
pub struct Args {
    /// The room folder (room.json: object names, sizes and relation hints).
    room: PathBuf,
    /// The room's model folder (as written by `neuroom train`).
    models: PathBuf,
    /// The equirectangular panorama (width = 2 × height), or a photo with `--intrinsics`; several are
    /// views of one arrangement.
    #[arg(required = true)]
    images: Vec<PathBuf>,
    /// The photos' intrinsics: JSON with `transforms.json`'s camera keys (`w`, `h`, `fl_x`, `fl_y`,
    /// `cx`, `cy`, optional OPENCV distortion `k1`, `k2`, `p1`, `p2`). The camera must be level.
    #[arg(long)]
    intrinsics: Option<PathBuf>,
    /// Output arrangement JSON.
    #[arg(short, long)]
    out: PathBuf,
    #[command(flatten)]
    search: super::search_args::SearchArgs,
    /// Stop after the initial poses (no holistic fit).
    #[arg(long)]
    no_fit: bool,
    /// Write what the object search saw of each image into this folder: the image, the empty room
    /// under the image's light, that light, and their difference with the detected regions.
    #[arg(long)]
    search_views: Option<PathBuf>,
    /// Pose iterations of the fit (stage 1).
    #[arg(long)]
    pose_iterations: Option<usize>,
    /// Light code and tone iterations of the fit (stage 2).
    #[arg(long)]
    appearance_iterations: Option<usize>,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let mut fit = FitConfig::refinement();
    fit.pose_iterations = args.pose_iterations.unwrap_or(fit.pose_iterations);
    fit.appearance_iterations = args
        .appearance_iterations
        .unwrap_or(fit.appearance_iterations);
    let total = (fit.pose_iterations + fit.appearance_iterations) as u64;
    let config = args.search.apply(LocateConfig::default());
    // The stages and the fit take turns on the one display.
    let bars = RefCell::new(StageBars::new());
    let several = args.images.len() > 1;
    let mut stage = |step: LocateStep| {
        let mut bars = bars.borrow_mut();
        bars.update("locate", step.done as u64, step.total as u64);
        let what = step.stage.map_or("located", |s| s.name());
        bars.message(&match several {
            true => format!("{}: {what}", step.image),
            false => what.to_string(),
        });
    };
    let mut fitted = |log: &IterationLog| {
        bars.borrow_mut()
            .update("fit", log.iteration as u64 + 1, total)
    };
    let outputs = neuroom::locate::locate(
        &args.room,
        &args.models,
        &neuroom::locate::LocateInput {
            images: &args.images,
            intrinsics: args.intrinsics.as_deref(),
            search_views: args.search_views.as_deref(),
        },
        &args.out,
        &config,
        (!args.no_fit).then_some(&fit),
        LocateProgress {
            stage: &mut stage,
            fit: &mut fitted,
        },
    )?;
    bars.borrow_mut().finish();
    for (image, located) in args.images.iter().zip(&outputs.located) {
        println!(
            "{}: camera found in {:.1} s (alignment score {:.3}, confidence {:.2}); {} detections, {} \
             objects placed in {:.1} s",
            image.display(),
            located.seconds[0],
            located.camera.score,
            located.camera.confidence,
            located.detections,
            located.found.len(),
            located.seconds[1]
        );
        if let Some(warning) = &located.camera.warning {
            eprintln!("warning: {}: {warning}", image.display());
        }
    }
    if !outputs.fitted && !args.no_fit && (args.images.len() > 1 || args.intrinsics.is_some()) {
        println!("the holistic fit takes one panorama: the arrangement holds the initial poses");
    }
    println!(
        "initial arrangement: {}\narrangement: {}",
        outputs.init.display(),
        outputs.arrangement.display()
    );
    Ok(())
}

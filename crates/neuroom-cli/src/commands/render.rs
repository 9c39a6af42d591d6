//! `neuroom render MODELS ARRANGEMENT -o out.png`: render a trained room as an arrangement places it.

use std::path::PathBuf;

use glam::DVec3;
use neuroom::view::ViewCamera;

/// Render a room's trained models placed by an arrangement, as a panorama from its camera or from any
/// pinhole viewpoint; optionally also the depth and the instance mask.
///
/// Examples:
///   `neuroom render models/bedroom rooms/bedroom/panoramas/bedroom_a0_l0.json -o pano.png --width 512`
///   `neuroom render models/bedroom arr.json -o view.png --eye 1,1,1.6 --look-at 3,2,0.8 --fov 70`
#[derive(clap::Args)]
pub struct Args {
    /// A room's model folder (as written by `neuroom train`: holds manifest.json).
    models: PathBuf,
    /// Arrangement JSON (FORMAT.md): where each object stands and the panorama camera.
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
    /// Pinhole camera centre `x,y,z` in metres; without it, the panorama camera of the arrangement.
    #[arg(long, value_parser = parse_point, requires = "look_at")]
    eye: Option<DVec3>,
    /// Point the pinhole camera looks at, `x,y,z` in metres.
    #[arg(long, value_parser = parse_point, requires = "eye")]
    look_at: Option<DVec3>,
    /// Pinhole horizontal field of view, degrees.
    #[arg(long, default_value_t = 70.0)]
    fov: f64,
}

/// Parses `x,y,z`.
fn parse_point(s: &str) -> Result<DVec3, String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| format!("`{x}` is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(DVec3::new(*x, *y, *z)),
        _ => Err(format!(
            "expected three finite numbers `x,y,z`, found `{s}`"
        )),
    }
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    let camera = match (args.eye, args.look_at) {
        (Some(eye), Some(target)) => ViewCamera::Pinhole {
            width: args.width,
            height: args.height.unwrap_or(args.width * 3 / 4),
            fov_deg: args.fov,
            eye,
            target,
        },
        _ => ViewCamera::Panorama { width: args.width },
    };
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

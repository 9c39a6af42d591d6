//! `neuroom export MODELS ARRANGEMENT --gltf out.glb --report out.html --rrd out.rrd [--truth GT.json]`.

use std::path::PathBuf;

use neuroom::export::ExportOptions;
use neuroom::export::MeshDetail;

/// Export a solved room: `--gltf` writes one glTF 2.0 binary (the room and every object as meshes
/// extracted from their SDFs, vertex colours from the colour network under the solved lighting, objects
/// placed by their poses, the panorama camera); `--report` writes a self-contained HTML page (the input
/// panorama and the solved scene's render overlaid under a slider, views of the solved scene, the same
/// glTF in a 3D view to orbit and zoom, a top-down map against the ground truth, the metrics) that opens
/// offline in any browser with WebGL; `--rrd` writes a Rerun recording (the same meshes, the solved boxes and
/// the ground truth's, the camera, the input panorama) that opens with `rerun` 0.36 (`pip install
/// rerun-sdk==0.36.3`). `--rrd` needs a neuroom built with `--features rerun`.
///
/// Examples:
///   `neuroom export models/bedroom solved.json --gltf room.glb`
///   `neuroom export models/bedroom solved.json --gltf room.glb --report report.html \`
///   `    --truth rooms/bedroom/panoramas/bedroom_a0_l0.json`
///   `cargo build --release -p neuroom-cli --features rerun`
///   `neuroom export models/bedroom solved.json --rrd room.rrd \`
///   `    --truth rooms/bedroom/panoramas/bedroom_a0_l0.json && rerun room.rrd`
#[derive(clap::Args)]
#[command(verbatim_doc_comment)]
pub struct Args {
    /// A room's model folder (as written by `neuroom train`).
    models: PathBuf,
    /// The solved (or any) arrangement JSON.
    arrangement: PathBuf,
    /// Write the glTF binary (.glb) here.
    #[arg(long, required_unless_present_any = ["report", "rrd"])]
    gltf: Option<PathBuf>,
    /// Write the HTML report here.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Write a Rerun recording (.rrd) here (needs a build with `--features rerun`).
    #[arg(long)]
    rrd: Option<PathBuf>,
    /// Ground-truth arrangement: the report draws it and scores the arrangement against it; the
    /// recording shows its boxes.
    #[arg(long)]
    truth: Option<PathBuf>,
    /// The room folder (object sizes); by default the one holding the ground truth's `panoramas/`.
    #[arg(long)]
    room: Option<PathBuf>,
    /// The input panorama; by default the arrangement's `image` beside it or beside the ground truth.
    #[arg(long)]
    panorama: Option<PathBuf>,
    /// Mesh cell size of objects, millimetres.
    #[arg(long, default_value_t = 20.0)]
    object_cell_mm: f32,
    /// Mesh cell size of the room, millimetres.
    #[arg(long, default_value_t = 40.0)]
    room_cell_mm: f32,
    /// Width of the report's panorama render.
    #[arg(long, default_value_t = 512)]
    width: u32,
    /// Number of pinhole views in the report.
    #[arg(long, default_value_t = 2)]
    views: usize,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    anyhow::ensure!(
        args.object_cell_mm > 0.0 && args.room_cell_mm > 0.0,
        "cell sizes must be positive"
    );
    let options = ExportOptions {
        gltf: args.gltf,
        report: args.report,
        rrd: args.rrd,
        truth: args.truth,
        room: args.room,
        panorama: args.panorama,
        detail: MeshDetail {
            object_cell_m: args.object_cell_mm / 1000.0,
            room_cell_m: args.room_cell_mm / 1000.0,
            ..MeshDetail::default()
        },
        render_width: args.width,
        views: args.views,
        ..ExportOptions::default()
    };
    let start = std::time::Instant::now();
    let summary =
        neuroom::export::export(&args.models, &args.arrangement, &options, &mut |stage| {
            eprintln!("[{:6.1} s] {stage}", start.elapsed().as_secs_f64())
        })?;
    if let Some((path, vertices, triangles)) = &summary.gltf {
        println!(
            "wrote {} ({vertices} vertices, {triangles} triangles)",
            path.display()
        );
    }
    if let Some((psnr, ssim)) = summary.image_agreement {
        println!("solved render against the input: PSNR {psnr:.2} dB, SSIM {ssim:.3}");
    }
    if let Some(s) = &summary.score {
        let f = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.1}"));
        println!(
            "against the ground truth: IoU {} %, ARE {}°, APE {} cm, precision {:.0} %, recall {:.0} %",
            f(s.mean_iou_percent),
            f(s.mean_rotation_error_deg),
            f(s.mean_position_error_cm),
            100.0 * s.precision,
            100.0 * s.recall
        );
    }
    for path in [&summary.report, &summary.rrd].into_iter().flatten() {
        println!("wrote {}", path.display());
    }
    println!("done in {:.1} s", start.elapsed().as_secs_f64());
    Ok(())
}

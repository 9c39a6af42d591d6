//! `neuroom bench phone ROOM…`: each room and its `--phone` copy trained with the same step budgets
//! and compared on the room's own truth; with several rooms, the worst of them and locate over all
//! their panoramas.

use std::path::PathBuf;

use neuroom::bench_phone::{
    HeldOutFigures, PhoneBenchReport, PhoneBenchSpec, PhoneBenchSummary, bench_phone,
};
use neuroom::locate::LocateConfig;
use neuroom::suite::SuiteTraining;
use neuroom::train::TrainBar;

use super::frame_corrections_arg::FrameCorrectionsArg;

use super::bench_suite::describe_mean;

/// The arguments of `bench phone`.
#[derive(clap::Args)]
pub struct PhoneArgs {
    /// The room folders (several: locate is judged over all their panoramas).
    #[arg(required = true)]
    rooms: Vec<PathBuf>,
    /// Where the phone copy and both rooms' models are kept (a second run only scores).
    #[arg(long, default_value = "suite-models")]
    cache: PathBuf,
    /// Training steps per object model, for both.
    #[arg(long, default_value_t = SuiteTraining::default().object_steps)]
    object_steps: u64,
    /// Training steps of the background model, for both.
    #[arg(long, default_value_t = SuiteTraining::default().background_steps)]
    background_steps: u64,
    /// Worker threads of the training (0 = all cores); the same count gives the same models.
    #[arg(long, default_value_t = 0)]
    threads: usize,
    /// Seed of the degradation.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Per-frame corrections of both trainings: `capture` (the phone copy's captures ask for them,
    /// the room's do not), `always` or `never`.
    #[arg(long, value_enum, default_value_t)]
    frame_corrections: FrameCorrectionsArg,
    /// Compare the trainings only: no locate on the test panoramas.
    #[arg(long)]
    no_locate: bool,
    /// Also print the report as one JSON object.
    #[arg(long)]
    json: bool,
}

fn figures(f: &HeldOutFigures) -> String {
    let show =
        |v: Option<f64>, unit: &str| v.map_or("–".to_string(), |v| format!("{v:.2} {unit}"));
    format!(
        "PSNR {} (exposure matched {}), depth {} (offset {}), Chamfer {}",
        show(f.psnr_db, "dB"),
        show(f.psnr_exposure_matched_db, "dB"),
        show(f.median_depth_error_mm, "mm"),
        show(f.median_depth_offset_mm, "mm"),
        show(f.chamfer_mm, "mm")
    )
}

/// Runs the benchmark.
pub fn run(a: &PhoneArgs) -> anyhow::Result<()> {
    let training = SuiteTraining {
        object_steps: a.object_steps,
        background_steps: a.background_steps,
        threads: a.threads,
        frame_corrections: a.frame_corrections.into(),
        ..SuiteTraining::default()
    };
    let mut reports = Vec::with_capacity(a.rooms.len());
    for room in &a.rooms {
        let spec = PhoneBenchSpec {
            room: room.clone(),
            cache: a.cache.clone(),
            training: training.clone(),
            seed: a.seed,
            locate: (!a.no_locate).then(LocateConfig::default),
        };
        let report = bench_phone(&spec, &TrainBar::default(), &mut |note| {
            println!("== {note}")
        })?;
        print_room(&report);
        reports.push(report);
    }
    let summary = PhoneBenchSummary::of(reports);
    if summary.rooms.len() > 1 {
        let iou = summary.locate.as_ref().map_or(String::new(), |l| {
            format!(
                "; locate over {} panoramas: IoU {:.1} % → {:.1} % ({:.1} points, worst room {:.1})",
                l.panoramas,
                l.clean_iou_percent,
                l.phone_iou_percent,
                l.iou_loss_points,
                l.worst_room_iou_loss_points
            )
        });
        println!(
            "over {} rooms: PSNR up to {:.2} dB (exposure matched {:.2} dB), Chamfer up to {:+.2} mm; \
             truth aligned: PSNR up to {:.2} dB, Chamfer up to {:+.2} mm{iou}",
            summary.rooms.len(),
            summary.worst_psnr_loss_db,
            summary.worst_exposure_matched_psnr_loss_db,
            summary.worst_chamfer_increase_mm,
            summary.worst_aligned_psnr_loss_db,
            summary.worst_aligned_chamfer_increase_mm
        );
    }
    if a.json {
        println!("{}", serde_json::to_string(&summary)?);
    }
    Ok(())
}

/// One room's figures, as text.
fn print_room(report: &PhoneBenchReport) {
    println!("{}:", report.room);
    for m in &report.models {
        println!("{:<14} room:  {}", m.name, figures(&m.clean));
        println!("{:<14} phone: {}", "", figures(&m.phone));
        if let Some(aligned) = &m.phone_aligned {
            println!("{:<14} phone, truth aligned: {}", "", figures(aligned));
        }
        if let Some(p) = &m.poses {
            let refined = p.refined.map_or(String::new(), |r| {
                format!(", refined {:.2} cm / {:.2}°", r.position_cm, r.rotation_deg)
            });
            println!(
                "{:<14} poses: {} frames tracked {:.2} cm / {:.2}°{refined}",
                "", p.frames, p.tracked.position_cm, p.tracked.rotation_deg
            );
        }
    }
    if let Some(locate) = &report.locate {
        println!("{}", describe_mean("locate, room's models", &locate.clean));
        println!("{}", describe_mean("locate, phone's models", &locate.phone));
    }
    let iou = report.locate.as_ref().map_or(String::new(), |l| {
        format!(", IoU {:.1} points", l.iou_loss_points)
    });
    println!(
        "phone data cost: PSNR up to {:.2} dB (exposure matched {:.2} dB), Chamfer up to {:+.2} mm; \
         truth aligned: PSNR up to {:.2} dB, Chamfer up to {:+.2} mm{iou}",
        report.worst_psnr_loss_db,
        report.worst_exposure_matched_psnr_loss_db,
        report.worst_chamfer_increase_mm,
        report.worst_aligned_psnr_loss_db,
        report.worst_aligned_chamfer_increase_mm
    );
}

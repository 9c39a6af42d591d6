//! `neuroom bench locate --suite DIR…`: the validation suite, trained with step budgets (cached) and
//! located room by room; per panorama, per room, the mean over the rooms and the worst room.

use std::path::PathBuf;

use neuroom::CameraEffect;
use neuroom::figures::{LocateFigures, WorstRoom};
use neuroom::locate::{LocateConfig, LocateMean};
use neuroom::suite::{SuiteEvent, SuiteSpec, SuiteTraining};
use neuroom::train::TrainBar;

/// The options of `bench locate` that only the suite takes.
#[derive(clap::Args)]
pub struct SuiteArgs {
    /// Run the validation suite instead of one room: each DIR is a room folder or a folder of rooms
    /// (e.g. `suite ../shared/data/blender-lite`). Every room is trained with step budgets (kept in
    /// `--cache`, so a second run only locates), every test panorama located with the holistic fit,
    /// and the figures printed per room, as their mean over the rooms and for the worst room.
    #[arg(long, num_args = 1.., value_name = "DIR", conflicts_with_all = ["room", "models", "photos"])]
    pub suite: Vec<PathBuf>,
    /// Where the suite keeps the models it trained, one folder per room and training budget.
    #[arg(long, default_value = "suite-models", requires = "suite")]
    pub cache: PathBuf,
    /// Training steps per object model of the suite's rooms.
    #[arg(long, requires = "suite", default_value_t = SuiteTraining::default().object_steps)]
    pub object_steps: u64,
    /// Training steps of the suite's background models.
    #[arg(long, requires = "suite", default_value_t = SuiteTraining::default().background_steps)]
    pub background_steps: u64,
    /// Worker threads of the suite's training (0 = all cores); the same count gives the same models.
    #[arg(long, requires = "suite", default_value_t = 0)]
    pub threads: usize,
    /// Initial poses only: leave out the holistic fit that `neuroom locate`, and so the suite, runs.
    #[arg(long, requires = "suite")]
    pub no_fit: bool,
    /// Only train the suite's rooms into `--cache` (or find them there) and stop: makes the cache
    /// ready, e.g. at low priority in the background, before the suite is run.
    #[arg(long, requires = "suite")]
    pub train_only: bool,
}

/// Runs the suite with the locate pipeline `locate`; `json` adds one JSON object per panorama, per
/// room and for the suite.
pub fn run_suite(
    args: &SuiteArgs,
    locate: LocateConfig,
    effect: Option<CameraEffect>,
    print_panorama: &mut dyn FnMut(&neuroom::locate::PanoramaScore),
    json: bool,
    record: &super::record_args::RecordArgs,
) -> anyhow::Result<()> {
    let spec = SuiteSpec {
        dirs: args.suite.clone(),
        cache: args.cache.clone(),
        training: SuiteTraining {
            object_steps: args.object_steps,
            background_steps: args.background_steps,
            threads: args.threads,
            ..SuiteTraining::default()
        },
        locate,
        fit: (!args.no_fit).then(|| neuroom::fit::FitConfig {
            preview_height: None,
            ..neuroom::fit::FitConfig::refinement()
        }),
        effect,
    };
    if args.train_only {
        let trained =
            neuroom::suite::train_suite(&spec, &TrainBar::default(), &mut |room, models| {
                println!("== {room} (models in {})", models.display())
            })?;
        for room in &trained {
            println!("{}: models ready in {}", room.room, room.models.display());
        }
        return Ok(());
    }
    let mut failed = None;
    let report =
        neuroom::suite::bench_suite(&spec, &TrainBar::default(), &mut |event| match event {
            SuiteEvent::Training { room, models } => {
                println!("== {room} (models in {})", models.display());
            }
            SuiteEvent::Panorama { score, .. } => print_panorama(score),
            SuiteEvent::Room(room) => {
                println!("{}", describe_mean(&room.room, &room.mean));
                if json {
                    match serde_json::to_string(room) {
                        Ok(line) => println!("{line}"),
                        Err(e) => failed = Some(e),
                    }
                }
            }
        })?;
    if let Some(e) = failed {
        return Err(e.into());
    }
    println!();
    for room in &report.rooms {
        println!("{}", describe_mean(&room.room, &room.mean));
    }
    println!(
        "{}",
        describe_mean(
            &format!("mean of {} rooms", report.rooms.len()),
            &report.mean
        )
    );
    println!(
        "{}",
        describe_mean(
            &format!("worst room ({})", report.worst.room),
            &report.worst.mean
        )
    );
    if json {
        println!("{}", serde_json::json!({ "suite": report }));
    }
    let label = format!("validation suite, {} rooms", report.rooms.len());
    let mut row = record.record(&label, LocateFigures::from_locate_mean(&report.mean));
    // One room is its own worst room: the row would repeat.
    row.worst_room = (report.rooms.len() > 1).then(|| WorstRoom {
        room: report.worst.room.clone(),
        figures: LocateFigures::from_locate_mean(&report.worst.mean),
    });
    record.write(row)
}

/// One line of a room's (or the suite's) figures.
pub fn describe_mean(label: &str, m: &LocateMean) -> String {
    let initial = m.initial.map_or(String::new(), |[iou, _, ape]| {
        format!(" (initial poses: IoU {iou:.1} %, APE {ape:.1} cm)")
    });
    format!(
        "{label}: {} panoramas, camera {:.2} cm (max {:.2}) {:.3}° (max {:.3}), P {:.2} R {:.2}, \
         IoU {:.1} %, ARE {:.1}° ({:.1}° up to symmetry), APE {:.1} cm, placed within 20 cm {:.0} %, \
         {:.1} s per panorama{initial}",
        m.panoramas,
        m.camera_position_error_cm,
        m.camera_position_error_max_cm,
        m.camera_rotation_error_deg,
        m.camera_rotation_error_max_deg,
        m.precision,
        m.recall,
        m.iou_percent,
        m.are_deg,
        m.are_up_to_symmetry_deg,
        m.ape_cm,
        100.0 * m.placed_share,
        m.seconds
    )
}

//! `neuroom bench …`: the benchmarks behind the README's performance figures, as text and JSON.

use std::path::PathBuf;

use super::mlp_precision_arg::MlpPrecisionArg;
use neuroom::bench::{self, FieldBench};
use neuroom::figures::invocation;
use neuroom::training_figures::{TrainingFigureRecord, TrainingFigures};

/// Measure the performance figures the README reports.
///
/// Example: `neuroom bench field --json`
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    which: Which,
}

#[derive(clap::Subcommand)]
enum Which {
    /// Forward and forward+backward throughput of the neural field on points uniform in the unit cube.
    ///
    /// Without flags: the default object and room configurations on 65 536 and 262 144 points.
    /// Example: `neuroom bench field --log2-table 16 --finest 512 --n 65536 --json`
    Field(FieldArgs),
    /// Ray-traced samples per second of the synthetic-room renderer on a furnished panorama.
    ///
    /// Example: `neuroom bench synth --width 1024 --json`
    Synth(SynthArgs),
    /// The paper's Table 3: field queries, buffer memory and time per pose-fit iteration for 256 … 2048
    /// rays with the background + 1 and + 10 objects, safe-region against classical sampling.
    ///
    /// Example: `neuroom bench render --json`
    Render(RenderArgs),
    /// Train one model of a room from scratch with a time budget and report its held-out PSNR, depth
    /// error, Chamfer distance to the ground-truth mesh and light-code check.
    ///
    /// Example: `neuroom bench train rooms/bedroom chair --seconds 300 --json`
    Train(TrainArgs),
    /// The holistic fit on a room's trained models: for every test panorama with a ground truth, initial
    /// poses = ground truth + seeded noise (±25 cm, ±20° yaw, ±5° tilt), the camera known; mean IoU,
    /// ARE and APE before and after, and wall time. Optionally the paper's ablation, light adaptation
    /// (Table 2), safe-region against classical sampling (Table 3's convergence) and the timing case.
    ///
    /// Example: `neuroom bench fit rooms/bedroom models/bedroom --ablations --light --sampling --timing --json`
    Fit(FitArgs),
    /// Locate every test panorama of a room (`panoramas/*.png` with ground truth beside them) and score
    /// the camera, the identification and the initial poses against the ground truth (with `--fit`, also
    /// the poses the holistic fit solves from them).
    ///
    /// With `--photos N`, each test panorama is cut into N level photos (90° wide, 320 × 240), each
    /// located on its own and scored on the objects it shows.
    ///
    /// Example: `neuroom bench locate rooms/bedroom models/bedroom --fit --json`, or
    /// `neuroom bench locate rooms/bedroom models/bedroom --photos 4 --json`
    Locate(LocateArgs),
    /// Automatic object masks against the true ones: for every object captured standing in the room
    /// (`neuroom synth --objects-in-room`, or a validation suite room's `in_room/`), the masks
    /// `neuroom masks` makes with a proposed box, and their IoU with the capture's true masks over all
    /// frames; the mean and the worst object.
    ///
    /// Example: `neuroom bench masks suite/laundry/in_room --json`
    Masks(super::bench_masks::MasksArgs),
    /// The levelling of tilted panoramas, without models: for every test panorama of the rooms given,
    /// the error of the up direction `locate` would level it to, as taken and tilted by 10° about
    /// four axes; their mean, median and largest.
    ///
    /// Example: `neuroom bench level suite ../shared/data/blender-lite --json`
    Level(super::bench_level::LevelArgs),
    /// What phone data costs: the room and its `neuroom degrade --phone` copy trained with the same
    /// step budgets (cached in `--cache`); per model the held-out PSNR, depth error and Chamfer of
    /// both on the room's own views and meshes, and locate's figures with either's models on the
    /// same test panoramas.
    ///
    /// Example: `neuroom bench phone ../shared/data/blender-lite --json`
    Phone(super::bench_phone::PhoneArgs),
    /// The README's results table, made from the figure records (`bench/figures/*.json`) that the
    /// benchmarks write with `--record`.
    ///
    /// Example: `neuroom bench table --readme README.md` (or `--check` to only compare)
    Table(super::bench_figures::TableArgs),
    /// A fast case end to end (the `tiny` or `studio` room made, trained with short step budgets and
    /// every test panorama located) at fixed seeds and thread count: the figures CI checks against
    /// their committed record.
    ///
    /// Example: `neuroom bench baseline tiny --check bench/figures/90-baseline-tiny.json`
    Baseline(super::bench_figures::BaselineArgs),
}

#[derive(clap::Args)]
struct LocateArgs {
    /// Room folder (its `panoramas/` hold the test panoramas and their ground truth).
    #[arg(required_unless_present = "suite")]
    room: Option<PathBuf>,
    /// The room's model folder (as written by `neuroom train`).
    #[arg(required_unless_present = "suite")]
    models: Option<PathBuf>,
    #[command(flatten)]
    suite: super::bench_suite::SuiteArgs,
    /// Compare objects with the empty room under a global colour gain only, not re-shaded by the
    /// surface normal (the ablation of that step).
    #[arg(long)]
    no_shading: bool,
    /// Compare objects with the empty room under one light everywhere, not relit by the light as it
    /// varies over the panorama (the ablation of that step).
    #[arg(long)]
    no_local_light: bool,
    /// Relight the room and the objects also by a light at a point of the room, fitted under the
    /// light field (off by default; see docs/object-search.md).
    #[arg(long)]
    point_light: bool,
    /// Sub-pixels per pixel along each axis when the object search splats a hypothesis (by default
    /// 1: whole pixels, each its nearest point's colour, rims half covered; n: each pixel the share of
    /// its n × n sub-pixels the object covers, with their mean colour).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=4))]
    supersample: Option<u32>,
    /// Width of the panorama the object search works on (by default 512; the height is half of it):
    /// wider sees small, far objects in more pixels and costs time in proportion to the pixels.
    #[arg(long, value_parser = clap::value_parser!(u32).range(128..=4096))]
    object_width: Option<u32>,
    #[command(flatten)]
    search: super::search_args::SearchArgs,
    /// Also run the holistic fit from the initial poses (as `neuroom locate` does) and score its poses
    /// (the suite runs it unless `--no-fit`).
    #[arg(long, conflicts_with_all = ["photos", "suite"])]
    fit: bool,
    /// Locate photos cut from the panoramas instead: this many per panorama, at evenly spaced headings.
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=36))]
    photos: Option<u32>,
    /// Horizontal field of view of those photos (degrees).
    #[arg(long, default_value_t = 90.0, requires = "photos")]
    photo_fov: f64,
    /// Also merge each panorama's photos as views of one arrangement, scored against all its objects.
    #[arg(long, requires = "photos")]
    merge: bool,
    /// Give every panorama what a real camera does to it first: `tilt` (10°), `underexposed` (×0.5),
    /// `overexposed` (×2), `warm` or `cold` (another white balance), `jpeg` (quality 80) or `noise`
    /// (shot and read noise); a tilt tilts the true camera too.
    #[arg(long, value_parser = parse_effect, conflicts_with = "photos")]
    camera_effect: Option<neuroom::CameraEffect>,
    /// Also print each true object's IoU, rotation and position errors (or that it was missed), and
    /// the object search's objective at the found and at the true poses.
    #[arg(long)]
    objects: bool,
    /// A JSON object of locate-configuration fields to set over the others (`LocateConfig`'s serde
    /// names; nested objects merge key by key), for experiments: `{"search": {"min_contrast": 0.01}}`.
    #[arg(long, value_name = "FILE")]
    set: Option<PathBuf>,
    /// Print one JSON object per panorama and one for the mean, after the text.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    record: super::record_args::RecordArgs,
}

#[derive(clap::Args)]
struct FitArgs {
    /// Room folder (room.json, `panoramas/*.png` with ground-truth `*.json`).
    room: PathBuf,
    /// The room's model folder (as written by `neuroom train`).
    models: PathBuf,
    /// Panorama file stems to run (comma-separated; default: all with a ground truth).
    #[arg(long, value_delimiter = ',')]
    panoramas: Vec<String>,
    /// Seed of the pose noise and of the fit's sampling.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Pose noise bounds: horizontal position (cm), yaw (degrees), tilt (degrees).
    #[arg(long, value_delimiter = ',', default_values_t = [25.0, 20.0, 5.0])]
    noise: Vec<f64>,
    /// Skip the pose cases (run only the sections asked for below).
    #[arg(long)]
    skip_poses: bool,
    /// Also run the paper's ablation (w/o photometric, w/o physical, w/o observation, photometric only).
    #[arg(long)]
    ablations: bool,
    /// Light adaptation (Table 2): PSNR with no adaptation, tone only, light codes only, both.
    #[arg(long)]
    light: bool,
    /// Rows of the light-adaptation re-render (the input is box-filtered to them).
    #[arg(long, default_value_t = 256)]
    light_height: u32,
    /// Safe-region against classical sampling on the first panorama (Table 3's convergence).
    #[arg(long)]
    sampling: bool,
    /// Rays per iteration of the sampling comparison.
    #[arg(long, default_value_t = 256)]
    sampling_rays: usize,
    /// The timing case: 500 pose iterations of 1024 rays with 5 objects.
    #[arg(long)]
    timing: bool,
    /// Pose iterations of each fit (default: the fit's default).
    #[arg(long)]
    pose_iterations: Option<usize>,
    /// Stage-2 iterations (light adaptation runs and fits).
    #[arg(long)]
    appearance_iterations: Option<usize>,
    /// Rays on the objects per iteration.
    #[arg(long)]
    rays: Option<usize>,
    /// Print one JSON object per line after each text line.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct TrainArgs {
    /// Room folder.
    room: PathBuf,
    /// `background` or an object name from room.json.
    model: String,
    /// Optimisation steps (default: the training default for that kind of model).
    #[arg(long)]
    steps: Option<u64>,
    /// Time budget in seconds instead of steps (with `--steps`, whichever ends first).
    #[arg(long)]
    seconds: Option<f64>,
    /// Count the budget in CPU seconds per worker thread instead of wall-clock seconds, so other programs
    /// on the machine do not shrink it (it runs more steps than the same wall-clock seconds on an idle
    /// machine, where the threads also wait for each other).
    #[arg(long)]
    cpu_clock: bool,
    /// Arithmetic of the networks' products.
    #[arg(long, value_enum, default_value_t)]
    mlp_precision: MlpPrecisionArg,
    /// Rays per step (default: the training default for that kind of model).
    #[arg(long, value_parser = clap::value_parser!(u32).range(16..=65_536))]
    batch_rays: Option<u32>,
    /// A JSON object of training-configuration fields to set over the others (`TrainConfig`'s serde
    /// names; nested objects merge key by key), for experiments:
    /// `{"warmup_steps": 50, "object": {"batch_rays": 4096}}`.
    #[arg(long, value_name = "FILE")]
    set: Option<PathBuf>,
    /// Print the report as JSON after the text.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    record: super::record_args::RecordArgs,
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Print one JSON object after the table.
    #[arg(long)]
    json: bool,
    /// Timed iterations per row (the median is reported).
    #[arg(long, default_value_t = 3)]
    iterations: usize,
}

#[derive(clap::Args)]
struct SynthArgs {
    /// Print one JSON object after the text line.
    #[arg(long)]
    json: bool,
    /// Panorama width in pixels (height is half).
    #[arg(long, default_value_t = 1024)]
    width: u32,
    /// Seed of the room and its arrangement.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(clap::Args)]
struct FieldArgs {
    /// Print one JSON object per measurement (after the text lines).
    #[arg(long)]
    json: bool,
    /// Hash table size per level, log2 (measures a custom configuration based on the object one).
    #[arg(long)]
    log2_table: Option<u32>,
    /// Finest hash grid resolution (custom configuration).
    #[arg(long)]
    finest: Option<usize>,
    /// Number of points (repeatable; default 65536 and 262144).
    #[arg(long)]
    n: Vec<usize>,
    /// Worker threads.
    #[arg(long, default_value_t = 2)]
    threads: usize,
    /// Arithmetic of the networks' products.
    #[arg(long, value_enum, default_value_t)]
    mlp_precision: MlpPrecisionArg,
}

/// Runs the command.
pub fn run(args: Args) -> anyhow::Result<()> {
    match args.which {
        Which::Field(a) => {
            let spec = FieldBench {
                log2_table: a.log2_table,
                finest: a.finest,
                n: a.n,
                threads: a.threads,
                mlp_precision: a.mlp_precision.into(),
            };
            for report in bench::field(&spec)? {
                println!("{}", bench::describe_field(&report));
                if a.json {
                    println!("{}", serde_json::to_string(&report)?);
                }
            }
        }
        Which::Synth(a) => {
            let report = bench::synth(a.width, a.seed)?;
            println!("{}", bench::describe_synth(&report));
            if a.json {
                println!("{}", serde_json::to_string(&report)?);
            }
        }
        Which::Train(a) => train(&a)?,
        Which::Fit(a) => fit(a)?,
        Which::Locate(a) => run_locate(&a)?,
        Which::Masks(a) => super::bench_masks::run(&a)?,
        Which::Level(a) => super::bench_level::run(&a)?,
        Which::Phone(a) => super::bench_phone::run(&a)?,
        Which::Table(a) => super::bench_figures::table(&a)?,
        Which::Baseline(a) => super::bench_figures::baseline(&a)?,
        Which::Render(a) => {
            let report = bench::render(a.iterations)?;
            print!("{}", bench::describe_render(&report));
            if a.json {
                println!("{}", serde_json::to_string(&report)?);
            }
        }
    }
    Ok(())
}

/// `neuroom bench train`: one model trained and scored, kept as a training-table row with `--record`.
fn train(a: &TrainArgs) -> anyhow::Result<()> {
    let batch_rays = a.batch_rays.map(|rays| rays as usize);
    let options = neuroom::train::TrainOptions {
        object_steps: a.steps,
        background_steps: a.steps,
        object_seconds: a.seconds,
        background_seconds: a.seconds,
        object_batch_rays: batch_rays,
        background_batch_rays: batch_rays,
        cpu_clock: a.cpu_clock,
        mlp_precision: a.mlp_precision.into(),
        ..Default::default()
    };
    let mut config = options.config();
    if let Some(path) = &a.set {
        config = neuroom::overrides::from_file(
            &config,
            path,
            neuroom::train::OPTIONAL_KEYS,
            "training",
        )?;
    }
    let report = bench::train(&a.room, &a.model, &config)?;
    println!("{}", bench::describe_train(&report));
    if a.json {
        println!("{}", serde_json::to_string(&report)?);
    }
    let figures = TrainingFigures::from_report(&report, &config);
    a.record
        .write(TrainingFigureRecord::measured_now(invocation(), figures))
}

fn fit(a: FitArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.noise.len() == 3 && a.noise.iter().all(|v| v.is_finite() && *v >= 0.0),
        "--noise takes three non-negative numbers: centimetres, yaw degrees, tilt degrees"
    );
    let mut config = neuroom::fit::FitConfig::default();
    config.pose_iterations = a.pose_iterations.unwrap_or(config.pose_iterations);
    config.appearance_iterations = a
        .appearance_iterations
        .unwrap_or(config.appearance_iterations);
    config.rays = a.rays.unwrap_or(config.rays);
    let spec = neuroom::bench_fit::FitBench {
        room: a.room,
        models: a.models,
        panoramas: a.panoramas,
        seed: a.seed,
        noise: neuroom::bench_fit::PoseNoise {
            position_m: a.noise[0] / 100.0,
            yaw_deg: a.noise[1],
            tilt_deg: a.noise[2],
        },
        config,
        poses: !a.skip_poses,
        ablations: a.ablations,
        light_height: a.light.then_some(a.light_height),
        light_iterations: config.appearance_iterations,
        sampling: a
            .sampling
            .then_some((a.sampling_rays, config.pose_iterations)),
        timing_iterations: a.timing.then_some(500),
    };
    let mut failed = None;
    neuroom::bench_fit::fit_bench(&spec, &mut |row| {
        println!("{}", neuroom::bench_fit::describe(row));
        if a.json {
            match serde_json::to_string(row) {
                Ok(line) => println!("{line}"),
                Err(e) => failed = Some(e),
            }
        }
    })?;
    failed.map_or(Ok(()), |e| Err(e.into()))
}

/// `neuroom bench locate`: camera, identification and initial-pose scores per panorama and their mean.
fn run_locate(a: &LocateArgs) -> anyhow::Result<()> {
    let defaults = neuroom::locate::LocateConfig::default();
    let mut config = a.search.apply(neuroom::locate::LocateConfig {
        match_shading: !a.no_shading,
        local_light: (defaults.local_light.clone())
            .filter(|_| !a.no_local_light)
            .map(|l| neuroom::locate::LocalLightConfig {
                point_light: a.point_light,
                ..l
            }),
        ..defaults
    });
    if let Some(n) = a.supersample {
        config.search.supersample = n as usize;
    }
    if let Some(w) = a.object_width {
        config.object_width = w as usize;
    }
    if let Some(path) = &a.set {
        config = neuroom::overrides::from_file(&config, path, &[], "locate")?;
    }
    let fit = neuroom::fit::FitConfig {
        preview_height: None,
        ..neuroom::fit::FitConfig::refinement()
    };
    let fit = a.fit.then_some(&fit);
    let room = match (&a.room, a.objects) {
        (Some(dir), true) => Some(neuroom::read_room(dir)?),
        _ => None,
    };
    let mut each = |s: &neuroom::locate::PanoramaScore| {
        if let Some(i) = &s.initial {
            println!(
                "{}: initial poses IoU {:.1} %, ARE {:.1}°, APE {:.1} cm; after the fit:",
                s.panorama,
                i.mean_iou_percent.unwrap_or(0.0),
                i.mean_rotation_error_deg.unwrap_or(f64::NAN),
                i.mean_position_error_cm.unwrap_or(f64::NAN),
            );
        }
        println!(
            "{}: camera {:.2} cm {:.3}° (tilt {:.1}°, score {:.2}, first round {:.2} / other {:.2}, \
             confidence {:.2}{}), P {:.2} R {:.2}, IoU {:.1} %, ARE {:.1}° ({:.1}° up to symmetry), APE {:.1} cm, \
             placed {:.0} %, {:.1} s",
            s.panorama,
            s.camera_position_error_cm,
            s.camera_rotation_error_deg,
            s.located.camera.tilt_deg,
            s.located.camera.score,
            s.located.camera.first_round,
            s.located.camera.other_place.unwrap_or(f64::NAN),
            s.located.camera.confidence,
            if s.located.camera.warning.is_some() {
                ", said lost"
            } else {
                ""
            },
            s.objects.precision,
            s.objects.recall,
            s.objects.mean_iou_percent.unwrap_or(0.0),
            s.objects.mean_rotation_error_deg.unwrap_or(f64::NAN),
            s.objects
                .mean_rotation_error_up_to_symmetry_deg
                .unwrap_or(f64::NAN),
            s.objects.mean_position_error_cm.unwrap_or(f64::NAN),
            100.0 * s.objects.placed_share,
            s.seconds
        );
        if let Some(room) = &room {
            for line in neuroom::score::object_lines(room, &s.objects) {
                println!("  {line}");
            }
            if let Some(c) = &s.camera_objective {
                let verdict = if c.truth > c.found + 0.005 {
                    "the true camera correlates better: the search missed it"
                } else {
                    "the found camera correlates at least as well as the true one"
                };
                println!(
                    "  camera correlation: found {:.3}, truth {:.3}; {verdict}",
                    c.found, c.truth
                );
            }
            if let Some(o) = &s.objective {
                let verdict = if o.truth < o.found {
                    "the truth explains the panorama better: the search missed it"
                } else {
                    "the found poses explain the panorama at least as well as the truth"
                };
                println!(
                    "  search objective (colour error): found {:.1}, truth {:.1}; {verdict}",
                    o.found, o.truth
                );
                for t in &o.truth_standings {
                    let id = t.id;
                    let name = room.objects.iter().find(|r| r.id == id);
                    println!(
                        "  {} (id {id}) at its true pose: score {:.1} over {} pixels ({:.0} % of \
                         those it shows), {}",
                        name.map_or("?", |r| r.name.as_str()),
                        t.score,
                        t.explained,
                        100.0 * t.precision,
                        if t.accepted { "accepted" } else { "refused" }
                    );
                }
            }
        }
        if a.json {
            println!("{}", serde_json::to_string(s).unwrap_or_default());
        }
    };
    if !a.suite.suite.is_empty() {
        return super::bench_suite::run_suite(
            &a.suite,
            config,
            a.camera_effect,
            &mut each,
            a.json,
            &a.record,
        );
    }
    let (Some(room_dir), Some(models)) = (&a.room, &a.models) else {
        anyhow::bail!("bench locate needs ROOM and MODELS, or --suite DIR…");
    };
    let mean = match a.photos {
        Some(n) => {
            anyhow::ensure!(
                a.photo_fov > 1.0 && a.photo_fov < 170.0,
                "--photo-fov: {} is not a field of view between 1° and 170°",
                a.photo_fov
            );
            let cut = neuroom::locate_photos::PhotoCut {
                per_panorama: n as usize,
                horizontal_fov_deg: a.photo_fov,
                merge: a.merge,
                ..Default::default()
            };
            let bench = neuroom::locate_photos::bench_locate_photos(
                room_dir, models, &config, &cut, &mut each,
            )?;
            if let Some((_, merged)) = &bench.merged {
                print_locate_mean("merged photos", merged, a.json)?;
            }
            bench.photos.1
        }
        None => {
            let effect = a.camera_effect.as_ref();
            neuroom::locate::bench_locate(room_dir, models, &config, fit, effect, &mut each)?.1
        }
    };
    print_locate_mean("", &mean, a.json)?;
    let name = neuroom::read_room(room_dir)?.name;
    let figures = neuroom::figures::LocateFigures::from_locate_mean(&mean);
    a.record.write(a.record.record(&name, figures))
}

/// A camera effect by name ([`neuroom::CameraEffect::named`]).
fn parse_effect(name: &str) -> Result<neuroom::CameraEffect, String> {
    neuroom::CameraEffect::named(name).ok_or_else(|| {
        format!(
            "unknown camera effect `{name}` (one of {})",
            neuroom::CameraEffect::NAMES.join(", ")
        )
    })
}

/// Prints the mean of `neuroom bench locate` (labelled `label` when not empty), and with `json` as JSON.
fn print_locate_mean(
    label: &str,
    mean: &neuroom::locate::LocateMean,
    json: bool,
) -> anyhow::Result<()> {
    let text_label = if label.is_empty() { "mean" } else { label };
    println!("{}", super::bench_suite::describe_mean(text_label, mean));
    if json {
        let mut value = serde_json::to_value(mean)?;
        if !label.is_empty() {
            value["of"] = label.into();
        }
        println!("{value}");
    }
    Ok(())
}

//! Short trainings on analytic scenes: the reached figures, exact resumption, and a whole room with its
//! model folder.

mod common;

use glam::Vec3;
use neuroom_core::formats::read_room;
use neuroom_core::formats::{DepthNoise, read_capture};
use neuroom_core::surface::{Grid, chamfer, extract_surface};
use neuroom_train::augment::Augmentation;
use neuroom_train::config::{FrameRefinement, RefineWhen};
use neuroom_train::dataset::{Aabb, Dataset, LoadOptions, Role};
use neuroom_train::eval::{evaluate, extract_mesh};
use neuroom_train::progress::Quiet;
use neuroom_train::ray_choice::RayChoice;
use neuroom_train::rng::Pcg32;
use neuroom_train::room::{load_model_data, model_specs, with_threads};
use neuroom_train::{ModelKind, ObjectStart, TrainConfig, Trainer, load_room_models, train_room};

/// A fast configuration for tests: small batches and tables, no time budget, no augmentation.
fn quick_config(steps: u64) -> TrainConfig {
    let mut c = TrainConfig::default();
    for b in [&mut c.object, &mut c.background] {
        b.steps = steps;
        b.time_budget_s = None;
        b.batch_rays = 512;
        b.log2_table = 14;
        b.finest_resolution = 256;
    }
    c.env_maps.clear();
    c.holdout = 5;
    c.checkpoint_every = 0;
    c
}

fn ball_data(dir: &std::path::Path) -> Dataset {
    object_data(dir, &common::ball(0.15), 0.7)
}

/// The capture of the analytic object `field` seen by 20 small cameras orbiting it at `distance`, as
/// the dataset of object 1.
fn object_data(
    dir: &std::path::Path,
    field: &neuroom_field::AnalyticField,
    distance: f64,
) -> Dataset {
    let cam = neuroom_core::camera::Pinhole::new(48, 48, 40.0, 40.0, 24.0, 24.0);
    common::write_analytic_capture(dir, field, &common::orbit(20, distance), cam, 1);
    let capture = read_capture(dir).unwrap();
    let role = Role::Object {
        ids: vec![1],
        capture_to_object: neuroom_core::Pose::IDENTITY,
    };
    Dataset::load(
        &capture,
        &role,
        &LoadOptions {
            holdout: 5,
            bounds: None,
        },
    )
    .unwrap()
}

const BALL_BOX: Aabb = Aabb {
    min: [-0.15; 3],
    max: [0.15; 3],
};

#[test]
fn a_poisoned_field_stops_with_a_divergence_error_not_nan_weights() {
    let dir = tempfile::tempdir().unwrap();
    let data = ball_data(dir.path());
    let config = quick_config(100);
    let aug = Augmentation::default();
    let mut trainer = Trainer::new(&data, &aug, &config, ModelKind::Object, BALL_BOX);
    let sdf = trainer.field.params.get_mut(neuroom_field::Group::SdfMlp);
    sdf[0] = f32::NAN;
    let before = trainer.field.params.clone();
    let err = trainer.run("ball", None, &Quiet).unwrap_err();
    assert!(
        matches!(
            err,
            neuroom_train::room::TrainError::Diverged { step: 20, .. }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("ball: training diverged"), "{err}");
    // No faulty step was applied: every other parameter is untouched.
    let after = &trainer.field.params;
    for g in neuroom_field::Group::ALL {
        let (a, b) = (before.get(g), after.get(g));
        assert!(
            a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{} changed",
            g.name()
        );
    }
}

#[test]
fn a_ball_is_learned_to_stated_psnr_depth_and_chamfer() {
    let dir = tempfile::tempdir().unwrap();
    let data = ball_data(dir.path());
    let config = quick_config(250);
    let aug = Augmentation::default();
    let start = std::time::Instant::now();
    let mut trainer = Trainer::new(&data, &aug, &config, ModelKind::Object, BALL_BOX);
    trainer.run("ball", None, &Quiet).unwrap();
    let bounds = field_bounds(&trainer);
    let report = evaluate(&trainer.field, &data.held_out, &bounds, &aug, 1);
    let learned = extract_mesh(&trainer.field, &bounds, 64);
    let truth = extract_surface(
        &Grid::over(Vec3::splat(-0.2), Vec3::splat(0.2), 64),
        &|p: &[Vec3]| p.iter().map(|x| x.length() - 0.15).collect(),
    );
    let distance = chamfer(&learned, &truth, 10_000);
    eprintln!(
        "ball: {report:?}, chamfer {distance:?}, batch PSNR {:.2}, inv_s {}, {:.1} s",
        trainer.state.last.psnr(),
        trainer.field.inv_s(),
        start.elapsed().as_secs_f64()
    );
    assert!(report.psnr_db > 24.0, "{report:?}");
    assert!(report.median_depth_error_m < 0.003, "{report:?}");
    assert!(report.coverage > 0.98, "{report:?}");
    assert!(distance.mean < 0.005, "{distance:?}");
}

/// The box of a trainer's field (the model's box with its margin).
fn field_bounds(trainer: &Trainer<'_>) -> Aabb {
    let fc = trainer.field.config();
    Aabb {
        min: fc.bounds_min,
        max: fc.bounds_max,
    }
}

/// A tall column (10 × 24 × 80 cm, coloured by position) seen by 20 cameras at 1.4 m, with its box.
fn column_data(dir: &std::path::Path) -> (Dataset, Aabb) {
    coloured_column_data(dir, Vec3::ZERO)
}

/// The column of [`column_data`] with its colours mid-grey at `grey` (each channel saturates 0.4 m
/// from it along its axis).
fn coloured_column_data(dir: &std::path::Path, grey: Vec3) -> (Dataset, Aabb) {
    let half = Vec3::new(0.05, 0.12, 0.4);
    let column = neuroom_field::AnalyticField::Cuboid {
        centre: Vec3::ZERO,
        half,
        color: neuroom_field::AnalyticColor::Position {
            origin: grey,
            scale: 0.4,
        },
    };
    let bounds = Aabb {
        min: (-half).to_array(),
        max: half.to_array(),
    };
    (object_data(dir, &column, 1.4), bounds)
}

/// Held-out PSNR of the column of [`column_data`] after a short training that starts from `start`.
fn column_psnr(start: ObjectStart) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let (data, bounds) = column_data(dir.path());
    let config = TrainConfig {
        object_start: start,
        ..quick_config(250)
    };
    let aug = Augmentation::default();
    let mut trainer = Trainer::new(&data, &aug, &config, ModelKind::Object, bounds);
    trainer.run("column", None, &Quiet).unwrap();
    let bounds = field_bounds(&trainer);
    evaluate(&trainer.field, &data.held_out, &bounds, &aug, 1).psnr_db
}

/// How a phone's tracker got one frame wrong: the centre it gives is off by `shift`, its rays are
/// turned by `turn` about it.
struct PoseError {
    shift: Vec3,
    turn: glam::Quat,
}

/// `errors` with what the corrections' gauge cannot tell from the model taken out of their shifts: their
/// mean, and their mean along each frame's line of sight to the column's centre from `origins` (every
/// camera nearer the column and the column larger read the same depths), as a tracker's errors are
/// on average (`FrameCorrections`' module).
fn zero_on_average(mut errors: Vec<PoseError>, origins: &[[f32; 3]]) -> Vec<PoseError> {
    let sights: Vec<Vec3> = origins
        .iter()
        .map(|o| -Vec3::from(*o).normalize())
        .collect();
    let n = errors.len() as f32;
    let mean = errors.iter().map(|e| e.shift).sum::<Vec3>() / n;
    for e in &mut errors {
        e.shift -= mean;
    }
    let along: f32 = errors
        .iter()
        .zip(&sights)
        .map(|(e, s)| e.shift.dot(*s))
        .sum();
    let sum: Vec3 = sights.iter().sum();
    let x = along / (n - sum.length_squared() / n);
    for (e, s) in errors.iter_mut().zip(&sights) {
        e.shift -= x * (*s - sum / n);
    }
    errors
}

/// The `k`-th of a deterministic sequence of draws spread over [-1, 1] (golden-ratio steps).
fn draw(k: usize) -> f32 {
    (k as f32 * 0.618_034).fract() * 2.0 - 1.0
}

/// The column's capture ([`column_data`]) as a phone would give it: every training frame's centre off
/// by up to 1.5 cm, its rays turned by up to 0.7°, its colours scaled by up to ±15 % per channel (fixed
/// draws). Returns the dataset, the column's box and each frame's pose error.
fn phone_column_data(dir: &std::path::Path) -> (Dataset, Aabb, Vec<PoseError>) {
    let (mut data, bounds) = column_data(dir);
    let errors: Vec<PoseError> = (0..data.origins.len())
        .map(|f| {
            let axis = Vec3::new(draw(9 * f + 3), draw(9 * f + 4), draw(9 * f + 5)).normalize();
            PoseError {
                shift: 0.015 * Vec3::new(draw(9 * f), draw(9 * f + 1), draw(9 * f + 2)),
                turn: glam::Quat::from_axis_angle(axis, 0.7f32.to_radians() * draw(9 * f + 6)),
            }
        })
        .collect();
    let errors = zero_on_average(errors, &data.origins);
    for (o, e) in data.origins.iter_mut().zip(&errors) {
        *o = (Vec3::from(*o) + e.shift).to_array();
    }
    for i in 0..data.rays.len() {
        let f = data.rays.frame[i] as usize;
        data.rays.dir[i] = (errors[f].turn * Vec3::from(data.rays.dir[i])).to_array();
        let gain = [
            1.0 + 0.15 * draw(9 * f + 7),
            1.0,
            1.0 + 0.15 * draw(9 * f + 8),
        ];
        for (c, g) in data.rays.rgb[i].iter_mut().zip(gain) {
            *c = (*c as f32 * g).min(65535.0) as u16;
        }
    }
    (data, bounds, errors)
}

/// The mean distance (metres) between where each frame's ray towards the column's centre meets the
/// centre's depth as the capture gives it (corrected by `corrections` when given) and as it truly is,
/// after taking out the mean over the frames (moving every camera alike moves the model alike).
fn centre_ray_error(
    data: &Dataset,
    errors: &[PoseError],
    corrections: Option<&neuroom_train::frame_corrections::FrameCorrections>,
) -> f32 {
    let misses: Vec<Vec3> = errors
        .iter()
        .enumerate()
        .map(|(f, e)| {
            let given = Vec3::from(data.origins[f]);
            let truth = given - e.shift;
            let t = truth.length();
            let d_true = -truth / t;
            let (mut o, mut d) = (given, e.turn * d_true);
            if let Some(c) = corrections {
                (o, d) = (c.origin(f, o), c.direction(f, d));
            }
            (o + t * d) - (truth + t * d_true)
        })
        .collect();
    let mean = misses.iter().sum::<Vec3>() / misses.len() as f32;
    misses.iter().map(|m| (*m - mean).length()).sum::<f32>() / misses.len() as f32
}

/// A column's object model trained on `data` under `config`, and its held-out report.
fn train_column<'a>(
    data: &'a Dataset,
    aug: &'a Augmentation,
    config: &TrainConfig,
    bounds: Aabb,
) -> (Trainer<'a>, neuroom_train::eval::EvalReport) {
    let mut trainer = Trainer::new(data, aug, config, ModelKind::Object, bounds);
    trainer.run("column", None, &Quiet).unwrap();
    let report = evaluate(
        &trainer.field,
        &data.held_out,
        &field_bounds(&trainer),
        aug,
        1,
    );
    (trainer, report)
}

#[test]
fn a_phone_capture_trains_better_with_its_frames_corrected() {
    let dir = tempfile::tempdir().unwrap();
    let (data, bounds, errors) = phone_column_data(dir.path());
    let aug = Augmentation::default();
    let run = |when: RefineWhen| {
        // Poses converge more slowly than colours: 400 steps left a third of the error.
        let mut config = quick_config(800);
        config.frame_refinement.when = when;
        let (trainer, report) = train_column(&data, &aug, &config, bounds);
        let residual = trainer
            .corrections()
            .map(|c| centre_ray_error(&data, &errors, Some(c)));
        (report, residual)
    };
    let (plain, none) = run(RefineWhen::Never);
    let (refined, residual) = run(RefineWhen::Always);
    let before = centre_ray_error(&data, &errors, None);
    let residual = residual.expect("corrections learned");
    eprintln!(
        "phone column: plain {plain:?}, refined {refined:?}; error at the column {:.2} -> {:.2} cm",
        100.0 * before,
        100.0 * residual
    );
    assert!(none.is_none());
    assert!(residual < 0.5 * before, "{residual} against {before}");
    assert!(
        refined.median_depth_error_m < 0.6 * plain.median_depth_error_m,
        "{refined:?} against {plain:?}"
    );
    assert!(
        refined.psnr_db > plain.psnr_db + 1.0,
        "{:.2} against {:.2} dB",
        refined.psnr_db,
        plain.psnr_db
    );
}

/// A column whose blue channel is white on its upper part ([`coloured_column_data`]) exposed per frame by
/// a camera that clips at white: each training frame's colours scaled by a gain between 0.74 and 1.35
/// (fixed draws, about 1 on average in log) and clipped at 1, as a phone's auto-exposure leaves its
/// highlights. Red and green stay clear of white, so they pin each frame's gain.
fn clipped_column_data(dir: &std::path::Path) -> (Dataset, Aabb) {
    let (mut data, bounds) = coloured_column_data(dir, Vec3::new(0.0, 0.0, -0.2));
    data.device.auto_exposure = true;
    for i in 0..data.rays.len() {
        let gain = (0.3 * draw(data.rays.frame[i] as usize)).exp();
        for c in &mut data.rays.rgb[i] {
            *c = (*c as f32 * gain).min(65535.0) as u16;
        }
    }
    (data, bounds)
}

#[test]
fn clipped_highlights_of_frames_with_their_own_exposure_are_learned_as_bright_as_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let (data, bounds) = clipped_column_data(dir.path());
    let surface: Vec<&[u16; 3]> = (0..data.rays.len())
        .filter(|&i| !data.rays.empty[i])
        .map(|i| &data.rays.rgb[i])
        .collect();
    let clipped = surface.iter().filter(|c| c[2] == 65535).count();
    assert!(
        clipped * 5 > surface.len(),
        "{clipped} of {} surface rays clip",
        surface.len()
    );
    let aug = Augmentation::default();
    let run = |white: f32| {
        let mut config = quick_config(400);
        config.frame_refinement.clipped_white = white;
        let (_, report) = train_column(&data, &aug, &config, bounds);
        report.psnr_exposure_matched_db.expect("frames with gains")
    };
    let as_values = run(2.0);
    let as_bounds = run(FrameRefinement::default().clipped_white);
    eprintln!("clipped column: {as_values:.2} dB as values, {as_bounds:.2} dB as bounds");
    assert!(
        as_bounds > as_values + 0.5,
        "{as_bounds:.2} against {as_values:.2} dB"
    );
}

#[test]
fn a_phone_capture_without_depth_is_aligned_by_its_silhouettes() {
    let dir = tempfile::tempdir().unwrap();
    let (mut data, bounds, errors) = phone_column_data(dir.path());
    // No depth on any surface ray: what aligns a frame is its colours and its silhouette, the
    // opacity and free-space terms of the rays that miss the column.
    data.rays.distance.fill(0.0);
    data.rays.normal.fill([0; 3]);
    let aug = Augmentation::default();
    let run = |silhouettes: bool| {
        let mut config = quick_config(800);
        config.frame_refinement.when = RefineWhen::Always;
        config.frame_refinement.silhouettes = silhouettes;
        let mut trainer = Trainer::new(&data, &aug, &config, ModelKind::Object, bounds);
        trainer.run("column", None, &Quiet).unwrap();
        centre_ray_error(&data, &errors, trainer.corrections())
    };
    let before = centre_ray_error(&data, &errors, None);
    let (colours_only, with_silhouettes) = (run(false), run(true));
    eprintln!(
        "phone column without depth: error at the column {:.2} cm; corrected by the colours {:.2} cm, \
         with the silhouettes {:.2} cm",
        100.0 * before,
        100.0 * colours_only,
        100.0 * with_silhouettes
    );
    assert!(
        with_silhouettes < 0.6 * before,
        "{with_silhouettes} against {before}"
    );
    // Since the frames' common move along their sights is pinned, the colours alone align this
    // column as well; at the slower default pose rate a little better than with the silhouettes.
    assert!(
        colours_only < 0.6 * before,
        "{colours_only} against {before}"
    );
}

#[test]
fn noisy_depth_trains_better_when_the_capture_declares_its_noise() {
    let dir = tempfile::tempdir().unwrap();
    let (mut data, bounds) = column_data(dir.path());
    let noise = DepthNoise::PHONE_LIDAR;
    let mut rng = Pcg32::new(3, 0);
    for d in data.rays.distance.iter_mut().filter(|d| **d > 0.0) {
        *d += noise.sigma_at(*d) * rng.next_normal();
    }
    let aug = Augmentation::default();
    let mut run = |declared: Option<DepthNoise>| {
        data.device.depth_noise = declared;
        let mut trainer = Trainer::new(&data, &aug, &quick_config(400), ModelKind::Object, bounds);
        trainer.run("column", None, &Quiet).unwrap();
        evaluate(
            &trainer.field,
            &data.held_out,
            &field_bounds(&trainer),
            &aug,
            1,
        )
    };
    let (plain, declared) = (run(None), run(Some(noise)));
    eprintln!("noisy column: plain {plain:?}, noise declared {declared:?}");
    assert!(
        declared.median_depth_error_m < 0.85 * plain.median_depth_error_m
            && declared.psnr_db > plain.psnr_db + 0.5,
        "{declared:?} against {plain:?}"
    );
}

#[test]
fn a_tall_object_starting_from_its_box_learns_faster_than_from_a_sphere() {
    let from_box = column_psnr(ObjectStart::Box);
    let from_sphere = column_psnr(ObjectStart::Sphere);
    eprintln!("column: from its box {from_box:.2} dB, from a sphere {from_sphere:.2} dB");
    assert!(from_box > 25.0, "{from_box:.2} dB");
    // From the sphere the column's colours are hardly learnt at all (about 12 dB when written).
    assert!(
        from_box > from_sphere + 5.0,
        "{from_box:.2} against {from_sphere:.2} dB"
    );
}

#[test]
fn runs_with_the_same_seed_are_bit_identical_on_any_thread_count() {
    let dir = tempfile::tempdir().unwrap();
    let data = ball_data(&dir.path().join("capture"));
    let mut config = quick_config(15);
    config.object.batch_rays = 256;
    let aug = Augmentation::default();
    let run = |threads: usize| {
        with_threads(threads, || {
            let mut t = Trainer::new(&data, &aug, &config, ModelKind::Object, BALL_BOX);
            t.run("ball", None, &Quiet).unwrap();
            t.field.params.clone()
        })
    };
    let reference = run(2);
    for (threads, other) in [(2, run(2)), (1, run(1)), (3, run(3))] {
        for g in neuroom_field::Group::ALL {
            let same = reference
                .get(g)
                .iter()
                .zip(other.get(g))
                .all(|(x, y)| x.to_bits() == y.to_bits());
            assert!(same, "{} differs between 2 and {threads} threads", g.name());
        }
    }
}

#[test]
fn resuming_from_a_checkpoint_continues_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let data = ball_data(&dir.path().join("capture"));
    let guided = RayChoice {
        guided_share: 0.5,
        importance_weighted: true,
    };
    for choice in [RayChoice::default(), guided] {
        let mut config = quick_config(20);
        config.object.batch_rays = 128;
        config.ray_choice = choice;
        let aug = Augmentation::default();
        with_threads(1, || {
            let mut straight = Trainer::new(&data, &aug, &config, ModelKind::Object, BALL_BOX);
            straight.run("straight", None, &Quiet).unwrap();

            let ckpt = dir.path().join("ckpt");
            let mut first = Trainer::new(&data, &aug, &config, ModelKind::Object, BALL_BOX);
            for _ in 0..10 {
                first.step();
            }
            first.save(&ckpt).unwrap();
            drop(first);
            let mut second =
                Trainer::resume(&data, &aug, &config, ModelKind::Object, &ckpt).unwrap();
            assert_eq!(second.state.step, 10);
            second.run("second", None, &Quiet).unwrap();
            assert_eq!(second.state.step, 20);
            assert_eq!(second.state.rng, straight.state.rng);
            assert!(
                second.field.params == straight.field.params,
                "parameters differ after resuming ({choice:?})"
            );
        });
    }
}

#[test]
fn a_room_trains_into_a_model_folder_that_loads_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let room = dir.path().join("room");
    common::write_tiny_room(&room);
    let out = dir.path().join("models");
    let mut config = quick_config(30);
    config.env_maps = neuroom_train::augment::vendored_env_maps();
    config.holdout = 6;
    // An interrupted background run: 12 steps taken, checkpoint on disk.
    let spec = model_specs(&read_room(&room).unwrap()).remove(0);
    let (data, bounds, _) = load_model_data(&spec, &config).unwrap();
    let aug = Augmentation::load(&config.env_maps).unwrap();
    let mut partial = Trainer::new(&data, &aug, &config, ModelKind::Background, bounds);
    for _ in 0..12 {
        partial.step();
    }
    partial
        .save(&out.join("tiny/background/checkpoint"))
        .unwrap();
    let summary = train_room(&room, &out, &config, &[], &Quiet).unwrap();
    assert_eq!(
        summary.trained,
        vec!["background".to_string(), "ball".to_string()]
    );
    assert!(summary.manifest.complete);
    let models = load_room_models(&summary.dir).unwrap();
    assert_eq!(models.fields.len(), 2);
    let (entry, field) = models.object(1).unwrap();
    assert_eq!(entry.objects, vec!["ball".to_string()]);
    assert_eq!(entry.light_codes.names.len(), 1 + config.env_maps.len());
    assert_eq!(field.config().light_codes, entry.light_codes.names.len());
    assert!(entry.stats.eval.is_some() && entry.stats.steps == 30);
    // The object's own box (room.json `size`) is recorded beside the field's padded one.
    let size = read_room(&room).unwrap().objects[0].size.as_vec3();
    for a in 0..3 {
        assert!((entry.half_extents()[a] - 0.5 * size[a]).abs() < 1e-6);
        assert!(entry.bounds.max[a] > entry.half_extents()[a]);
    }
    let (background, _) = models.background().unwrap();
    assert!(background.object_box.is_none());
    assert_eq!(
        background.stats.steps, 30,
        "the background resumes at step 12 and stops at 30"
    );
    assert!(!summary.dir.join("background/checkpoint").exists());
    // A second call finds every model finished.
    let again = train_room(&room, &out, &config, &[], &Quiet).unwrap();
    assert!(again.trained.is_empty());
    assert_eq!(again.manifest.models.len(), 2);
    // Models made with another budget are refused, not reused.
    let mut other = config.clone();
    other.object.log2_table -= 1;
    let refused = train_room(&room, &out, &other, &[], &Quiet)
        .unwrap_err()
        .to_string();
    assert!(
        refused.contains("ball")
            && refused.contains("config.json")
            && refused.contains("log2_table"),
        "{refused}"
    );
}

//! Adam, checkpoints, and a small real learning test.

use glam::Vec3;
use neuroom_field::checkpoint::{load, save};
use neuroom_field::rng::SplitMix;
use neuroom_field::{
    Adam, AdamConfig, AnalyticColor, AnalyticField, CodeSet, Field, Group, NUM_GROUPS, NeusConfig,
    NeusField, Outputs, Params, Schedule, Tape,
};

#[test]
fn adam_minimises_a_quadratic() {
    let mut params = Params::<f32>::default();
    params.groups[Group::SdfMlp as usize] = vec![3.0, -2.0, 0.5];
    params.groups[Group::Light as usize] = vec![1.0];
    let target = [1.0f32, 1.0, -1.0];
    let mut adam = Adam::new(
        AdamConfig {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-8,
        },
        &params,
    );
    let mut lr = [0.0; NUM_GROUPS];
    lr[Group::SdfMlp as usize] = 0.05;
    let mut grads = Params::zeros_like(&params);
    for _ in 0..600 {
        for (g, (p, t)) in grads.groups[1]
            .iter_mut()
            .zip(params.groups[1].iter().zip(&target))
        {
            *g = 2.0 * (p - t);
        }
        grads.groups[Group::Light as usize][0] = 1.0;
        adam.step(&mut params, &mut grads, &lr);
    }
    for (p, t) in params.get(Group::SdfMlp).iter().zip(&target) {
        assert!((p - t).abs() < 1e-2, "{p} vs {t}");
    }
    assert_eq!(
        params.get(Group::Light),
        &[1.0],
        "a group at rate 0 stays frozen"
    );
}

#[test]
fn schedules() {
    let poly = Schedule::Polynomial {
        warmup: 10,
        total: 100,
        power: 2.0,
        floor: 0.01,
    };
    assert!((poly.factor(0) - 0.1).abs() < 1e-6);
    assert!((poly.factor(50) - 0.25).abs() < 1e-6);
    assert_eq!(poly.factor(1000), 0.01);
    let exp = Schedule::Exponential {
        warmup: 0,
        gamma: 0.5,
        every: 10,
    };
    assert!((exp.factor(20) - 0.25).abs() < 1e-6);
}

fn random_batch(config: &NeusConfig, n: usize, rng: &mut SplitMix) -> Vec<[f32; 3]> {
    let (lo, hi) = (config.bounds_min, config.bounds_max);
    (0..n)
        .map(|_| std::array::from_fn(|a| lo[a] + (hi[a] - lo[a]) * rng.next_f64() as f32))
        .collect()
}

/// One Adam step of SDF regression to `target`; returns the mean squared error before the step.
fn regression_step(
    field: &mut NeusField<f32>,
    target: &AnalyticField,
    adam: &mut Adam,
    tape: &mut Tape<f32>,
    grads: &mut Params<f32>,
    points: &[[f32; 3]],
    lr: &[f32; NUM_GROUPS],
) -> f32 {
    let n = points.len();
    let codes = CodeSet::default();
    field.forward(points, &[], &codes, Outputs::Sdf, tape);
    let mut sdf = vec![0.0; n];
    tape.copy_sdf(&mut sdf);
    let mut d = vec![0.0; n];
    let mut mse = 0.0;
    for i in 0..n {
        let e = sdf[i] - target.eval(Vec3::from_array(points[i])).0;
        mse += e * e / n as f32;
        d[i] = 2.0 * e / n as f32;
    }
    grads.fill_zero();
    field.backward(&codes, tape, &d, None, grads, None);
    adam.step(&mut field.params, grads, lr);
    mse
}

#[test]
fn checkpoint_round_trip_resumes_exactly() {
    let mut config = NeusConfig::object([0.4, 0.4, 0.4]);
    config.hash.log2_table = 12;
    config.appearance_codes = 3;
    let mut field = NeusField::<f32>::new(config.clone());
    field.set_active_levels(9);
    let target = AnalyticField::Sphere {
        centre: Vec3::ZERO,
        radius: 0.25,
        color: AnalyticColor::Constant(Vec3::ONE),
    };
    let mut adam = Adam::new(AdamConfig::default(), &field.params);
    let (mut tape, mut grads) = (Tape::default(), Params::zeros_like(&field.params));
    let lr = [1e-2; NUM_GROUPS];
    let mut rng = SplitMix::new(3);
    let batches: Vec<_> = (0..4)
        .map(|_| random_batch(&config, 500, &mut rng))
        .collect();
    for b in &batches[..2] {
        regression_step(
            &mut field, &target, &mut adam, &mut tape, &mut grads, b, &lr,
        );
    }
    let dir = tempfile::tempdir().unwrap();
    save(
        dir.path(),
        &field,
        Some(&adam),
        serde_json::json!({ "step": 2 }),
    )
    .unwrap();
    let (mut loaded, loaded_adam, meta) = load(dir.path()).unwrap();
    let mut loaded_adam = loaded_adam.expect("Adam state saved");
    assert_eq!(meta.trainer["step"], 2);
    assert_eq!(loaded.active_levels(), 9);
    let bits = |p: &Params<f32>| {
        p.groups
            .iter()
            .flatten()
            .map(|v| v.to_bits())
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&loaded.params), bits(&field.params));
    assert_eq!(bits(&loaded_adam.m), bits(&adam.m));
    assert_eq!(bits(&loaded_adam.v), bits(&adam.v));
    assert_eq!(loaded_adam.step, adam.step);
    let mut tape2 = Tape::default();
    for b in &batches[2..] {
        regression_step(
            &mut field, &target, &mut adam, &mut tape, &mut grads, b, &lr,
        );
        regression_step(
            &mut loaded,
            &target,
            &mut loaded_adam,
            &mut tape2,
            &mut grads,
            b,
            &lr,
        );
    }
    assert_eq!(
        bits(&loaded.params),
        bits(&field.params),
        "training resumes bit-exactly"
    );
    assert!(!dir.path().join("config.tmp").exists());
}

#[test]
fn neus_field_learns_a_box_sdf() {
    let config = NeusConfig::object([0.5, 0.5, 0.5]);
    let mut field = NeusField::<f32>::new(config.clone());
    let target = AnalyticField::Cuboid {
        centre: Vec3::new(0.05, -0.05, 0.0),
        half: Vec3::new(0.3, 0.2, 0.25),
        color: AnalyticColor::Constant(Vec3::ONE),
    };
    let mut adam = Adam::new(AdamConfig::default(), &field.params);
    let (mut tape, mut grads) = (Tape::default(), Params::zeros_like(&field.params));
    let mut lr = [5e-3; NUM_GROUPS];
    lr[Group::Hash as usize] = 2e-2;
    let mut rng = SplitMix::new(9);
    let steps = 300;
    let schedule = Schedule::Exponential {
        warmup: 0,
        gamma: 0.3,
        every: steps,
    };
    for step in 0..steps {
        let points = random_batch(&config, 4096, &mut rng);
        let rates = lr.map(|r| r * schedule.factor(step));
        regression_step(
            &mut field, &target, &mut adam, &mut tape, &mut grads, &points, &rates,
        );
    }
    // Mean absolute error on fresh points within 5 cm of the surface, where rendering needs it.
    let points: Vec<Vec3> = random_batch(&config, 20000, &mut rng)
        .into_iter()
        .map(Vec3::from_array)
        .filter(|p| target.eval(*p).0.abs() < 0.05)
        .collect();
    let mut sdf = vec![0.0; points.len()];
    Field::sdf(&field, &points, &mut sdf);
    let mae = points
        .iter()
        .zip(&sdf)
        .map(|(p, s)| (s - target.eval(*p).0).abs())
        .sum::<f32>()
        / points.len() as f32;
    assert!(mae < 5e-3, "mean |SDF error| near the surface {mae} m");
}

/// A full forward + backward pass (colour, codes per point, `∂loss/∂x`) gives the same bits on one
/// thread, three and eight: the gradient groups are cut by the batch, not by the threads.
#[test]
fn gradients_do_not_depend_on_the_thread_count() {
    let mut config = NeusConfig::object([0.4, 0.3, 0.5]);
    config.hash.log2_table = 12;
    config.appearance_codes = 4;
    config.light_codes = 2;
    let field = NeusField::<f32>::new(config.clone());
    let mut rng = SplitMix::new(11);
    let n = 37 * neuroom_field::CHUNK + 101;
    let points = random_batch(&config, n, &mut rng);
    let dirs: Vec<[f32; 3]> = (0..n)
        .map(|_| {
            let v = Vec3::from_array(std::array::from_fn(|_| rng.next_f64() as f32 - 0.5));
            v.normalize_or(Vec3::X).to_array()
        })
        .collect();
    let appearance: Vec<u32> = (0..n).map(|i| (i / 700 % 4) as u32).collect();
    let light: Vec<u32> = (0..n).map(|i| (i / 1300 % 2) as u32).collect();
    let codes = CodeSet {
        appearance: neuroom_field::Codes::PerPoint(&appearance),
        light: neuroom_field::Codes::PerPoint(&light),
        ..CodeSet::default()
    };
    let d_sdf: Vec<f32> = (0..n).map(|_| rng.next_f64() as f32 - 0.5).collect();
    let d_rgb: Vec<f32> = (0..3 * n).map(|_| rng.next_f64() as f32 - 0.5).collect();
    let pass = || {
        let mut tape = Tape::default();
        field.forward(&points, &dirs, &codes, Outputs::Full, &mut tape);
        let mut grads = Params::zeros_like(&field.params);
        let mut d_points = vec![[0.0f32; 3]; n];
        field.backward(
            &codes,
            &mut tape,
            &d_sdf,
            Some(&d_rgb),
            &mut grads,
            Some(&mut d_points),
        );
        (grads, d_points)
    };
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(pass)
    };
    let one = on(1);
    assert!(one.0.get(Group::ColorMlp).iter().any(|g| *g != 0.0));
    assert!(one.0.get(Group::Appearance).iter().any(|g| *g != 0.0));
    for threads in [3, 8] {
        let other = on(threads);
        assert!(
            one.0 == other.0,
            "parameter gradients differ on {threads} threads"
        );
        assert!(
            one.1 == other.1,
            "point gradients differ on {threads} threads"
        );
    }
}

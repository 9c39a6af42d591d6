//! The paper's Table 3 on this machine: per iteration of a pose fit (plan + forward + backward of a batch
//! of rays through the background and `K` objects), the field queries, the renderer's buffer memory and
//! the time, for safe-region and classical sampling. Fields are untrained default [`NeusField`]s, so a
//! query costs what it costs in a real fit; their geometric initialisation (spheres in the objects' boxes,
//! an inside-out sphere for the room, shrunk to fit inside the room's box as trained walls do) gives
//! sphere tracing real surfaces to find.

use crate::config::{RenderConfig, Sampling};
use crate::renderer::Renderer;
use crate::scene::{Background, InstanceCodes, Model, Scene, SceneObject, Tone};
use crate::volume::RayOutput;
use glam::{DVec3, Vec3};
use neuroom_core::stats::upper_median_by;
use neuroom_core::{Pose, Ray};
use neuroom_field::rng::SplitMix;
use neuroom_field::{NeusConfig, NeusField, Params};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// What to measure.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderBenchConfig {
    /// Batch sizes (rays per iteration).
    pub rays: Vec<usize>,
    /// Object counts besides the background.
    pub objects: Vec<usize>,
    /// Timed iterations per row (after one warm-up); the median is reported.
    pub iterations: usize,
    /// Seed of the ray directions.
    pub seed: u64,
}

impl Default for RenderBenchConfig {
    fn default() -> Self {
        Self {
            rays: vec![256, 512, 1024, 2048],
            objects: vec![1, 10],
            iterations: 3,
            seed: 7,
        }
    }
}

/// One (sampling, rays, objects) measurement.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderBenchRow {
    /// `safe_region` or `classical`.
    pub sampling: String,
    /// Rays per iteration.
    pub rays: usize,
    /// Objects besides the background.
    pub objects: usize,
    /// Sphere-tracing queries (SDF only).
    pub trace_queries: u64,
    /// Coarse-sample queries (SDF only).
    pub coarse_queries: u64,
    /// Full queries (SDF, colour, gradient; these also run backward).
    pub full_queries: u64,
    /// All queries per iteration.
    pub queries: u64,
    /// Peak bytes of the renderer's ray and sample buffers (fields' own tapes excluded).
    pub buffer_bytes: u64,
    /// Median milliseconds of plan + forward + backward.
    pub ms_per_iteration: f64,
    /// Median milliseconds of the plan (culling, sphere tracing, sample placement).
    pub ms_plan: f64,
    /// Median milliseconds of the forward pass (full field queries, compositing).
    pub ms_forward: f64,
    /// Median milliseconds of the backward pass (compositing, fields, poses).
    pub ms_backward: f64,
}

/// The measurements, one row per (sampling, objects, rays).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderBenchReport {
    /// Rayon worker threads.
    pub threads: usize,
    /// The rows.
    pub rows: Vec<RenderBenchRow>,
}

/// The benchmark room: 6 × 5 × 3 m.
const ROOM: (Vec3, Vec3) = (Vec3::ZERO, Vec3::new(6.0, 5.0, 3.0));
/// Half extents of every object box.
const HALF: Vec3 = Vec3::new(0.4, 0.4, 0.5);
/// The camera, in the middle of the room.
const CAMERA: Vec3 = Vec3::new(3.0, 2.5, 1.4);

/// Runs the benchmark.
pub fn bench_render(config: &RenderBenchConfig) -> RenderBenchReport {
    let max_objects = config.objects.iter().copied().max().unwrap_or(0);
    let mut scene = bench_scene(max_objects);
    let all = scene.objects.clone();
    let mut rows = Vec::new();
    for &k in &config.objects {
        scene.objects = all[..k].to_vec();
        let mut grads: Vec<Params<f32>> = scene
            .models
            .iter()
            .map(|m| Params::zeros_like(&m.field.params))
            .collect();
        for &n in &config.rays {
            let rays = bench_rays(&scene, n, config.seed);
            for (name, sampling) in [
                ("safe_region", Sampling::SAFE_REGION),
                ("classical", Sampling::CLASSICAL),
            ] {
                let row = bench_row(&scene, &rays, sampling, config.iterations, &mut grads);
                rows.push(RenderBenchRow {
                    sampling: name.to_string(),
                    objects: k,
                    ..row
                });
            }
        }
    }
    RenderBenchReport {
        threads: rayon::current_num_threads(),
        rows,
    }
}

/// One measurement: a warm-up iteration, then the median of `iterations` timed ones.
fn bench_row(
    scene: &Scene<NeusField>,
    rays: &[Ray],
    sampling: Sampling,
    iterations: usize,
    grads: &mut [Params<f32>],
) -> RenderBenchRow {
    let mut renderer = Renderer::new(RenderConfig {
        sampling,
        jitter: true,
        ..RenderConfig::default()
    });
    let d_out = vec![
        RayOutput {
            rgb: [1e-3; 3],
            depth: 1e-3,
            opacity: 0.0,
        };
        rays.len()
    ];
    let mut times: [Vec<f64>; 4] = Default::default();
    for it in 0..=iterations {
        renderer.config_mut().seed = it as u64;
        let start = Instant::now();
        renderer.plan(scene, rays);
        let planned = Instant::now();
        renderer.forward(scene);
        let forward = Instant::now();
        renderer.backward(scene, &d_out, grads);
        let end = Instant::now();
        if it > 0 {
            let spans = [
                (start, end),
                (start, planned),
                (planned, forward),
                (forward, end),
            ];
            for (t, (a, b)) in times.iter_mut().zip(spans) {
                t.push((b - a).as_secs_f64() * 1e3);
            }
        }
    }
    let [total, plan, fwd, bwd] = times.map(median);
    let stats = renderer.stats();
    RenderBenchRow {
        sampling: String::new(),
        rays: rays.len(),
        objects: 0,
        trace_queries: stats.trace_queries,
        coarse_queries: stats.coarse_queries,
        full_queries: stats.full_queries,
        queries: stats.queries(),
        buffer_bytes: stats.buffer_bytes,
        ms_per_iteration: total,
        ms_plan: plan,
        ms_forward: fwd,
        ms_backward: bwd,
    }
}

/// The median (0 for no values).
fn median(mut v: Vec<f64>) -> f64 {
    upper_median_by(&mut v, f64::total_cmp).unwrap_or(0.0)
}

/// The room and `k` objects on a ring around the camera, each its own default NeuS model.
fn bench_scene(k: usize) -> Scene<NeusField> {
    let (lo, hi) = ROOM;
    let mut room = NeusConfig::room(lo.to_array(), hi.to_array());
    room.init.radius = 0.45 * (hi - lo).min_element();
    room.init.box_half_extent = None;
    let mut models = vec![Model::neus(NeusField::new(room))];
    let mut objects = Vec::with_capacity(k);
    for i in 0..k {
        let mut config = NeusConfig::object(HALF.to_array());
        config.seed = 100 + i as u64;
        models.push(Model::neus(NeusField::new(config)));
        let angle = std::f64::consts::TAU * i as f64 / k as f64;
        let centre = CAMERA.as_dvec3() + DVec3::new(1.8 * angle.cos(), 1.8 * angle.sin(), -0.8);
        let pose = Pose::from_yaw_translation(angle, centre);
        objects.push(SceneObject::new(i + 1, i as u16 + 1, &pose, HALF));
    }
    Scene {
        models,
        background: Background {
            model: 0,
            bounds_min: lo,
            bounds_max: hi,
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects,
    }
}

/// `n` rays from the camera toward random points of the objects' boxes (as a fit samples rays on the
/// object masks), object `i mod K` for ray `i`; random directions when there are no objects.
fn bench_rays(scene: &Scene<NeusField>, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = SplitMix::new(seed);
    let mut u = move || 2.0 * rng.next_f64() as f32 - 1.0;
    (0..n)
        .map(|i| {
            let offset = Vec3::new(u(), u(), u());
            let target = match scene.objects.get(i % scene.objects.len().max(1)) {
                Some(o) => o.translation + o.rotation() * (offset * o.half_extents),
                None => CAMERA + offset,
            };
            Ray::new(CAMERA, target - CAMERA)
        })
        .collect()
}

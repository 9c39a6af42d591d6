//! Benchmarks of the fit: initial poses = ground truth + seeded noise, the fit, and the arrangement
//! scores before and after ([`neuroom_core::metrics::evaluate_arrangement`]); plus an analytic room (a
//! shell and posed cuboids, its panorama rendered by the renderer itself) for tests and for timing runs
//! that need no trained models.

use crate::codes::FitField;
use crate::config::{FitConfig, LossSwitches};
use crate::fit::{FitError, ObjectInit, fit, render_panorama};
use crate::relations::{Hint, RoomBox};
use glam::{DMat3, DVec3, Vec3};
use neuroom_core::Pose;
use neuroom_core::image::RgbImage;
use neuroom_core::metrics::{
    ArrangementScore, GtObject, PredictedObject, Symmetry, evaluate_arrangement,
};
use neuroom_field::{AnalyticColor, AnalyticField, NeusConfig, NeusField};
use neuroom_render::{Background, InstanceCodes, Model, Scene, SceneObject, Tone};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The paper's ablation (its Table 1 rows): complete, without photometric, without physical, without
/// observation, photometric only.
pub const ABLATIONS: [(&str, LossSwitches); 5] = [
    ("complete", switches(true, true, true)),
    ("w/o photometric", switches(false, true, true)),
    ("w/o physical", switches(true, true, false)),
    ("w/o observation", switches(true, false, true)),
    ("photometric only", switches(true, false, false)),
];

const fn switches(photometric: bool, observation: bool, physical: bool) -> LossSwitches {
    LossSwitches {
        photometric,
        observation,
        physical,
    }
}

/// Noise added to ground-truth poses to make initial estimates (uniform in ±each bound).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PoseNoise {
    /// Horizontal offset per axis (metres); the height moves by a fifth of it, since objects stand on
    /// something and a detector's error is mostly in depth.
    pub position_m: f64,
    /// Rotation about world z (degrees).
    pub yaw_deg: f64,
    /// Rotation about a random horizontal axis (degrees).
    pub tilt_deg: f64,
}

impl Default for PoseNoise {
    /// The benchmark: ±25 cm, ±20° yaw, ±5° tilt.
    fn default() -> Self {
        Self {
            position_m: 0.25,
            yaw_deg: 20.0,
            tilt_deg: 5.0,
        }
    }
}

impl PoseNoise {
    /// `pose` perturbed by draws from `rng`.
    pub fn perturb(&self, pose: &Pose, rng: &mut impl Rng) -> Pose {
        let mut u = |bound: f64| bound * (2.0 * rng.random::<f64>() - 1.0);
        let offset = DVec3::new(
            u(self.position_m),
            u(self.position_m),
            u(self.position_m / 5.0),
        );
        let yaw = DMat3::from_rotation_z(u(self.yaw_deg).to_radians());
        let axis_angle = u(std::f64::consts::PI);
        let axis = DVec3::new(axis_angle.cos(), axis_angle.sin(), 0.0);
        let tilt = DMat3::from_axis_angle(axis, u(self.tilt_deg).to_radians());
        Pose::new(tilt * yaw * pose.rotation, pose.translation + offset)
    }
}

/// A ground-truth object of a bench case.
#[derive(Clone, Debug, PartialEq)]
pub struct BenchObject {
    /// Its true pose, id, name, hints and upright flag (the pose is replaced by a noisy one for the fit).
    pub truth: ObjectInit,
    /// What identifies its model (interchangeable instances share it).
    pub model: String,
    /// Full extents of its box (metres).
    pub size: DVec3,
}

/// Scores and time of one fit from a noisy start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseReport {
    /// Scores of the initial estimate.
    pub before: ArrangementScore,
    /// Scores after the fit.
    pub after: ArrangementScore,
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
    /// Pose iterations run.
    pub pose_iterations: usize,
    /// Rays on the objects per iteration.
    pub rays: usize,
    /// Objects fitted.
    pub objects: usize,
}

/// Scores of `poses` (scene order: `objects[k]`) against the ground truth.
pub fn score(objects: &[BenchObject], poses: &[Pose]) -> ArrangementScore {
    let gt: Vec<GtObject> = objects
        .iter()
        .map(|o| GtObject {
            id: o.truth.id,
            model: o.model.clone(),
            size: o.size,
            object_to_world: o.truth.pose,
            symmetry: Symmetry::None,
        })
        .collect();
    let predicted: Vec<PredictedObject> = objects
        .iter()
        .zip(poses)
        .map(|(o, p)| PredictedObject {
            id: o.truth.id,
            object_to_world: *p,
        })
        .collect();
    evaluate_arrangement(&gt, &predicted)
}

/// Runs one case: initial poses = truth + `noise` drawn with `seed`, then the fit of `scene` to
/// `panorama`; reports the scores before and after.
#[allow(clippy::too_many_arguments)]
pub fn run_case<F: FitField>(
    scene: Scene<F>,
    room: &RoomBox,
    panorama: &RgbImage,
    camera_to_world: &Pose,
    objects: &[BenchObject],
    noise: &PoseNoise,
    seed: u64,
    config: &FitConfig,
) -> Result<CaseReport, FitError> {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let init: Vec<ObjectInit> = objects
        .iter()
        .map(|o| ObjectInit {
            pose: noise.perturb(&o.truth.pose, &mut rng),
            ..o.truth.clone()
        })
        .collect();
    let before = score(objects, &init.iter().map(|i| i.pose).collect::<Vec<_>>());
    let start = Instant::now();
    let result = fit(
        scene,
        room,
        panorama,
        camera_to_world,
        &init,
        config,
        &mut |_| {},
    )?;
    let seconds = start.elapsed().as_secs_f64();
    let by_id = |id: u16| result.objects.iter().find(|o| o.id == id).map(|o| o.pose);
    let poses: Vec<Pose> = objects
        .iter()
        .map(|o| by_id(o.truth.id).unwrap_or(o.truth.pose))
        .collect();
    Ok(CaseReport {
        before,
        after: score(objects, &poses),
        seconds,
        pose_iterations: config.pose_iterations,
        rays: config.rays,
        objects: objects.len(),
    })
}

/// A room for tests and timing: its scene, free-space box, camera, ground truth and panorama (rendered
/// at the true poses).
#[derive(Clone, Debug)]
pub struct BenchRoom<F> {
    /// Room and objects at their true poses.
    pub scene: Scene<F>,
    /// The free space.
    pub room: RoomBox,
    /// Panorama camera pose.
    pub camera_to_world: Pose,
    /// Ground truth.
    pub objects: Vec<BenchObject>,
    /// The panorama.
    pub panorama: RgbImage,
}

/// The room's free space: 6 × 5 × 3 m, floor at z = 0.
const ROOM_MIN: Vec3 = Vec3::new(-3.0, -2.5, 0.0);
const ROOM_MAX: Vec3 = Vec3::new(3.0, 2.5, 3.0);

/// Up to five cuboids: (half extents, centre, yaw, colour scale, hints). The fourth has its back against
/// the +y wall; the fifth stands on the first.
fn cuboid_specs() -> [(Vec3, Vec3, f32, f32, Vec<Hint>); 5] {
    use std::f32::consts::FRAC_PI_2;
    [
        (
            Vec3::new(0.4, 0.3, 0.35),
            Vec3::new(2.0, 0.8, 0.35),
            0.3,
            0.3,
            vec![Hint::Floor],
        ),
        (
            Vec3::new(0.3, 0.5, 0.4),
            Vec3::new(-1.8, -1.0, 0.4),
            -0.6,
            0.4,
            vec![Hint::Floor],
        ),
        (
            Vec3::new(0.25, 0.25, 0.45),
            Vec3::new(0.5, -1.8, 0.45),
            1.0,
            0.25,
            vec![Hint::Floor],
        ),
        (
            Vec3::new(0.25, 0.6, 0.4),
            Vec3::new(-0.8, 2.25, 0.4),
            -FRAC_PI_2,
            0.35,
            vec![Hint::Floor, Hint::Wall],
        ),
        (
            Vec3::new(0.15, 0.15, 0.1),
            Vec3::new(2.0, 0.8, 0.8),
            0.7,
            0.15,
            vec![Hint::On("box1".into())],
        ),
    ]
}

/// A room shell with `n ≤ 5` cuboids rendered at NeuS sharpness `inv_s`, seen from (0, 0, 1.4) by a
/// panorama of `height` rows.
pub fn analytic_room(
    n: usize,
    inv_s: f32,
    height: u32,
    config: &FitConfig,
) -> BenchRoom<AnalyticField> {
    let centre = (ROOM_MIN + ROOM_MAX) / 2.0;
    let half = (ROOM_MAX - ROOM_MIN) / 2.0;
    let shell = AnalyticField::RoomShell {
        centre,
        half,
        color: AnalyticColor::Position {
            origin: centre,
            scale: 4.0,
        },
    };
    let specs = cuboid_specs();
    let mut models = vec![Model {
        field: shell,
        inv_s,
    }];
    let mut objects = Vec::new();
    let mut truth = Vec::new();
    for (k, (h, t, yaw, scale, hints)) in specs.into_iter().take(n).enumerate() {
        let field = AnalyticField::Cuboid {
            centre: Vec3::ZERO,
            half: h,
            color: AnalyticColor::Position {
                origin: Vec3::ZERO,
                scale,
            },
        };
        models.push(Model { field, inv_s });
        let id = k as u16 + 1;
        let pose = Pose::from_yaw_translation(yaw as f64, t.as_dvec3());
        objects.push(SceneObject::new(k + 1, id, &pose, h));
        truth.push(BenchObject {
            truth: ObjectInit {
                id,
                name: format!("box{id}"),
                pose,
                upright: true,
                hints,
            },
            model: format!("box{id}"),
            size: (2.0 * h).as_dvec3(),
        });
    }
    let scene = Scene {
        models,
        background: Background {
            model: 0,
            bounds_min: ROOM_MIN - Vec3::splat(0.05),
            bounds_max: ROOM_MAX + Vec3::splat(0.05),
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects,
    };
    let camera_to_world = Pose::new(DMat3::IDENTITY, DVec3::new(0.0, 0.0, 1.4));
    let panorama = render_panorama(&scene, &camera_to_world, height, config);
    BenchRoom {
        scene,
        room: RoomBox {
            min: ROOM_MIN,
            max: ROOM_MAX,
        },
        camera_to_world,
        objects: truth,
        panorama,
    }
}

/// The layout of [`analytic_room`] with untrained NeuS fields of the default sizes (each its analytic
/// base: a sphere per object, the inside-out room box for the room): the network cost of a fit with trained
/// models, for timing runs that have none.
pub fn untrained_neus_room(n: usize, height: u32, config: &FitConfig) -> BenchRoom<NeusField> {
    let analytic = analytic_room(n, 1.0, 1, config);
    let room_field = NeusField::new(NeusConfig::room(ROOM_MIN.to_array(), ROOM_MAX.to_array()));
    let mut models = vec![Model::neus(room_field)];
    models.extend(analytic.scene.objects.iter().map(|o| {
        Model::neus(NeusField::new(NeusConfig::object(
            o.half_extents.to_array(),
        )))
    }));
    let scene = Scene {
        models,
        background: analytic.scene.background,
        objects: analytic.scene.objects,
    };
    let panorama = render_panorama(&scene, &analytic.camera_to_world, height, config);
    BenchRoom {
        scene,
        room: analytic.room,
        camera_to_world: analytic.camera_to_world,
        objects: analytic.objects,
        panorama,
    }
}

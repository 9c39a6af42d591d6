//! Finite-difference checks of every loss's backward pass, on analytic fields posed away from kinks.

use glam::{DMat3, DVec3, Vec3};
use neuroom_core::Pose;
use neuroom_field::{AnalyticColor, AnalyticField};
use neuroom_fit::alignment::alignment_loss;
use neuroom_fit::gravity::gravity_loss;
use neuroom_fit::magnetic::magnetic_loss;
use neuroom_fit::observation::{observation_loss, view_directions};
use neuroom_fit::photometric::photometric_loss;
use neuroom_fit::pose_grad::PoseGrad;
use neuroom_fit::probe::{Probe, Target};
use neuroom_fit::relations::{Relation, RoomBox};
use neuroom_fit::surface::{Face, SurfacePoints, sample_surface};
use neuroom_fit::violation::violation_loss;
use neuroom_render::volume::RayOutput;
use neuroom_render::{Background, InstanceCodes, Model, Scene, SceneObject, Tone};

const ROOM: RoomBox = RoomBox {
    min: Vec3::new(-3.0, -2.5, 0.0),
    max: Vec3::new(3.0, 2.5, 3.0),
};
const GREY: AnalyticColor = AnalyticColor::Constant(Vec3::splat(0.5));

/// Room shell (floor at 0), a tilted box (object 0) and a sphere (object 1) that it slightly penetrates.
fn scene() -> Scene<AnalyticField> {
    let room = AnalyticField::RoomShell {
        centre: Vec3::new(0.0, 0.0, 1.5),
        half: Vec3::new(3.0, 2.5, 1.5),
        color: GREY,
    };
    let cuboid = AnalyticField::Cuboid {
        centre: Vec3::ZERO,
        half: Vec3::new(0.4, 0.3, 0.25),
        color: GREY,
    };
    let sphere = AnalyticField::Sphere {
        centre: Vec3::ZERO,
        radius: 0.3,
        color: GREY,
    };
    let box_pose = Pose::new(
        DMat3::from_rotation_z(0.4) * DMat3::from_rotation_x(0.1),
        DVec3::new(1.0, 0.5, 0.27),
    );
    let sphere_pose = Pose::new(DMat3::from_rotation_y(0.3), DVec3::new(1.55, 0.7, 0.4));
    Scene {
        models: [room, cuboid, sphere]
            .into_iter()
            .map(|field| Model {
                field,
                inv_s: 100.0,
            })
            .collect(),
        background: Background {
            model: 0,
            bounds_min: Vec3::new(-3.0, -2.5, 0.0),
            bounds_max: Vec3::new(3.0, 2.5, 3.0),
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects: vec![
            SceneObject::new(1, 1, &box_pose, Vec3::new(0.4, 0.3, 0.25)),
            SceneObject::new(2, 2, &sphere_pose, Vec3::splat(0.3)),
        ],
    }
}

fn surfaces(scene: &Scene<AnalyticField>) -> Vec<SurfacePoints> {
    scene
        .objects
        .iter()
        .enumerate()
        .map(|(k, o)| sample_surface(&scene.models[o.model].field, o.half_extents, 300, k as u64))
        .collect()
}

/// Compares `grads` with central differences of `loss` over every translation and 6D component of
/// every object; returns the worst error relative to the gradient scale.
fn check_poses(
    scene: &Scene<AnalyticField>,
    grads: &[PoseGrad],
    loss: impl Fn(&Scene<AnalyticField>) -> f32,
) -> f32 {
    let h = 1e-3f32;
    let mut worst = 0.0f32;
    for (k, g) in grads.iter().enumerate() {
        let r6 = g.rotation6d(&scene.objects[k]);
        let analytic: Vec<f32> = g.translation.to_array().into_iter().chain(r6).collect();
        let scale = analytic.iter().fold(1e-3f32, |m, v| m.max(v.abs()));
        for (i, &a) in analytic.iter().enumerate() {
            let shifted = |s: f32| {
                let mut sc = scene.clone();
                let o = &mut sc.objects[k];
                if i < 3 {
                    o.translation[i] += s;
                } else {
                    o.rotation6d[i - 3] += s;
                }
                loss(&sc)
            };
            let numeric = (shifted(h) - shifted(-h)) / (2.0 * h);
            let err = (numeric - a).abs() / scale;
            println!("object {k} param {i}: analytic {a:.5} numeric {numeric:.5}");
            worst = worst.max(err);
        }
    }
    worst
}

#[test]
fn photometric_gradient_matches_finite_differences() {
    let outputs: Vec<RayOutput<f32>> = (0..5)
        .map(|i| RayOutput {
            rgb: [0.1 * i as f32, 0.5, 0.9 - 0.1 * i as f32],
            depth: 1.0,
            opacity: 1.0,
        })
        .collect();
    let target = vec![[0.3, 0.2, 0.6]; 5];
    let mut d = Vec::new();
    photometric_loss(&outputs, &target, 2.0, &mut d);
    let h = 1e-3;
    for r in 0..5 {
        for c in 0..3 {
            let mut o = outputs.clone();
            o[r].rgb[c] += h;
            let up = photometric_loss(&o, &target, 2.0, &mut Vec::new());
            o[r].rgb[c] -= 2.0 * h;
            let down = photometric_loss(&o, &target, 2.0, &mut Vec::new());
            assert!(((up - down) / (2.0 * h) - d[r].rgb[c]).abs() < 1e-3);
        }
    }
}

#[test]
fn observation_gradient_matches_finite_differences() {
    let s = scene();
    let camera = Vec3::new(0.0, 0.0, 1.4);
    let initial = view_directions(&s.objects, camera + Vec3::new(0.2, -0.1, 0.3));
    let loss = |sc: &Scene<AnalyticField>| {
        observation_loss(
            &sc.objects,
            camera,
            &initial,
            0.02,
            100.0,
            &mut [PoseGrad::ZERO; 2],
        )
    };
    let mut grads = [PoseGrad::ZERO; 2];
    assert!(observation_loss(&s.objects, camera, &initial, 0.02, 100.0, &mut grads) > 0.0);
    let mut none = [PoseGrad::ZERO; 2];
    assert_eq!(
        observation_loss(&s.objects, camera, &initial, 0.5, 100.0, &mut none),
        0.0
    );
    assert!(check_poses(&s, &grads, loss) < 1e-2);
}

#[test]
fn gravity_gradient_matches_finite_differences() {
    let s = scene();
    let upright = [true, true];
    let loss = |sc: &Scene<AnalyticField>| {
        gravity_loss(&sc.objects, &upright, 3.0, &mut [PoseGrad::ZERO; 2])
    };
    let mut grads = [PoseGrad::ZERO; 2];
    assert!(gravity_loss(&s.objects, &upright, 3.0, &mut grads) > 0.0);
    assert!(check_poses(&s, &grads, loss) < 1e-2);
}

#[test]
fn alignment_gradient_matches_finite_differences() {
    let s = scene();
    let relations = [0, 1].map(|object| Relation {
        object,
        face: Face::Back,
        target: Target::Room,
    });
    let loss = |sc: &Scene<AnalyticField>| {
        alignment_loss(&sc.objects, &relations, 3.0, &mut [PoseGrad::ZERO; 2])
    };
    let mut grads = [PoseGrad::ZERO; 2];
    assert!(alignment_loss(&s.objects, &relations, 3.0, &mut grads) > 0.0);
    assert!(check_poses(&s, &grads, loss) < 1e-2);
}

#[test]
fn violation_gradient_matches_finite_differences() {
    let s = scene();
    let surf = surfaces(&s);
    let relations = [Relation {
        object: 0,
        face: Face::Bottom,
        target: Target::Room,
    }];
    let counts: Vec<usize> = surf.iter().map(|p| p.points.len()).collect();
    // A ball misses the corners of its box's faces (about 1 − π/4 of the starts).
    assert!(
        counts.iter().all(|&c| c > 200),
        "surface points: {counts:?}"
    );
    let loss = |sc: &Scene<AnalyticField>| {
        let mut g = [PoseGrad::ZERO; 2];
        violation_loss(
            sc,
            &surf,
            &relations,
            0.025,
            1.0,
            &mut Probe::default(),
            &mut Vec::new(),
            &mut g,
        )
    };
    let mut grads = [PoseGrad::ZERO; 2];
    let value = violation_loss(
        &s,
        &surf,
        &relations,
        0.025,
        1.0,
        &mut Probe::default(),
        &mut Vec::new(),
        &mut grads,
    );
    assert!(
        value > 1e-4,
        "the box penetrates the sphere and the floor: {value}"
    );
    let worst = check_poses(&s, &grads, loss);
    assert!(worst < 3e-2, "worst relative error {worst}");
}

#[test]
fn magnetic_gradient_matches_finite_differences() {
    let s = scene();
    let surf = surfaces(&s);
    let relations = [
        Relation {
            object: 0,
            face: Face::Bottom,
            target: Target::Room,
        },
        Relation {
            object: 1,
            face: Face::Bottom,
            target: Target::Object(0),
        },
        Relation {
            object: 0,
            face: Face::Back,
            target: Target::Object(1),
        },
    ];
    let run = |sc: &Scene<AnalyticField>, g: &mut [PoseGrad]| {
        magnetic_loss(
            sc,
            &ROOM,
            &surf,
            &relations,
            2.0,
            0.0,
            &mut Probe::default(),
            &mut Vec::new(),
            g,
        )
    };
    let mut grads = [PoseGrad::ZERO; 2];
    assert!(run(&s, &mut grads) > 1e-4);
    let worst = check_poses(&s, &grads, |sc| run(sc, &mut [PoseGrad::ZERO; 2]));
    assert!(worst < 3e-2, "worst relative error {worst}");
}

#[test]
fn a_back_within_the_wall_gap_is_left_where_it_stands() {
    let back_on_wall = Relation {
        object: 0,
        face: Face::Back,
        target: Target::Room,
    };
    // The tilted box of `scene`, upright and turned with its back (−x) to the wall at x = −3.
    let loss = |offset: f64, wall_gap: f32| {
        let mut s = scene();
        s.objects.truncate(1);
        s.objects[0].set_pose(&Pose::new(
            DMat3::IDENTITY,
            DVec3::new(-3.0 + 0.4 + offset, 0.0, 0.25),
        ));
        let surf = surfaces(&s);
        magnetic_loss(
            &s,
            &ROOM,
            &surf,
            &[back_on_wall],
            1.0,
            wall_gap,
            &mut Probe::default(),
            &mut Vec::new(),
            &mut [PoseGrad::ZERO],
        )
    };
    assert!((loss(0.02, 0.0) - 0.02f32.powi(2)).abs() < 2e-5);
    assert_eq!(loss(0.02, 0.03), 0.0);
    assert!((loss(0.05, 0.03) - 0.02f32.powi(2)).abs() < 2e-5);
    // Penetration is pushed out whatever the gap allowed.
    assert!((loss(-0.01, 0.03) - 0.01f32.powi(2)).abs() < 2e-5);
}

#[test]
fn surface_points_lie_on_the_zero_set_and_keep_their_faces() {
    let s = scene();
    let surf = &surfaces(&s)[0];
    let half = Vec3::new(0.4, 0.3, 0.25);
    for (p, f) in surf.points.iter().zip(&surf.faces) {
        let on_face = match f {
            Face::Bottom => (p.z + half.z).abs() < 3e-3,
            Face::Back => (p.x + half.x).abs() < 3e-3,
            _ => true,
        };
        assert!(on_face, "{p:?} {f:?}");
    }
    assert!(surf.on(Face::Bottom).count() > 20 && surf.on(Face::Back).count() > 20);
}

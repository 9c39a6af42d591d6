//! The compositional renderer on analytic scenes: a sphere and a box posed in a room shell, seen by a
//! pinhole camera. Depth and instance images against exact ray intersections, safe region against
//! classical sampling, finite differences through the whole composite (poses, 6D components, tones,
//! light codes of a shared NeuS model), and a tiny photometric pose fit.

use glam::{DMat3, DVec3, Mat3, Vec3};
use neuroom_core::camera::{CameraModel, Equirect, Pinhole};
use neuroom_core::{Pose, Ray};
use neuroom_field::{AnalyticColor, AnalyticField, Group, NeusConfig, NeusField, Params};
use neuroom_render::volume::RayOutput;
use neuroom_render::{
    Background, InstanceCodes, Model, RenderConfig, RenderedShare, Renderer, Sampling, Scene,
    SceneObject, Tone, render_image, render_image_reporting,
};

const ROOM_CENTRE: Vec3 = Vec3::new(0.0, 0.0, 1.5);
const ROOM_HALF: Vec3 = Vec3::new(3.0, 2.5, 1.5);
const SPHERE_RADIUS: f32 = 0.3;
const BOX_HALF: Vec3 = Vec3::new(0.3, 0.2, 0.25);

fn position_color(scale: f32) -> AnalyticColor {
    AnalyticColor::Position {
        origin: Vec3::ZERO,
        scale,
    }
}

/// Models: 0 room shell, 1 sphere, 2 box; objects: the sphere (id 1) and the box (id 2).
fn scene(inv_s: f32) -> Scene<AnalyticField> {
    let room = AnalyticField::RoomShell {
        centre: ROOM_CENTRE,
        half: ROOM_HALF,
        color: AnalyticColor::Position {
            origin: ROOM_CENTRE,
            scale: 4.0,
        },
    };
    let sphere = AnalyticField::Sphere {
        centre: Vec3::ZERO,
        radius: SPHERE_RADIUS,
        color: position_color(0.5),
    };
    let cuboid = AnalyticField::Cuboid {
        centre: Vec3::ZERO,
        half: BOX_HALF,
        color: position_color(0.4),
    };
    let models = [room, sphere, cuboid]
        .into_iter()
        .map(|field| Model { field, inv_s })
        .collect();
    let sphere_pose = Pose::new(
        DMat3::from_rotation_z(0.4) * DMat3::from_rotation_x(0.3),
        DVec3::new(1.0, 0.45, 1.3),
    );
    let box_pose = Pose::new(
        DMat3::from_rotation_z(-0.5) * DMat3::from_rotation_y(0.15),
        DVec3::new(1.3, -0.55, 1.0),
    );
    Scene {
        models,
        background: Background {
            model: 0,
            bounds_min: ROOM_CENTRE - ROOM_HALF - Vec3::splat(0.05),
            bounds_max: ROOM_CENTRE + ROOM_HALF + Vec3::splat(0.05),
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects: vec![
            SceneObject::new(1, 1, &sphere_pose, Vec3::splat(SPHERE_RADIUS)),
            SceneObject::new(2, 2, &box_pose, BOX_HALF),
        ],
    }
}

/// A camera at (−1.5, 0, 1.2) looking along +x, z up (OpenGL camera frame: x right, y up, −z forward).
fn camera_pose() -> Pose {
    let (forward, up) = (DVec3::X, DVec3::Z);
    let right = forward.cross(up);
    Pose::new(
        DMat3::from_cols(right, up, -forward),
        DVec3::new(-1.5, 0.0, 1.2),
    )
}

fn pinhole(w: u32, h: u32) -> Pinhole {
    let f = 0.9 * w as f64;
    Pinhole::new(w, h, f, f, w as f64 / 2.0, h as f64 / 2.0)
}

fn camera_rays(camera: &impl CameraModel, pose: &Pose) -> Vec<Ray> {
    (0..camera.height())
        .flat_map(|v| (0..camera.width()).map(move |u| (u, v)))
        .map(|(u, v)| camera.pixel_ray(pose, u, v))
        .collect()
}

/// Exact first hit along a world ray: distance and instance id (0 = room).
fn analytic_hit(scene: &Scene<AnalyticField>, ray: &Ray) -> (f32, u16) {
    let (lo, hi) = (ROOM_CENTRE - ROOM_HALF, ROOM_CENTRE + ROOM_HALF);
    let far = (0..3)
        .map(|a| {
            let d = ray.direction[a];
            let wall = if d > 0.0 { hi[a] } else { lo[a] };
            (wall - ray.origin[a]) / d
        })
        .fold(f32::INFINITY, f32::min);
    let mut best = (far, 0u16);
    for o in &scene.objects {
        let r = o.rotation();
        let (p, d) = (
            r.transpose() * (ray.origin - o.translation),
            r.transpose() * ray.direction,
        );
        let t = if o.model == 1 {
            let b = p.dot(d);
            let c = p.dot(p) - SPHERE_RADIUS * SPHERE_RADIUS;
            let disc = b * b - c;
            (disc >= 0.0).then(|| -b - disc.sqrt())
        } else {
            let (t0, t1) = (0..3).fold((f32::NEG_INFINITY, f32::INFINITY), |(t0, t1), a| {
                let (ta, tb) = ((-BOX_HALF[a] - p[a]) / d[a], (BOX_HALF[a] - p[a]) / d[a]);
                (t0.max(ta.min(tb)), t1.min(ta.max(tb)))
            });
            (t1 > t0).then_some(t0)
        };
        if let Some(t) = t.filter(|&t| t > 0.0 && t < best.0) {
            best = (t, o.instance_id);
        }
    }
    best
}

#[test]
fn depth_and_instance_images_match_exact_intersections() {
    let scene = scene(3000.0);
    let (camera, pose) = (pinhole(64, 48), camera_pose());
    let (rgb, depth, mask) = render_image(&scene, &camera, &pose, &RenderConfig::default());
    let (w, h) = (camera.width, camera.height);
    let exact = |u: u32, v: u32| analytic_hit(&scene, &camera.pixel_ray(&pose, u, v));
    let (mut worst, mut sum, mut count, mut seen) = (0.0f32, 0.0f32, 0, [0usize; 3]);
    for v in 1..h - 1 {
        for u in 1..w - 1 {
            let (t, id) = exact(u, v);
            let interior = [(u - 1, v), (u + 1, v), (u, v - 1), (u, v + 1)]
                .iter()
                .all(|&(a, b)| exact(a, b).1 == id);
            if !interior {
                continue;
            }
            assert_eq!(*mask.get(u, v), id, "instance at ({u}, {v})");
            let ray = camera.pixel_ray(&pose, u, v);
            let forward = pose.transform_vector(-DVec3::Z).as_vec3();
            let z = t * ray.direction.dot(forward);
            let err = (depth.get(u, v) - z).abs();
            worst = worst.max(err);
            sum += err;
            count += 1;
            seen[id as usize] += 1;
            assert!(rgb.get(u, v).iter().all(|c| (0.0..=1.0).contains(c)));
        }
    }
    let mean = sum / count as f32;
    println!(
        "depth error over {count} interior pixels: mean {mean:.2e} m, worst {worst:.2e} m; per id {seen:?}"
    );
    assert!(
        seen.iter().all(|&n| n > 20),
        "every instance is seen: {seen:?}"
    );
    assert!(worst < 5e-3 && mean < 1.5e-3);
}

#[test]
fn a_reported_render_counts_up_to_every_pixel_and_renders_the_same_image() {
    let scene = scene(3000.0);
    let camera = Equirect::new(192, 96).unwrap();
    let pose = Pose::new(DMat3::IDENTITY, DVec3::new(-0.5, 0.0, 1.2));
    let config = RenderConfig::default();
    let reports = std::sync::Mutex::new(Vec::new());
    let tell = |share: RenderedShare| reports.lock().unwrap().push(share);
    let reported = render_image_reporting(&scene, &camera, &pose, &config, &tell);
    let plain = render_image(&scene, &camera, &pose, &config);
    assert_eq!(reported.0.data, plain.0.data);
    assert_eq!(reported.2.data, plain.2.data);
    let reports = reports.into_inner().unwrap();
    let total = 192 * 96;
    assert!(reports.len() >= 2, "{} reports", reports.len());
    assert!(reports.windows(2).all(|p| p[0].done < p[1].done));
    assert!(reports.iter().all(|r| r.total == total));
    assert_eq!(reports.last().map(|r| r.done), Some(total));
}

#[test]
fn panorama_renders_every_object_with_ray_distance_depth() {
    let scene = scene(3000.0);
    let camera = Equirect::new(96, 48).unwrap();
    let pose = Pose::new(DMat3::IDENTITY, DVec3::new(-0.5, 0.0, 1.2));
    let (_, depth, mask) = render_image(&scene, &camera, &pose, &RenderConfig::default());
    let mut errs = Vec::new();
    for v in 0..camera.height {
        for u in 0..camera.width {
            let (t, id) = analytic_hit(&scene, &camera.pixel_ray(&pose, u, v));
            if *mask.get(u, v) == id {
                errs.push((depth.get(u, v) - t).abs());
            }
        }
    }
    errs.sort_by(f32::total_cmp);
    let agree = errs.len() as f32 / (camera.width * camera.height) as f32;
    let median = errs[errs.len() / 2];
    println!("panorama: instance agreement {agree:.3}, median depth error {median:.2e} m");
    assert!(agree > 0.97 && median < 2e-3);
    assert!(mask.data.contains(&1) && mask.data.contains(&2));
}

#[test]
fn safe_region_and_classical_agree_on_sharp_fields() {
    let scene = scene(3000.0);
    let (camera, pose) = (pinhole(48, 36), camera_pose());
    let safe = render_image(&scene, &camera, &pose, &RenderConfig::default());
    let classical_config = RenderConfig {
        sampling: Sampling::CLASSICAL,
        ..RenderConfig::default()
    };
    let classical = render_image(&scene, &camera, &pose, &classical_config);
    let n = safe.0.data.len();
    let mut colour = Vec::with_capacity(n);
    let mut depth = Vec::with_capacity(n);
    for i in 0..n {
        if safe.2.data[i] != classical.2.data[i] {
            continue;
        }
        let (a, b) = (safe.0.data[i], classical.0.data[i]);
        colour.push((0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max));
        depth.push((safe.1.data[i] - classical.1.data[i]).abs());
    }
    let agree = colour.len() as f32 / n as f32;
    for v in [&mut colour, &mut depth] {
        v.sort_by(f32::total_cmp);
    }
    let (c50, d50) = (colour[colour.len() / 2], depth[depth.len() / 2]);
    let (c95, d95) = (
        colour[colour.len() * 95 / 100],
        depth[depth.len() * 95 / 100],
    );
    println!(
        "safe vs classical: instance agreement {agree:.3}; colour median {c50:.1e} p95 {c95:.1e}; depth median {d50:.1e} p95 {d95:.1e} m"
    );
    assert!(agree > 0.98);
    assert!(c50 < 5e-3 && c95 < 3e-2 && d50 < 2e-3 && d95 < 1e-2);
}

/// `Σ_r a_r · rgb_r + b_r · depth_r + c_r · opacity_r`, accumulated in f64, with fixed pseudo-random
/// weights; the per-ray gradient is the weights. Rays for which `keep` is false get zero weight: finite
/// differences are taken away from kinks, and NeuS opacity `max(1 − σ(s f₁)/σ(s f₀), 0)` has one where
/// the SDF along a ray stops decreasing, i.e. on rays grazing a silhouette.
fn weights(n: usize, keep: impl Fn(usize) -> bool) -> Vec<RayOutput<f32>> {
    (0..n)
        .map(|i| {
            if !keep(i) {
                return RayOutput::default();
            }
            let x = (i as f32 * 0.618_034).fract();
            let y = (i as f32 * 0.414_214).fract();
            RayOutput {
                rgb: [x - 0.5, 0.3 - y, 0.5 * (x + y) - 0.4],
                depth: 0.2 * (y - 0.5),
                opacity: x * y - 0.2,
            }
        })
        .collect()
}

fn weighted_loss(outputs: &[RayOutput<f32>], w: &[RayOutput<f32>]) -> f64 {
    outputs
        .iter()
        .zip(w)
        .map(|(o, w)| {
            (0..3).map(|c| (o.rgb[c] * w.rgb[c]) as f64).sum::<f64>()
                + (o.depth * w.depth) as f64
                + (o.opacity * w.opacity) as f64
        })
        .sum()
}

/// Compares an analytic gradient with a central difference of `loss` over a parameter set by `set`.
fn check(what: &str, analytic: f32, scale: f32, h: f32, mut loss: impl FnMut(f32) -> f64) -> f64 {
    let numeric = (loss(h) - loss(-h)) / (2.0 * h as f64);
    let err = (numeric - analytic as f64).abs();
    let tol = 2e-2 * scale as f64 + 2e-2 * numeric.abs();
    assert!(
        err <= tol,
        "{what}: analytic {analytic:.5e} vs finite difference {numeric:.5e}"
    );
    err / scale as f64
}

#[test]
fn pose_and_tone_gradients_match_finite_differences_through_the_composite() {
    for sampling in [Sampling::SAFE_REGION, Sampling::CLASSICAL] {
        let worst = finite_differences(sampling);
        println!(
            "{sampling:?}: worst finite-difference error relative to the gradient's scale: {worst:.2e}"
        );
    }
}

/// Checks every pose, 6D, tone and background-tone gradient of one sampling scheme; returns the worst
/// error relative to its group's gradient scale.
fn finite_differences(sampling: Sampling) -> f64 {
    let mut scene = scene(60.0);
    scene.objects[0].tone = Tone {
        shift: Vec3::new(0.05, -0.02, 0.1),
        scale: Vec3::new(0.9, 1.1, 1.05),
    };
    scene.background.tone.scale = Vec3::new(1.1, 0.95, 1.0);
    let (camera, pose) = (pinhole(24, 18), camera_pose());
    let rays = camera_rays(&camera, &pose);
    let mut renderer = Renderer::new(RenderConfig {
        sampling,
        ..RenderConfig::default()
    });
    renderer.plan(&scene, &rays);
    renderer.forward(&scene);
    let w = weights(rays.len(), |i| {
        let (u, v) = (i as u32 % camera.width, i as u32 / camera.width);
        let id = |u: u32, v: u32| analytic_hit(&scene, &camera.pixel_ray(&pose, u, v)).1;
        let inner = u > 0 && v > 0 && u + 1 < camera.width && v + 1 < camera.height;
        inner
            && [(u - 1, v), (u + 1, v), (u, v - 1), (u, v + 1)]
                .iter()
                .all(|&(a, b)| id(a, b) == id(u, v))
    });
    let mut grads: Vec<Params<f32>> = vec![Params::default(); 3];
    let g = renderer.backward(&scene, &w, &mut grads);
    let mut eval = |s: &Scene<AnalyticField>| weighted_loss(renderer.forward(s), &w);
    let mut worst = 0.0f64;
    for (k, og) in g.objects.iter().enumerate() {
        let t_scale = og.translation.abs().max_element();
        for a in 0..3 {
            worst = worst.max(check(
                "translation",
                og.translation[a],
                t_scale,
                2e-3,
                |h| {
                    let mut s = scene.clone();
                    s.objects[k].translation[a] += h;
                    eval(&s)
                },
            ));
        }
        let r_scale = og.rotation6d.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        for c in 0..6 {
            worst = worst.max(check("rotation6d", og.rotation6d[c], r_scale, 5e-3, |h| {
                let mut s = scene.clone();
                s.objects[k].rotation6d[c] += h;
                eval(&s)
            }));
        }
        let tone_scale = og.tone.shift.abs().max(og.tone.scale.abs()).max_element();
        for a in 0..3 {
            worst = worst.max(check(
                "tone shift",
                og.tone.shift[a],
                tone_scale,
                1e-3,
                |h| {
                    let mut s = scene.clone();
                    s.objects[k].tone.shift[a] += h;
                    eval(&s)
                },
            ));
            worst = worst.max(check(
                "tone scale",
                og.tone.scale[a],
                tone_scale,
                1e-3,
                |h| {
                    let mut s = scene.clone();
                    s.objects[k].tone.scale[a] += h;
                    eval(&s)
                },
            ));
        }
    }
    let bg = g.background_tone;
    let bg_scale = bg.shift.abs().max(bg.scale.abs()).max_element();
    for a in 0..3 {
        worst = worst.max(check(
            "background shift",
            bg.shift[a],
            bg_scale,
            1e-3,
            |h| {
                let mut s = scene.clone();
                s.background.tone.shift[a] += h;
                eval(&s)
            },
        ));
    }
    assert!(g.objects.iter().all(|o| o.translation.length() > 1e-3));
    worst
}

/// Two instances of one NeuS model with their own light-code rows: each row's gradient is that
/// instance's, and matches finite differences; the translation gradient through the network too.
#[test]
fn shared_neus_model_routes_light_code_gradients_per_instance() {
    let (lo, hi) = (ROOM_CENTRE - ROOM_HALF, ROOM_CENTRE + ROOM_HALF);
    let mut room = NeusConfig::room(lo.to_array(), hi.to_array());
    room.hash.log2_table = 12;
    let mut object = NeusConfig::object([0.3, 0.3, 0.3]);
    object.hash.log2_table = 12;
    object.light_codes = 2;
    let models = vec![
        Model::neus(NeusField::new(room)),
        Model::neus(NeusField::new(object)),
    ];
    let place = |x: f64, y: f64, light: u32, id: u16| {
        let pose = Pose::from_yaw_translation(0.3 * id as f64, DVec3::new(x, y, 1.2));
        let mut o = SceneObject::new(1, id, &pose, Vec3::splat(0.3));
        o.codes.light = light;
        o
    };
    let scene = Scene {
        models,
        background: Background {
            model: 0,
            bounds_min: lo,
            bounds_max: hi,
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects: vec![place(1.0, 0.4, 0, 1), place(1.0, -0.4, 1, 2)],
    };
    let rays = camera_rays(&pinhole(24, 18), &camera_pose());
    let mut renderer = Renderer::new(RenderConfig::default());
    renderer.plan(&scene, &rays);
    renderer.forward(&scene);
    let ids = renderer.instances();
    assert!(
        ids.contains(&1) && ids.contains(&2),
        "both instances of the shared model render"
    );
    let (_, _, mask) = render_image(
        &scene,
        &pinhole(24, 18),
        &camera_pose(),
        &RenderConfig::default(),
    );
    assert_eq!(
        mask.data, ids,
        "the tiled image of NeuS fields equals the batch"
    );
    // Keep rays through the middle of an initial sphere (radius 0.24) or clear of both.
    let w = weights(rays.len(), |i| {
        let ray = &rays[i];
        scene.objects.iter().all(|o| {
            let c = o.translation - ray.origin;
            let miss = (c - ray.direction * c.dot(ray.direction)).length();
            !(0.15..0.45).contains(&miss)
        })
    });
    let mut grads: Vec<Params<f32>> = scene
        .models
        .iter()
        .map(|m| Params::zeros_like(&m.field.params))
        .collect();
    renderer.backward(&scene, &w, &mut grads);
    let light = grads[1].get(Group::Light).to_vec();
    let cd = scene.models[1].field.config().code_dim;
    assert!(light[..cd].iter().any(|x| x.abs() > 0.0));
    assert!(light[cd..].iter().any(|x| x.abs() > 0.0));
    let scale = light.iter().fold(0.0f32, |m, x| m.max(x.abs()));
    for (row, i) in [(0, 3), (1, 5)] {
        let k = row * cd + i;
        check("light code", light[k], scale, 1e-2, |h| {
            let mut s = scene.clone();
            s.models[1].field.params.get_mut(Group::Light)[k] += h;
            weighted_loss(renderer.forward(&s), &w)
        });
    }
    // Colour sees the normal, whose path the field excludes by design: check the pose through the
    // weights alone (depth and opacity).
    let w_geo: Vec<RayOutput<f32>> = w
        .iter()
        .map(|o| RayOutput {
            rgb: [0.0; 3],
            ..*o
        })
        .collect();
    grads.iter_mut().for_each(Params::fill_zero);
    let g = renderer.backward(&scene, &w_geo, &mut grads);
    let t_scale = g.objects[0].translation.abs().max_element();
    for a in 0..3 {
        check(
            "translation (NeuS)",
            g.objects[0].translation[a],
            t_scale,
            2e-3,
            |h| {
                let mut s = scene.clone();
                s.objects[0].translation[a] += h;
                weighted_loss(renderer.forward(&s), &w_geo)
            },
        );
    }
}

/// A displaced box is pulled back toward its true pose by gradient descent on the photometric loss
/// against an image rendered at the true pose.
#[test]
fn photometric_descent_moves_a_displaced_object_back() {
    let truth = scene(80.0);
    let rays = camera_rays(&pinhole(40, 30), &camera_pose());
    let mut renderer = Renderer::new(RenderConfig::default());
    let target: Vec<[f32; 3]> = renderer
        .render(&truth, &rays)
        .iter()
        .map(|o| o.rgb)
        .collect();
    let mut scene = truth.clone();
    let true_box = truth.objects[1].clone();
    scene.objects[1].translation += Vec3::new(0.03, -0.06, 0.04);
    let yaw = Mat3::from_rotation_z(0.12);
    scene.objects[1].rotation6d =
        neuroom_core::rotation6d::rotation_to_6d_f32(yaw * true_box.rotation());
    let pose_error = |o: &SceneObject| {
        let dt = o.translation - true_box.translation;
        let r = o.rotation().transpose() * true_box.rotation();
        let angle = ((r.x_axis.x + r.y_axis.y + r.z_axis.z - 1.0) / 2.0)
            .clamp(-1.0, 1.0)
            .acos();
        (dt, angle.to_degrees())
    };
    let before = pose_error(&scene.objects[1]);
    let mut adam = [Adam::default(); 9];
    let mut model_grads = vec![Params::default(); 3];
    for _ in 0..100 {
        let d_out: Vec<RayOutput<f32>> = renderer
            .render(&scene, &rays)
            .iter()
            .zip(&target)
            .map(|(o, t)| RayOutput {
                rgb: std::array::from_fn(|c| 2.0 * (o.rgb[c] - t[c]) / rays.len() as f32),
                depth: 0.0,
                opacity: 0.0,
            })
            .collect();
        let g = renderer.backward(&scene, &d_out, &mut model_grads).objects[1];
        let o = &mut scene.objects[1];
        let params = o.translation.as_mut().iter_mut().chain(&mut o.rotation6d);
        let grads = g.translation.to_array().into_iter().chain(g.rotation6d);
        for ((p, g), adam) in params.zip(grads).zip(&mut adam) {
            *p -= adam.step(g, 4e-3);
        }
    }
    let after = pose_error(&scene.objects[1]);
    println!("box pose error before {before:?} (m, °), after {after:?}");
    // The camera looks along +x: the image-plane offset (y, z) is what one view pins down best.
    let lateral = |d: Vec3| Vec3::new(0.0, d.y, d.z).length();
    assert!(lateral(after.0) < 0.2 * lateral(before.0));
    assert!(after.0.length() < 0.5 * before.0.length() && after.1 < 0.5 * before.1);
}

/// A minimal Adam for the fit test.
#[derive(Clone, Copy, Default)]
struct Adam {
    m: f32,
    v: f32,
    t: i32,
}

impl Adam {
    fn step(&mut self, g: f32, lr: f32) -> f32 {
        self.t += 1;
        self.m = 0.9 * self.m + 0.1 * g;
        self.v = 0.999 * self.v + 0.001 * g * g;
        let m = self.m / (1.0 - 0.9f32.powi(self.t));
        let v = self.v / (1.0 - 0.999f32.powi(self.t));
        lr * m / (v.sqrt() + 1e-8)
    }
}

/// Culling: an object whose box no ray meets costs no query.
#[test]
fn culled_objects_are_never_queried() {
    let mut scene = scene(100.0);
    let rays = camera_rays(&pinhole(16, 12), &camera_pose());
    let mut renderer = Renderer::new(RenderConfig::default());
    renderer.render(&scene, &rays);
    let both = renderer.stats();
    scene.objects[1].translation = Vec3::new(-2.5, 0.0, 1.0);
    renderer.render(&scene, &rays);
    let one = renderer.stats();
    println!("queries with both objects in view {both:?}, with the box behind the camera {one:?}");
    assert!(one.queries() < both.queries() && one.segments < both.segments);
    assert!(renderer.instances().iter().all(|&i| i != 2));
}

/// Tiles rendered in parallel assemble into the same image as one batch of all pixels; a scene without
/// objects renders its background alone.
#[test]
fn tiled_images_equal_one_batch_and_background_alone_renders() {
    let mut scene = scene(500.0);
    let (camera, pose) = (pinhole(20, 15), camera_pose());
    let rays = camera_rays(&camera, &pose);
    for objects in [2, 0] {
        scene.objects.truncate(objects);
        let (rgb, _, mask) = render_image(&scene, &camera, &pose, &RenderConfig::default());
        let mut renderer = Renderer::new(RenderConfig::default());
        let batch: Vec<[f32; 3]> = renderer
            .render(&scene, &rays)
            .iter()
            .map(|o| o.rgb.map(|c| c.clamp(0.0, 1.0)))
            .collect();
        assert_eq!(rgb.data, batch);
        assert_eq!(mask.data, renderer.instances());
        assert!(renderer.outputs().iter().all(|o| o.opacity > 0.99));
    }
}

//! Small analytic rooms written in the docs/formats.md layout for tests: captures ray-traced (sphere tracing)
//! from analytic fields, with colour, z-depth and instance masks.

#![allow(dead_code)] // each test binary uses a different part of these helpers

use glam::{DMat3, DVec2, DVec3, Vec3};
use neuroom_core::Pose;
use neuroom_core::camera::{CameraModel, Pinhole};
use neuroom_core::formats::{
    BackgroundSpec, Capture, CaptureDevice, Frame, Room, RoomObject, write_capture, write_depth,
    write_mask, write_rgba, write_room,
};
use neuroom_core::image::Image;
use neuroom_field::{AnalyticColor, AnalyticField};
use serde_json::{Map, json};
use std::path::Path;

/// A camera at `eye` looking at `target`, OpenGL convention (looks along −z, +y up), world z up.
pub fn look_at(eye: DVec3, target: DVec3) -> Pose {
    let back = (eye - target).normalize();
    let right = DVec3::Z.cross(back).normalize();
    let up = back.cross(right);
    Pose::new(DMat3::from_cols(right, up, back), eye)
}

/// First hit of the ray `o + t d` with the zero set of `field` by sphere tracing, within `far`.
fn trace(field: &AnalyticField, o: Vec3, d: Vec3, far: f32) -> Option<f32> {
    let mut t = 0.0;
    for _ in 0..256 {
        let s = field.eval(o + t * d).0;
        if s.abs() < 1e-5 {
            return Some(t);
        }
        t += s.abs().max(1e-5);
        if t > far {
            return None;
        }
    }
    None
}

/// Ray-traces `field` from every pose and writes a capture folder with images, depths and masks (id `id`
/// on hit pixels, 0 and alpha 0 elsewhere).
pub fn write_analytic_capture(
    dir: &Path,
    field: &AnalyticField,
    poses: &[Pose],
    camera: Pinhole,
    id: u16,
) {
    let mut frames = Vec::new();
    for (k, pose) in poses.iter().enumerate() {
        let n = (camera.width * camera.height) as usize;
        let (mut rgba, mut depth, mut mask) =
            (vec![[0.0f32; 4]; n], vec![0.0f32; n], vec![0u16; n]);
        for i in 0..n {
            let px = DVec2::new(
                (i as u32 % camera.width) as f64 + 0.5,
                (i as u32 / camera.width) as f64 + 0.5,
            );
            let dc = camera.direction(px);
            let d = pose.transform_vector(dc).as_vec3();
            if let Some(t) = trace(field, pose.translation.as_vec3(), d, 20.0) {
                let c = field.eval(pose.translation.as_vec3() + t * d).2;
                rgba[i] = [c.x, c.y, c.z, 1.0];
                depth[i] = (t as f64 * -dc.z) as f32;
                mask[i] = id;
            }
        }
        let (w, h) = (camera.width, camera.height);
        write_rgba(
            dir.join(format!("images/{k:03}.png")),
            &Image {
                width: w,
                height: h,
                data: rgba,
            },
        )
        .unwrap();
        write_depth(
            dir.join(format!("depths/{k:03}.png")),
            &Image {
                width: w,
                height: h,
                data: depth,
            },
            0.0001,
        )
        .unwrap();
        write_mask(
            dir.join(format!("masks/{k:03}.png")),
            &Image {
                width: w,
                height: h,
                data: mask,
            },
        )
        .unwrap();
        frames.push(Frame {
            image: format!("images/{k:03}.png").into(),
            depth: Some(format!("depths/{k:03}.png").into()),
            instance: Some(format!("masks/{k:03}.png").into()),
            camera,
            camera_to_world: *pose,
            light: None,
            extra: Map::new(),
        });
    }
    let capture = Capture {
        dir: dir.to_owned(),
        frames,
        depth_unit_scale_factor: 0.0001,
        device: CaptureDevice::default(),
        extra: Map::new(),
    };
    write_capture(dir, &capture).unwrap();
}

/// A coloured ball of radius `r` at the origin.
pub fn ball(r: f32) -> AnalyticField {
    AnalyticField::Sphere {
        centre: Vec3::ZERO,
        radius: r,
        color: AnalyticColor::Position {
            origin: Vec3::ZERO,
            scale: r,
        },
    }
}

/// `views` cameras on a band around the origin at distance `dist`, elevations alternating ±25°.
pub fn orbit(views: usize, dist: f64) -> Vec<Pose> {
    (0..views)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / views as f64;
            let e: f64 = if k % 2 == 0 { 0.45 } else { -0.2 };
            let eye = dist * DVec3::new(a.cos() * e.cos(), a.sin() * e.cos(), e.sin());
            look_at(eye, DVec3::ZERO)
        })
        .collect()
}

/// A room `dir` with a 3 × 2.5 × 2.2 m box room (background capture from inside) and one ball of radius
/// 0.15 m (object `ball`, id 1), small images.
pub fn write_tiny_room(dir: &Path) {
    let cam = Pinhole::new(48, 48, 40.0, 40.0, 24.0, 24.0);
    write_analytic_capture(
        &dir.join("captures/ball"),
        &ball(0.15),
        &orbit(20, 0.7),
        cam,
        1,
    );
    let shell = AnalyticField::RoomShell {
        centre: Vec3::new(1.5, 1.25, 1.1),
        half: Vec3::new(1.5, 1.25, 1.1),
        color: AnalyticColor::Position {
            origin: Vec3::new(1.5, 1.25, 1.1),
            scale: 1.5,
        },
    };
    let room_cam = Pinhole::new(48, 36, 30.0, 30.0, 24.0, 18.0);
    let poses: Vec<Pose> = (0..12)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / 12.0;
            let eye = DVec3::new(1.5 + 0.3 * a.cos(), 1.25 + 0.3 * a.sin(), 1.2);
            look_at(eye, eye + DVec3::new(a.cos(), a.sin(), -0.2))
        })
        .collect();
    write_analytic_capture(
        &dir.join("captures/background"),
        &shell,
        &poses,
        room_cam,
        0,
    );
    let mut extra = Map::new();
    extra.insert(
        "room_box".into(),
        json!({"min": [0.0, 0.0, 0.0], "max": [3.0, 2.5, 2.2]}),
    );
    let room = Room {
        root: dir.to_owned(),
        name: "tiny".into(),
        background: BackgroundSpec {
            capture: "captures/background".into(),
        },
        objects: vec![RoomObject {
            id: 1,
            name: "ball".into(),
            category: "ball".into(),
            capture: "captures/ball".into(),
            size: DVec3::splat(0.3),
            capture_to_object: Pose::IDENTITY,
            relations: Vec::new(),
        }],
        extra,
    };
    write_room(dir, &room).unwrap();
}

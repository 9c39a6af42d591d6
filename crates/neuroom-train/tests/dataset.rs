//! Dataset conventions: rays through pixels with depth reach the back-projected surface point, in the
//! model frame; object pixels of object captures land inside the object box.

mod common;

use glam::Vec3;
use neuroom_core::camera::CameraModel;
use neuroom_core::formats::{read_capture, read_room};
use neuroom_train::dataset::{Dataset, LoadOptions, PixelClass, Role};
use neuroom_train::room::model_specs;
use std::path::Path;

#[test]
fn analytic_ball_rays_hit_the_surface_and_classes_follow_the_mask() {
    let dir = tempfile::tempdir().unwrap();
    let cam = neuroom_core::camera::Pinhole::new(32, 32, 30.0, 30.0, 16.0, 16.0);
    common::write_analytic_capture(
        dir.path(),
        &common::ball(0.2),
        &common::orbit(6, 0.8),
        cam,
        4,
    );
    let capture = read_capture(dir.path()).unwrap();
    // The capture frame is shifted by +x 0.5 into the object frame: rays must follow.
    let shift = neuroom_core::Pose::new(glam::DMat3::IDENTITY, glam::DVec3::new(0.5, 0.0, 0.0));
    let role = Role::Object {
        ids: vec![4],
        capture_to_object: shift,
    };
    let data = Dataset::load(
        &capture,
        &role,
        &LoadOptions {
            holdout: 3,
            bounds: None,
        },
    )
    .unwrap();
    assert_eq!(data.held_out.len(), 2);
    assert_eq!(data.origins.len(), 4);
    let centre = Vec3::new(0.5, 0.0, 0.0);
    let (mut surface, mut empty, mut good_normals) = (0, 0, 0);
    for i in 0..data.rays.len() {
        let (o, d) = (data.origin(i), Vec3::from(data.rays.dir[i]));
        assert!((d.length() - 1.0).abs() < 1e-5);
        if data.rays.empty[i] {
            empty += 1;
            continue;
        }
        surface += 1;
        let p = o + data.rays.distance[i] * d;
        assert!(
            ((p - centre).length() - 0.2).abs() < 1e-3,
            "ray {i} hits {p}"
        );
        // Normals from depth point outward from the ball (silhouette pixels may fall back to the ray).
        good_normals += usize::from(data.rays.normal(i).dot((p - centre).normalize()) > 0.95);
    }
    assert!(
        good_normals as f64 > 0.95 * surface as f64,
        "{good_normals} of {surface}"
    );
    assert!(
        surface > 500 && empty > 500,
        "{surface} surface, {empty} empty"
    );
    // A held-out view: the stored distance back-projects onto the pixel with its z-depth.
    let view = &data.held_out[0];
    let to_cam = view.camera_to_model.inverse();
    for i in (0..view.rgb.len())
        .filter(|&i| view.class[i] == PixelClass::Surface)
        .step_by(7)
    {
        let p = view.surface_point(i).unwrap();
        let (px, _) = view
            .camera
            .project(to_cam.transform_point(p.as_dvec3()))
            .unwrap();
        let w = view.camera.width as usize;
        assert!(
            (px.x - ((i % w) as f64 + 0.5)).abs() < 1e-3
                && (px.y - ((i / w) as f64 + 0.5)).abs() < 1e-3
        );
    }
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_blender_lite_object_rays_land_in_the_object_box() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/blender-lite");
    assert!(
        root.join("room.json").exists(),
        "{} is absent: this test needs the shared data beside the checkout",
        root.display()
    );
    let room = read_room(&root).unwrap();
    let spec = model_specs(&room)
        .into_iter()
        .find(|s| s.name == "stool")
        .unwrap();
    let capture = read_capture(&spec.capture).unwrap();
    let data = Dataset::load(
        &capture,
        &spec.role,
        &LoadOptions {
            holdout: 10,
            bounds: None,
        },
    )
    .unwrap();
    let b = spec.bounds.unwrap();
    let tol = 0.01;
    let (mut inside, mut total) = (0usize, 0usize);
    for i in (0..data.rays.len())
        .filter(|&i| !data.rays.empty[i] && data.rays.distance[i] > 0.0)
        .step_by(13)
    {
        let p = data.origin(i) + data.rays.distance[i] * Vec3::from(data.rays.dir[i]);
        total += 1;
        inside += usize::from((0..3).all(|a| p[a] > b.min[a] - tol && p[a] < b.max[a] + tol));
    }
    assert!(total > 1000);
    assert!(
        inside as f64 > 0.995 * total as f64,
        "{inside} of {total} inside the box"
    );
    assert_eq!(data.held_out.len(), 8);
}

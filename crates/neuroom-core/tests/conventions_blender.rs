//! Checks the camera conventions against a room rendered by Blender Cycles (`shared/data/blender-lite`),
//! which nobody on the project made: if our pinhole or panorama maths were mirrored, flipped or off by
//! half a pixel, depth would not agree between views and masks would not fall inside the object boxes.
//!
//! The same checks run on every room of the validation suite the project renders with Blender
//! (`suite/`, made by `tools/suite/make_room.py`), which is part of the repository.
//!
//! The files are read directly (`image`, `serde_json`) so that this test checks the conventions alone,
//! independently of the project's own readers. The blender-lite checks are ignored by default (`.ci/run` runs them
//! where that folder exists) and fail, naming it, when run without it.

use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use neuroom_core::camera::{CameraModel, Equirect, Pinhole};
use neuroom_core::obb::OrientedBox;
use neuroom_core::pose::Pose;
use serde_json::Value;

/// The Blender room; a test that needs it fails, naming it, when this checkout has no `shared/`
/// beside it (those tests are ignored by default and run by `.ci/run` where it exists).
fn room_dir() -> PathBuf {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/blender-lite"
    ));
    assert!(
        dir.join("room.json").is_file(),
        "{} is absent: this test needs the shared data beside the checkout",
        dir.display()
    );
    dir
}

fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

fn pose(rows: &Value) -> Pose {
    let rows: [[f64; 4]; 4] = serde_json::from_value(rows.clone()).expect("a 4×4 matrix");
    Pose::check_rows(&rows, 1e-5)
        .expect("a rigid pose")
        .orthonormalized()
}

/// A single-channel 8- or 16-bit PNG as (width, height, raw values).
fn read_plane(path: &Path) -> (u32, u32, Vec<u16>) {
    let img = image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let (w, h) = (img.width(), img.height());
    let values = match img {
        image::DynamicImage::ImageLuma8(p) => p.into_raw().into_iter().map(u16::from).collect(),
        image::DynamicImage::ImageLuma16(p) => p.into_raw(),
        other => panic!(
            "{}: expected a grey PNG, found {:?}",
            path.display(),
            other.color()
        ),
    };
    (w, h, values)
}

/// A depth map in metres (0 = no depth).
struct Depth {
    width: u32,
    height: u32,
    metres: Vec<f64>,
}

impl Depth {
    fn read(path: &Path, unit: f64) -> Self {
        let (width, height, raw) = read_plane(path);
        Self {
            width,
            height,
            metres: raw.into_iter().map(|d| d as f64 * unit).collect(),
        }
    }

    fn at(&self, u: u32, v: u32) -> f64 {
        self.metres[(v * self.width + u) as usize]
    }

    /// Bilinear depth at continuous pixel coordinates, only where the four neighbouring pixel centres all
    /// hold depth within 2 cm of each other (away from silhouettes, where interpolation means nothing).
    fn bilinear(&self, px: DVec2) -> Option<f64> {
        let (x, y) = (px.x - 0.5, px.y - 0.5);
        let (u0, v0) = (x.floor(), y.floor());
        if u0 < 0.0 || v0 < 0.0 || u0 + 1.0 >= self.width as f64 || v0 + 1.0 >= self.height as f64 {
            return None;
        }
        let (u, v) = (u0 as u32, v0 as u32);
        let d = [
            self.at(u, v),
            self.at(u + 1, v),
            self.at(u, v + 1),
            self.at(u + 1, v + 1),
        ];
        let (lo, hi) = d
            .iter()
            .fold((f64::MAX, f64::MIN), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        if lo <= 0.0 || hi - lo > 0.02 {
            return None;
        }
        let (fx, fy) = (x - u0, y - v0);
        Some((d[0] * (1.0 - fx) + d[1] * fx) * (1.0 - fy) + (d[2] * (1.0 - fx) + d[3] * fx) * fy)
    }
}

/// One background view: its camera, pose and depth.
struct View {
    camera: Pinhole,
    camera_to_world: Pose,
    depth: Depth,
}

fn read_background(dir: &Path) -> Vec<View> {
    let capture = dir.join("captures/background");
    let t = read_json(&capture.join("transforms.json"));
    let num = |k: &str| {
        t[k].as_f64()
            .unwrap_or_else(|| panic!("transforms.json: `{k}` missing"))
    };
    let camera = Pinhole::new(
        num("w") as u32,
        num("h") as u32,
        num("fl_x"),
        num("fl_y"),
        num("cx"),
        num("cy"),
    )
    .with_distortion(num("k1"), num("k2"), num("p1"), num("p2"));
    let unit = num("depth_unit_scale_factor");
    t["frames"]
        .as_array()
        .expect("frames")
        .iter()
        .map(|f| View {
            camera,
            camera_to_world: pose(&f["transform_matrix"]),
            depth: Depth::read(
                &capture.join(f["depth_file_path"].as_str().expect("depth path")),
                unit,
            ),
        })
        .collect()
}

/// |predicted − observed| depth for every pixel of `from` (on a `stride` grid) that lands on `to`.
fn reprojection_errors(from: &View, to: &View, stride: u32) -> Vec<f64> {
    let world_to_to = to.camera_to_world.inverse().compose(&from.camera_to_world);
    let mut errors = Vec::new();
    for v in (0..from.depth.height).step_by(stride as usize) {
        for u in (0..from.depth.width).step_by(stride as usize) {
            let d = from.depth.at(u, v);
            if d <= 0.0 {
                continue;
            }
            let p = world_to_to.transform_point(
                from.camera
                    .unproject(DVec2::new(u as f64 + 0.5, v as f64 + 0.5), d),
            );
            let Some((px, z)) = to.camera.project(p) else {
                continue;
            };
            if let Some(observed) = to.depth.bilinear(px) {
                errors.push((z - observed).abs());
            }
        }
    }
    errors
}

fn quantile(values: &mut [f64], q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    values[((values.len() - 1) as f64 * q).round() as usize]
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_background_depth_agrees_between_overlapping_views() {
    let dir = room_dir();
    check_background_views_agree(&dir);
}

/// Checks that the background views of `dir` agree on the depth of what two of them see.
fn check_background_views_agree(dir: &Path) {
    let views = read_background(dir);
    assert!(views.len() >= 2);
    let pixels = (views[0].depth.width * views[0].depth.height / 64) as usize;
    let mut all = Vec::new();
    let mut pairs = 0;
    for (i, from) in views.iter().enumerate().step_by(4) {
        // The partner that sees the most of this view, found on a coarse grid.
        let best = (0..views.len())
            .filter(|&j| j != i)
            .max_by_key(|&j| reprojection_errors(from, &views[j], 8).len())
            .expect("another view");
        if reprojection_errors(from, &views[best], 8).len() < pixels / 5 {
            continue;
        }
        let mut errors = reprojection_errors(from, &views[best], 1);
        let median = quantile(&mut errors, 0.5);
        eprintln!(
            "view {i:2} → {best:2}: {} px, median |Δz| {:.2} mm, 90% {:.2} mm",
            errors.len(),
            median * 1e3,
            quantile(&mut errors, 0.9) * 1e3
        );
        assert!(
            median < 0.001,
            "view {i} → {best}: median depth disagreement {:.1} mm",
            median * 1e3
        );
        all.extend(errors);
        pairs += 1;
    }
    assert!(pairs >= 5, "only {pairs} overlapping pairs");
    let median = quantile(&mut all, 0.5);
    eprintln!(
        "all pairs: median |Δz| {:.2} mm over {} px",
        median * 1e3,
        all.len()
    );
    assert!(
        median < 0.0006,
        "median depth disagreement {:.1} mm",
        median * 1e3
    );
}

/// Object id → full box extents, from room.json.
fn object_sizes(dir: &Path) -> Vec<(u16, DVec3)> {
    let room = read_json(&dir.join("room.json"));
    room["objects"]
        .as_array()
        .expect("objects")
        .iter()
        .map(|o| {
            let size: [f64; 3] = serde_json::from_value(o["size"].clone()).expect("size");
            (o["id"].as_u64().expect("id") as u16, DVec3::from(size))
        })
        .collect()
}

/// The counts behind the panorama check.
#[derive(Default)]
struct MaskAgreement {
    object_pixels: usize,
    object_inside_own_box: usize,
    empty_pixels: usize,
    empty_inside_a_box: usize,
}

fn check_panorama(dir: &Path, name: &str, sizes: &[(u16, DVec3)]) -> MaskAgreement {
    let pano = dir.join("panoramas");
    let truth = read_json(&pano.join(format!("{name}.json")));
    let camera_to_world = pose(&truth["camera_to_world"]);
    let boxes: Vec<(u16, OrientedBox)> = truth["objects"]
        .as_array()
        .expect("objects")
        .iter()
        .map(|o| {
            let id = o["id"].as_u64().expect("id") as u16;
            let size = sizes
                .iter()
                .find(|(i, _)| *i == id)
                .expect("object in room.json")
                .1;
            (id, OrientedBox::new(pose(&o["object_to_world"]), size))
        })
        .collect();
    let depth = Depth::read(&pano.join(format!("{name}.depth.png")), 0.001);
    let (_, _, mask) = read_plane(&pano.join(format!("{name}.mask.png")));
    let camera = Equirect::new(depth.width, depth.height).expect("a 2:1 panorama");
    let mut counts = MaskAgreement::default();
    for v in 0..depth.height {
        for u in 0..depth.width {
            let d = depth.at(u, v);
            if d <= 0.0 {
                continue;
            }
            let point = camera_to_world
                .transform_point(camera.unproject(DVec2::new(u as f64 + 0.5, v as f64 + 0.5), d));
            match mask[(v * depth.width + u) as usize] {
                0 => {
                    counts.empty_pixels += 1;
                    counts.empty_inside_a_box +=
                        usize::from(boxes.iter().any(|(_, b)| b.contains(point, -0.01)));
                }
                id => {
                    let own = &boxes
                        .iter()
                        .find(|(i, _)| *i == id)
                        .expect("mask id in the arrangement")
                        .1;
                    counts.object_pixels += 1;
                    counts.object_inside_own_box += usize::from(own.contains(point, 0.01));
                }
            }
        }
    }
    counts
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_panorama_depth_and_masks_fall_in_the_object_boxes() {
    let dir = room_dir();
    check_panoramas_against_boxes(
        &dir,
        &[
            "kitchen_a0_l0",
            "kitchen_a0_l1",
            "kitchen_a1_l0",
            "kitchen_a1_l1",
        ],
    );
}

/// Checks that the panoramas `names` of `dir` put object pixels inside their own box and empty-room
/// pixels outside every box.
fn check_panoramas_against_boxes(dir: &Path, names: &[&str]) {
    let sizes = object_sizes(dir);
    for &name in names {
        let c = check_panorama(dir, name, &sizes);
        let inside = c.object_inside_own_box as f64 / c.object_pixels as f64;
        let stray = c.empty_inside_a_box as f64 / c.empty_pixels as f64;
        eprintln!(
            "{name}: {} object px, {:.3} % inside their box (1 cm margin); {} empty px, {:.3} % inside a box (1 cm in)",
            c.object_pixels,
            100.0 * inside,
            c.empty_pixels,
            100.0 * stray
        );
        assert!(
            c.object_pixels > 500,
            "{name}: too few object pixels to check"
        );
        assert!(
            inside >= 0.99,
            "{name}: only {:.2} % of object pixels inside their box",
            100.0 * inside
        );
        assert!(
            stray <= 0.005,
            "{name}: {:.2} % of empty pixels inside an object box",
            100.0 * stray
        );
    }
}

#[test]
#[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
fn shared_data_panorama_ray_depth_agrees_with_background_views() {
    let dir = room_dir();
    check_panorama_depth_against_background(&dir, &["kitchen_a0_l0", "kitchen_a1_l0"]);
}

/// Checks that the ray depth of the empty room's pixels in panoramas `names` of `dir` agrees with the
/// z-depth of the background views that see the same points.
fn check_panorama_depth_against_background(dir: &Path, names: &[&str]) {
    let views = read_background(dir);
    for &name in names {
        let pano = dir.join("panoramas");
        let camera_to_world =
            pose(&read_json(&pano.join(format!("{name}.json")))["camera_to_world"]);
        let depth = Depth::read(&pano.join(format!("{name}.depth.png")), 0.001);
        let (_, _, mask) = read_plane(&pano.join(format!("{name}.mask.png")));
        let camera = Equirect::new(depth.width, depth.height).expect("a 2:1 panorama");
        let mut errors = Vec::new();
        for v in (0..depth.height).step_by(2) {
            for u in (0..depth.width).step_by(2) {
                let d = depth.at(u, v);
                // Objects are absent from the background captures: compare the empty room only.
                if d <= 0.0 || mask[(v * depth.width + u) as usize] != 0 {
                    continue;
                }
                let world = camera_to_world.transform_point(
                    camera.unproject(DVec2::new(u as f64 + 0.5, v as f64 + 0.5), d),
                );
                for view in &views {
                    let local = view.camera_to_world.inverse().transform_point(world);
                    let Some((px, z)) = view.camera.project(local) else {
                        continue;
                    };
                    if let Some(observed) = view.depth.bilinear(px) {
                        errors.push((z - observed).abs());
                    }
                }
            }
        }
        let median = quantile(&mut errors, 0.5);
        eprintln!(
            "{name} → background views: {} samples, median |Δz| {:.2} mm, 90% {:.2} mm",
            errors.len(),
            median * 1e3,
            quantile(&mut errors, 0.9) * 1e3
        );
        assert!(errors.len() > 10_000, "{name}: too few overlapping samples");
        assert!(
            median < 0.001,
            "{name}: median disagreement with the background views {:.1} mm",
            median * 1e3
        );
    }
}

/// The rooms of the repository's validation suite.
fn suite_rooms() -> Vec<PathBuf> {
    let suite = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../suite"));
    let mut rooms: Vec<PathBuf> = std::fs::read_dir(&suite)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (the suite is part of the repository)",
                suite.display()
            )
        })
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("room.json").is_file())
        .collect();
    rooms.sort();
    assert!(
        rooms.len() >= 6,
        "{}: only {} rooms",
        suite.display(),
        rooms.len()
    );
    rooms
}

/// The stems of a room's test panoramas (those with a ground truth).
fn panorama_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir.join("panoramas"))
        .expect("a panoramas folder")
        .filter_map(|e| e.ok())
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let stem = name.strip_suffix(".json")?;
            (!stem.contains('.')).then(|| stem.to_string())
        })
        .collect();
    names.sort();
    names
}

/// Checks that every object capture of `dir` sees its object inside its box (`size` about the origin
/// of its canonical frame, 1 cm margin), each frame taken to the object's frame through its
/// `capture_to_object` (identity when absent): the canonical frame, the pinhole convention and, for
/// objects captured standing in a room, their placement agree.
fn check_object_captures_in_their_boxes(dir: &Path) {
    let room = read_json(&dir.join("room.json"));
    let objects = room["objects"].as_array().expect("objects");
    let mut checked = Vec::new();
    for object in objects {
        let name = object["capture"].as_str().expect("capture");
        if checked.contains(&name) {
            continue;
        }
        checked.push(name);
        // Identical objects share one capture, whose masks may carry any of their ids.
        let ids: Vec<u16> = objects
            .iter()
            .filter(|o| o["capture"] == object["capture"])
            .map(|o| o["id"].as_u64().expect("id") as u16)
            .collect();
        let size: [f64; 3] = serde_json::from_value(object["size"].clone()).expect("size");
        let capture = dir.join(name);
        let t = read_json(&capture.join("transforms.json"));
        let num = |k: &str| t[k].as_f64().expect("intrinsics");
        let camera = Pinhole::new(
            num("w") as u32,
            num("h") as u32,
            num("fl_x"),
            num("fl_y"),
            num("cx"),
            num("cy"),
        );
        let capture_to_object = match object.get("capture_to_object") {
            Some(rows) => pose(rows),
            None => Pose::IDENTITY,
        };
        let half = DVec3::from(size) * 0.5 + DVec3::splat(0.01);
        let (mut seen, mut inside) = (0usize, 0usize);
        for f in t["frames"].as_array().expect("frames").iter().step_by(4) {
            let to_object = capture_to_object.compose(&pose(&f["transform_matrix"]));
            let depth = Depth::read(&capture.join(f["depth_file_path"].as_str().unwrap()), 0.001);
            let (_, _, mask) = read_plane(&capture.join(f["instance_file_path"].as_str().unwrap()));
            for v in 0..depth.height {
                for u in 0..depth.width {
                    let d = depth.at(u, v);
                    if d <= 0.0 || !ids.contains(&mask[(v * depth.width + u) as usize]) {
                        continue;
                    }
                    let p = to_object.transform_point(
                        camera.unproject(DVec2::new(u as f64 + 0.5, v as f64 + 0.5), d),
                    );
                    seen += 1;
                    inside += usize::from(p.abs().cmple(half).all());
                }
            }
        }
        let share = inside as f64 / seen.max(1) as f64;
        eprintln!(
            "{}: {seen} px, {:.3} % inside the box",
            capture.display(),
            100.0 * share
        );
        assert!(
            seen > 1000 && share > 0.995,
            "{}: {share}",
            capture.display()
        );
    }
}

#[test]
fn every_suite_room_follows_the_camera_and_depth_conventions() {
    for dir in suite_rooms() {
        eprintln!("== {}", dir.display());
        let names = panorama_names(&dir);
        assert!(
            names.len() >= 4,
            "{}: {} panoramas",
            dir.display(),
            names.len()
        );
        let names: Vec<&str> = names.iter().map(String::as_str).collect();
        check_background_views_agree(&dir);
        check_object_captures_in_their_boxes(&dir);
        check_panoramas_against_boxes(&dir, &names);
        check_panorama_depth_against_background(&dir, &names[..2]);
        // Objects captured standing in the room, where the suite has them (`make_room.py
        // --objects-in-room`).
        let in_room = dir.join("in_room");
        if in_room.join("room.json").is_file() {
            check_object_captures_in_their_boxes(&in_room);
        }
    }
}

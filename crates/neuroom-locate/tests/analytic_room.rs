//! Camera localization and object finding in an analytic room: a box-shaped room with coloured furniture
//! fixed to it (the "background"), and movable boxes.

use glam::{DMat3, DVec3, Vec3};
use neuroom_core::camera::{Equirect, Pinhole};
use neuroom_core::image::RgbImage;
use neuroom_core::pose::Pose;
use neuroom_field::{AnalyticColor, AnalyticField, CodeSet};
use neuroom_locate::evidence::{Detector, ResidualDetector, SearchView};
use neuroom_locate::objects::{
    Found, SearchConfig, SearchInput, arrangement_error, find_objects, pose_score,
};
use neuroom_locate::{
    LocalizeConfig, PANORAMA_FROM_PINHOLE, SphereImage, localize, render_background,
};
use neuroom_panorama::cloud::surface_cloud;
use neuroom_panorama::{Database, DatabaseConfig, Detection, ObjectModel, Support, build_database};
use neuroom_render::{Background, InstanceCodes, Model, RenderConfig, Scene, SceneObject, Tone};

const ROOM_CENTRE: Vec3 = Vec3::new(2.0, 1.5, 1.3);
const ROOM_HALF: Vec3 = Vec3::new(2.0, 1.5, 1.3);

fn fixture(centre: Vec3, half: Vec3, rgb: Vec3) -> AnalyticField {
    AnalyticField::Cuboid {
        centre,
        half,
        color: AnalyticColor::Constant(rgb),
    }
}

/// The empty room: a shell coloured by position with fixed, coloured blocks on its walls.
fn room_field() -> AnalyticField {
    AnalyticField::Union(vec![
        AnalyticField::RoomShell {
            centre: ROOM_CENTRE,
            half: ROOM_HALF,
            color: AnalyticColor::Position {
                origin: ROOM_CENTRE,
                scale: 3.0,
            },
        },
        fixture(
            Vec3::new(0.1, 0.8, 1.5),
            Vec3::new(0.1, 0.3, 0.4),
            Vec3::new(0.9, 0.2, 0.2),
        ),
        fixture(
            Vec3::new(2.6, 2.95, 1.0),
            Vec3::new(0.5, 0.05, 0.7),
            Vec3::new(0.1, 0.3, 0.8),
        ),
        fixture(
            Vec3::new(3.9, 1.0, 0.3),
            Vec3::new(0.1, 0.6, 0.3),
            Vec3::new(0.2, 0.7, 0.2),
        ),
        fixture(
            Vec3::new(1.2, 0.05, 2.0),
            Vec3::new(0.4, 0.05, 0.2),
            Vec3::new(0.9, 0.9, 0.1),
        ),
    ])
}

fn movable(half: Vec3, rgb: Vec3) -> AnalyticField {
    fixture(Vec3::ZERO, half, rgb)
}

const BOX_A: Vec3 = Vec3::new(0.3, 0.2, 0.25);
const BOX_B: Vec3 = Vec3::new(0.15, 0.15, 0.4);
const RED: Vec3 = Vec3::new(0.8, 0.15, 0.1);
const BLUE: Vec3 = Vec3::new(0.1, 0.2, 0.9);

/// The room with the movable models listed (none placed unless `placed` is given).
fn scene(placed: Option<(usize, Pose)>) -> Scene<AnalyticField> {
    let models = vec![
        Model {
            field: room_field(),
            inv_s: 400.0,
        },
        Model {
            field: movable(BOX_A, RED),
            inv_s: 400.0,
        },
        Model {
            field: movable(BOX_B, BLUE),
            inv_s: 400.0,
        },
    ];
    let halves = [BOX_A, BOX_B];
    Scene {
        models,
        background: Background {
            model: 0,
            bounds_min: ROOM_CENTRE - ROOM_HALF - Vec3::splat(0.05),
            bounds_max: ROOM_CENTRE + ROOM_HALF + Vec3::splat(0.05),
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects: placed
            .map(|(m, pose)| vec![SceneObject::new(m + 1, m as u16 + 1, &pose, halves[m])])
            .unwrap_or_default(),
    }
}

fn panorama(scene: &Scene<AnalyticField>, camera: &Pose, width: u32, gain: f32) -> RgbImage {
    let cam = Equirect::new(width, width / 2).unwrap();
    let (rgb, _, _) = neuroom_render::render_image(scene, &cam, camera, &RenderConfig::default());
    rgb.map(|c| c.map(|x| (x * gain).min(1.0)))
}

fn small_database(empty: &Scene<AnalyticField>) -> Database {
    let config = DatabaseConfig {
        width: 64,
        spacing: 0.6,
        heights: vec![1.4],
        ..DatabaseConfig::default()
    };
    build_database(empty, &config, &mut |_, _| {})
}

/// Localizes `query` in the empty room with 6 candidates refined at 128 and 256 px; returns the position
/// (metres) and rotation (degrees) errors against `truth`.
fn localization_error(
    empty: &Scene<AnalyticField>,
    db: &Database,
    query: &SphereImage,
    truth: &Pose,
) -> (f64, f64) {
    let config = LocalizeConfig {
        candidates: 6,
        fine_widths: vec![128, 256],
        ..LocalizeConfig::default()
    };
    let found = localize(empty, db, query, &config, &mut |_| {})
        .unwrap()
        .pose();
    (
        found.translation.distance(truth.translation),
        neuroom_core::metrics::rotation_error_deg(truth.rotation, found.rotation),
    )
}

#[test]
fn the_camera_is_found_despite_an_object_and_a_darker_exposure() {
    let empty = scene(None);
    let db = small_database(&empty);
    assert!(db.entries.len() >= 6, "{} entries", db.entries.len());
    let truth = Pose::from_yaw_translation(2.1, DVec3::new(1.35, 1.1, 1.5));
    let object = Pose::from_yaw_translation(0.4, DVec3::new(2.6, 1.9, 0.25));
    let query = SphereImage::panorama(panorama(&scene(Some((0, object))), &truth, 256, 0.8));
    let (position, rotation) = localization_error(&empty, &db, &query, &truth);
    assert!(position < 0.03, "position error {position} m");
    assert!(rotation < 0.5, "rotation error {rotation}°");
}

/// The panorama under other lights: the ceiling much darker than under the database's lights (its
/// edges with the walls reverse), a light on one side (a smooth gain across headings) and a darker
/// exposure.
fn relit_panorama(scene: &Scene<AnalyticField>, camera: &Pose, width: u32) -> RgbImage {
    let cam = Equirect::new(width, width / 2).unwrap();
    let (rgb, depth, _) =
        neuroom_render::render_image(scene, &cam, camera, &RenderConfig::default());
    let ceiling = (ROOM_CENTRE.z + ROOM_HALF.z) as f64 - 0.05;
    let (w, h) = (width as usize, width as usize / 2);
    RgbImage {
        data: (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                let ray = neuroom_panorama::sphere::direction(x, y, w, h);
                let world = camera.transform_point(ray * depth.data[i] as f64);
                let lon = std::f64::consts::PI * (1.0 - 2.0 * x / w as f64);
                let side = 0.7 + 0.3 * (0.5 + 0.5 * (lon - 1.0).cos());
                let surface = if world.z > ceiling { 0.3 } else { 1.0 };
                let gain = (0.85 * side * surface) as f32;
                rgb.data[i].map(|c| c * gain)
            })
            .collect(),
        ..rgb
    }
}

#[test]
fn the_camera_is_found_under_other_lights() {
    let empty = scene(None);
    let db = small_database(&empty);
    let truth = Pose::from_yaw_translation(-0.9, DVec3::new(2.55, 1.8, 1.45));
    let object = Pose::from_yaw_translation(0.4, DVec3::new(1.2, 2.2, 0.25));
    let query = SphereImage::panorama(relit_panorama(&scene(Some((0, object))), &truth, 256));
    let (position, rotation) = localization_error(&empty, &db, &query, &truth);
    // The target.
    assert!(position < 0.05, "position error {position} m");
    assert!(rotation < 0.5, "rotation error {rotation}°");
}

#[test]
fn edge_orientations_align_a_panorama_whose_contrast_is_reversed() {
    use neuroom_locate::align::{AlignConfig, Keyframe, align};
    let empty = scene(None);
    let truth = Pose::from_yaw_translation(0.7, DVec3::new(2.2, 1.4, 1.4));
    let width = 128;
    let (rgb, depth) = render_background(&empty, &truth, width, &RenderConfig::default());
    // Another light that turns every edge around: the brighter side of each is now the darker.
    let query = SphereImage::panorama(rgb.map(|c| c.map(|x| 0.9 - 0.8 * x)));
    let keyframe = Keyframe {
        rgb: &rgb,
        depth: &depth,
        camera_to_world: truth,
    };
    let start = Pose::from_yaw_translation(0.75, DVec3::new(2.26, 1.37, 1.4));
    let config = |orientation| AlignConfig {
        sigmas: vec![2.0, 1.0],
        orientation,
        ..AlignConfig::default()
    };
    let at_truth = AlignConfig {
        iterations: 0,
        ..config(None)
    };
    let signed = align(&keyframe, &query, &truth, &at_truth);
    let oriented = align(&keyframe, &query, &start, &config(Some(0.5)));
    assert!(
        signed.score < 0.0,
        "signed gradients correlate {} at the truth",
        signed.score
    );
    let found = oriented.camera_to_world;
    let position = found.translation.distance(truth.translation);
    let rotation = neuroom_core::metrics::rotation_error_deg(truth.rotation, found.rotation);
    assert!(
        oriented.score > 0.5,
        "orientations correlate {}",
        oriented.score
    );
    // From 6.7 cm and 2.9° off; orientations place edges less sharply than signed gradients (the
    // rendered rounds that follow in `localize` settle the last centimetres).
    assert!(position < 0.05, "position error {position} m");
    assert!(rotation < 0.5, "rotation error {rotation}°");
}

#[test]
fn the_database_round_trips_and_bad_files_are_named() {
    let empty = scene(None);
    let config = DatabaseConfig {
        width: 32,
        spacing: 1.2,
        heights: vec![1.4],
        ..DatabaseConfig::default()
    };
    let db = build_database(&empty, &config, &mut |_, _| {});
    assert!(!db.entries.is_empty());
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("locate.safetensors");
    db.write(&path).unwrap();
    let back = Database::read(&path).unwrap();
    assert_eq!(back.entries.len(), db.entries.len());
    assert_eq!((back.width, back.height), (32, 16));
    for (a, b) in back.entries.iter().zip(&db.entries) {
        assert_eq!(a.position, b.position);
        assert!((a.depth[100] - b.depth[100]).abs() < 1e-3);
        assert!((a.rgb.data[100][0] - b.rgb.data[100][0]).abs() < 0.5 / 255.0 + 1e-6);
    }
    std::fs::write(&path, b"not tensors").unwrap();
    let err = Database::read(&path).unwrap_err().to_string();
    assert!(err.contains("locate.safetensors"), "{err}");
}

fn object_models() -> Vec<ObjectModel> {
    [(BOX_A, RED, 1u16), (BOX_B, BLUE, 2u16)]
        .into_iter()
        .map(|(half, rgb, id)| {
            let field = movable(half, rgb);
            let half = half + Vec3::splat(0.02);
            ObjectModel {
                ids: vec![id],
                half,
                coarse: surface_cloud(&field, half, 0.04, CodeSet::default()),
                fine: surface_cloud(&field, half, 0.025, CodeSet::default()),
                support: Support::Floor,
                against_wall: false,
            }
        })
        .collect()
}

/// The view of the red box at `truth` from `camera` under a 0.9 exposure, with the empty room beside it.
fn object_view(camera: &Pose, truth: &Pose) -> (Scene<AnalyticField>, SearchView) {
    let empty = scene(None);
    let width = 128;
    let query = panorama(&scene(Some((0, *truth))), camera, width, 0.9);
    let (room, depth) = render_background(&empty, camera, width as usize, &RenderConfig::default());
    let view = SearchView {
        query,
        empty: room,
        empty_depth: depth,
        seen: None,
        light: None,
    };
    (empty, view)
}

/// The red box standing at a known pose, seen from a known camera, with the detections in its view.
struct PlacedBox {
    camera: Pose,
    truth: Pose,
    empty: Scene<AnalyticField>,
    view: SearchView,
    detections: Vec<Detection>,
    models: Vec<ObjectModel>,
}

impl PlacedBox {
    fn new() -> Self {
        Self::at(Pose::from_yaw_translation(
            0.5,
            DVec3::new(2.7, 2.0, BOX_A.z as f64),
        ))
    }

    /// The red box standing at `truth`.
    fn at(truth: Pose) -> Self {
        let camera = Pose::new(DMat3::IDENTITY, DVec3::new(1.5, 1.4, 1.4));
        let (empty, view) = object_view(&camera, &truth);
        let detections = ResidualDetector::default().detect(&view);
        Self {
            camera,
            truth,
            empty,
            view,
            detections,
            models: object_models(),
        }
    }

    fn input(&self) -> SearchInput<'_, AnalyticField> {
        SearchInput {
            empty: &self.empty,
            view: &self.view,
            camera_to_world: self.camera,
            detections: &self.detections,
            models: &self.models,
        }
    }
}

#[test]
fn the_present_object_is_placed_and_the_absent_one_is_not_invented() {
    let scene = PlacedBox::new();
    assert!(!scene.detections.is_empty());
    let found = find_objects(&scene.input(), &SearchConfig::default(), &mut |_| {});
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].id, 1);
    let pose = Pose::from_rows_unchecked(&found[0].object_to_world);
    let truth = scene.truth;
    let position = pose.translation.distance(truth.translation);
    // The box looks the same turned by 180°.
    let yaw = (pose.yaw() - truth.yaw()).rem_euclid(std::f64::consts::PI);
    let yaw = yaw.min(std::f64::consts::PI - yaw).to_degrees();
    assert!(position < 0.08, "position error {position} m");
    assert!(yaw < 8.0, "yaw error {yaw}°");
}

#[test]
fn the_true_pose_scores_above_a_turned_or_shifted_one() {
    let scene = PlacedBox::new();
    let input = scene.input();
    let truth = scene.truth;
    let config = SearchConfig::default();
    let score = |pose: &Pose| pose_score(&input, 0, pose, &config);
    let best = score(&truth);
    assert!(best.gain > 0.0 && best.precision > 0.8, "{best:?}");
    let turned = Pose::from_yaw_translation(0.5 + std::f64::consts::FRAC_PI_2, truth.translation);
    let shifted = Pose::from_yaw_translation(0.5, truth.translation + DVec3::new(0.0, 0.3, 0.0));
    for other in [turned, shifted] {
        let s = score(&other);
        assert!(s.gain < best.gain, "{s:?} ≥ {best:?}");
    }
}

#[test]
fn no_object_is_placed_where_the_camera_stands() {
    let truth = Pose::from_yaw_translation(0.5, DVec3::new(1.55, 1.4, BOX_A.z as f64));
    let scene = PlacedBox::at(truth);
    let input = scene.input();
    let config = SearchConfig::default();
    assert_eq!(pose_score(&input, 0, &truth, &config).gain, 0.0);
    let anywhere = SearchConfig {
        camera_clearance: f64::NEG_INFINITY,
        ..config
    };
    let seen = pose_score(&input, 0, &truth, &anywhere);
    assert!(seen.gain > 0.0, "{seen:?}");
}

#[test]
fn the_true_arrangement_explains_the_panorama_better_than_a_shifted_one_or_none() {
    let scene = PlacedBox::new();
    let input = scene.input();
    let config = SearchConfig::default();
    let at = |pose: &Pose| Found {
        model: 0,
        id: 1,
        object_to_world: pose.to_rows(),
        score: 0.0,
        explained: 0,
    };
    let truth = scene.truth;
    let shifted = Pose::from_yaw_translation(0.5, truth.translation + DVec3::new(0.0, 0.3, 0.0));
    let true_error = arrangement_error(&input, &[at(&truth)], &config);
    let none = arrangement_error(&input, &[], &config);
    let off = arrangement_error(&input, &[at(&shifted)], &config);
    assert!(
        true_error < off && true_error < none,
        "{true_error} {off} {none}"
    );
}

/// A 90° × 74° photo of `scene` from a level camera whose panorama frame is `camera` (looking along its
/// +x), under a 0.85 exposure.
fn photo(scene: &Scene<AnalyticField>, camera: &Pose) -> (RgbImage, Pinhole) {
    let intrinsics = Pinhole::new(200, 150, 100.0, 100.0, 100.0, 75.0);
    let gl = Pose::new(camera.rotation * PANORAMA_FROM_PINHOLE, camera.translation);
    let (rgb, _, _) =
        neuroom_render::render_image(scene, &intrinsics, &gl, &RenderConfig::default());
    (rgb.map(|c| c.map(|x| x * 0.85)), intrinsics)
}

#[test]
#[ignore = "photo localization is not reliable yet: this case ends about 25 cm off, beyond the 5 cm it asks (see docs/benchmarks.md, Locating photos)"]
fn the_camera_of_a_photo_is_found_from_its_field_of_view() {
    let empty = scene(None);
    let db = small_database(&empty);
    // Looking west at the red fixture, with the red box in view.
    let truth = Pose::from_yaw_translation(3.0, DVec3::new(2.3, 1.2, 1.45));
    let object = Pose::from_yaw_translation(0.4, DVec3::new(1.0, 1.6, 0.25));
    let (rgb, intrinsics) = photo(&scene(Some((0, object))), &truth);
    let query = SphereImage::from_photo(&rgb, &intrinsics);
    let seen = query.seen.as_ref().unwrap();
    assert!(seen.iter().filter(|s| **s).count() * 5 < seen.len());
    let (position, rotation) = localization_error(&empty, &db, &query, &truth);
    assert!(position < 0.05, "position error {position} m");
    assert!(rotation < 0.5, "rotation error {rotation}°");
}

#[test]
fn an_object_in_a_photo_is_placed_and_what_the_photo_cannot_see_is_not_held_against_it() {
    let camera = Pose::from_yaw_translation(0.49, DVec3::new(1.0, 1.1, 1.0));
    let truth = Pose::from_yaw_translation(0.5, DVec3::new(2.7, 2.0, BOX_A.z as f64));
    let empty = scene(None);
    let (rgb, intrinsics) = photo(&scene(Some((0, truth))), &camera);
    let sphere = SphereImage::from_photo(&rgb, &intrinsics).downsample(256, 128);
    let (room, depth) = render_background(&empty, &camera, 256, &RenderConfig::default());
    let view = SearchView {
        query: sphere.rgb,
        empty: room,
        empty_depth: depth,
        seen: sphere.seen,
        light: None,
    };
    let detections = ResidualDetector::default().detect(&view);
    assert!(!detections.is_empty());
    let models = object_models();
    let input = SearchInput {
        empty: &empty,
        view: &view,
        camera_to_world: camera,
        detections: &detections,
        models: &models,
    };
    let found = find_objects(&input, &SearchConfig::default(), &mut |_| {});
    assert_eq!(found.len(), 1, "{found:?}");
    assert_eq!(found[0].id, 1);
    let pose = Pose::from_rows_unchecked(&found[0].object_to_world);
    let position = pose.translation.distance(truth.translation);
    // 9.7 cm here, at 256 columns; the full panorama of this camera places the box within 3 cm, but
    // the photo's resampled pixels score a pose 10 cm nearer as high as the truth (25.6 against 25.5).
    assert!(position < 0.12, "position error {position} m");
}

#[test]
fn a_panorama_riddled_with_small_holes_still_aligns() {
    use neuroom_locate::align::{AlignConfig, Keyframe, align};
    let empty = scene(None);
    let truth = Pose::from_yaw_translation(0.7, DVec3::new(2.2, 1.4, 1.4));
    let width = 128;
    let (rgb, depth) = render_background(&empty, &truth, width, &RenderConfig::default());
    // Lone pixels taken out every few pixels, as noise at a bright surface's limit would be: a
    // step that moves points into or out of them must not count against the step.
    let (w, h) = (width, width / 2);
    let seen = (0..w * h)
        .map(|i| (i % w) % 4 != 1 || (i / w) % 3 != 1)
        .collect();
    let query = SphereImage {
        rgb: rgb.clone(),
        seen: Some(seen),
    };
    let keyframe = Keyframe {
        rgb: &rgb,
        depth: &depth,
        camera_to_world: truth,
    };
    let start = Pose::from_yaw_translation(0.75, DVec3::new(2.26, 1.37, 1.4));
    let config = AlignConfig {
        sigmas: vec![2.0, 1.0],
        ..AlignConfig::default()
    };
    let found = align(&keyframe, &query, &start, &config).camera_to_world;
    let position = found.translation.distance(truth.translation);
    let rotation = neuroom_core::metrics::rotation_error_deg(truth.rotation, found.rotation);
    assert!(position < 0.02, "position error {position} m");
    assert!(rotation < 0.3, "rotation error {rotation}°");
}

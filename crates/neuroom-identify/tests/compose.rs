//! Composed training panoramas in an analytic room: labels where objects are splatted, and the room's
//! rules (floor, wall, support, no overlap, inside the room).

use glam::{DVec3, Vec3};
use neuroom_core::obb::OrientedBox;
use neuroom_field::{AnalyticColor, AnalyticField, CodeSet, Field};
use neuroom_identify::compose::BACKGROUND;
use neuroom_identify::place::PlaceConfig;
use neuroom_identify::{ComposeConfig, RoomSource, compose};
use neuroom_panorama::cloud::surface_cloud;
use neuroom_panorama::{Database, DatabaseConfig, ObjectModel, Support, build_database};
use neuroom_render::{Background, InstanceCodes, Model, Scene, Tone};

const ROOM_CENTRE: Vec3 = Vec3::new(2.0, 1.5, 1.3);
const ROOM_HALF: Vec3 = Vec3::new(2.0, 1.5, 1.3);

fn room_field() -> AnalyticField {
    AnalyticField::RoomShell {
        centre: ROOM_CENTRE,
        half: ROOM_HALF,
        color: AnalyticColor::Constant(Vec3::splat(0.6)),
    }
}

fn database() -> Database {
    let empty = Scene {
        models: vec![Model {
            field: room_field(),
            inv_s: 400.0,
        }],
        background: Background {
            model: 0,
            bounds_min: ROOM_CENTRE - ROOM_HALF - Vec3::splat(0.05),
            bounds_max: ROOM_CENTRE + ROOM_HALF + Vec3::splat(0.05),
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        },
        objects: Vec::new(),
    };
    let config = DatabaseConfig {
        width: 64,
        spacing: 0.8,
        heights: vec![1.4],
        ..DatabaseConfig::default()
    };
    build_database(&empty, &config, &mut |_, _| {})
}

const COLOURS: [Vec3; 3] = [
    Vec3::new(0.9, 0.1, 0.1),
    Vec3::new(0.1, 0.2, 0.9),
    Vec3::new(0.1, 0.8, 0.2),
];

/// A table on the floor (two instances), a panel on a wall, a box on the table.
fn models() -> Vec<ObjectModel> {
    let specs = [
        (Vec3::new(0.4, 0.3, 0.35), Support::Floor, vec![1, 2]),
        (Vec3::new(0.03, 0.4, 0.3), Support::Wall, vec![3]),
        (Vec3::new(0.12, 0.12, 0.12), Support::On(0), vec![4]),
    ];
    specs
        .into_iter()
        .zip(COLOURS)
        .map(|((half, support, ids), colour)| {
            let field = AnalyticField::Cuboid {
                centre: Vec3::ZERO,
                half,
                color: AnalyticColor::Constant(colour),
            };
            ObjectModel {
                ids,
                half,
                coarse: surface_cloud(&field, half, 0.03, CodeSet::default()),
                fine: surface_cloud(&field, half, 0.02, CodeSet::default()),
                against_wall: support == Support::Wall,
                support,
            }
        })
        .collect()
}

/// No light, tone, noise or blur: the panorama is the room plus the objects' own colours.
fn plain() -> ComposeConfig {
    ComposeConfig {
        place: PlaceConfig {
            presence: 1.0,
            ..PlaceConfig::default()
        },
        light_gain: [1.0, 1.0],
        light_tint: 0.0,
        object_gain: [1.0, 1.0],
        object_shift: 0.0,
        empty_mismatch: 0.0,
        glows: 0,
        noise: 0.0,
        blur_probability: 0.0,
        ..ComposeConfig::default()
    }
}

fn close(a: [f32; 3], b: [f32; 3]) -> bool {
    (0..3).all(|k| (a[k] - b[k]).abs() < 0.02)
}

#[test]
fn labelled_pixels_are_where_objects_are_splatted() {
    let db = database();
    let field = room_field();
    let room = RoomSource::new(&field, &db).expect("the database has panoramas");
    let models = models();
    let mut seen = [0usize; 3];
    for seed in 0..12 {
        let s = compose(room, &models, &plain(), seed);
        assert_eq!(s.labels.len(), s.query.data.len());
        for ((q, e), &label) in s.query.data.iter().zip(&s.empty.data).zip(&s.labels) {
            if label == BACKGROUND {
                assert!(close(*q, *e), "seed {seed}: an unlabelled pixel changed");
                continue;
            }
            let m = label as usize - 1;
            seen[m] += 1;
            let own = COLOURS[m].to_array();
            let rim: [f32; 3] = std::array::from_fn(|k| 0.5 * (own[k] + e[k]));
            assert!(
                close(*q, own) || close(*q, rim),
                "seed {seed}: a pixel labelled {m} shows {q:?}"
            );
        }
    }
    assert!(seen.iter().all(|n| *n > 20), "pixels per model {seen:?}");
}

#[test]
fn placed_objects_follow_the_room_rules() {
    let db = database();
    let field = room_field();
    let room = RoomSource::new(&field, &db).expect("the database has panoramas");
    let models = models();
    let mut placed = [0usize; 3];
    for seed in 0..20 {
        let s = compose(room, &models, &ComposeConfig::default(), seed);
        for (i, (m, b)) in s.boxes.iter().enumerate() {
            placed[*m] += 1;
            let bottom = b.center().z - 0.5 * b.size.z;
            match models[*m].support {
                Support::Floor => assert!(bottom.abs() < 1e-3, "floor object at {bottom}"),
                Support::Wall => {
                    let back = b
                        .pose
                        .transform_point(DVec3::new(-0.5 * b.size.x, 0.0, 0.0));
                    let mut sdf = [0.0];
                    field.sdf(&[back.as_vec3()], &mut sdf);
                    assert!(sdf[0].abs() < 0.01, "wall object's back {} m off", sdf[0]);
                }
                Support::On(base) => {
                    let on = s.boxes.iter().any(|(k, other)| {
                        let top = other.center().z + 0.5 * other.size.z;
                        *k == base
                            && (top - bottom).abs() < 1e-6
                            && other.contains(b.center() - DVec3::Z * (0.5 * b.size.z + 1e-3), 1e-6)
                    });
                    assert!(on, "seed {seed}: the supported object stands on no table");
                }
            }
            for corner in b.corners() {
                let mut sdf = [0.0];
                field.sdf(&[corner.as_vec3()], &mut sdf);
                assert!(
                    sdf[0] > -0.02,
                    "seed {seed}: a corner is {} m inside a wall",
                    -sdf[0]
                );
            }
            for (_, other) in &s.boxes[i + 1..] {
                let shrink = |x: &OrientedBox| OrientedBox::new(x.pose, 0.95 * x.size);
                let shared = shrink(b).intersection_volume(&shrink(other));
                assert!(
                    shared < 1e-9,
                    "seed {seed}: two boxes overlap by {shared} m³"
                );
            }
        }
    }
    assert!(
        placed.iter().all(|n| *n >= 5),
        "placements per model {placed:?}"
    );
}

#[test]
fn composing_is_deterministic_in_the_seed() {
    let db = database();
    let field = room_field();
    let room = RoomSource::new(&field, &db).expect("the database has panoramas");
    let models = models();
    let config = ComposeConfig::default();
    assert_eq!(
        compose(room, &models, &config, 7),
        compose(room, &models, &config, 7)
    );
    assert_ne!(
        compose(room, &models, &config, 7).labels,
        compose(room, &models, &config, 8).labels
    );
}

#[test]
fn an_empty_database_gives_no_source() {
    let field = room_field();
    let empty = Database {
        width: 64,
        height: 32,
        entries: Vec::new(),
    };
    assert!(RoomSource::new(&field, &empty).is_none());
}

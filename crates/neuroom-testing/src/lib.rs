//! A tiny untrained room for tests and examples: NeuS fields at their geometric initialisation — a ball
//! per object model and a ball-shaped room seen from inside — with three named light codes, small hash
//! tables so they build and render in milliseconds, and an arrangement placing them. Product crates take this
//! crate as a dev-dependency only, so no fixture ships in them.

use std::path::Path;

use glam::{DVec3, Vec3};
use neuroom_core::Pose;
use neuroom_core::formats::{ArrangedObject, Arrangement};
use neuroom_field::{GeometricInit, Group, NeusConfig, NeusField, checkpoint};
use neuroom_render::{Background, Model, Scene, SceneObject};
use neuroom_train::dataset::Aabb;
use neuroom_train::room::ModelStats;
use neuroom_train::trainer::LightCodes;
use neuroom_train::{Manifest, ModelEntry, ModelKind, RoomModels};

/// Lower corner of the tiny room's box (metres).
pub const ROOM_MIN: [f32; 3] = [0.0, 0.0, 0.0];
/// Upper corner of the tiny room's box.
pub const ROOM_MAX: [f32; 3] = [3.0, 2.5, 2.4];
/// Centre of the room's ball-shaped shell.
pub const ROOM_CENTRE: [f32; 3] = [1.5, 1.25, 1.2];
/// Radius of the room's shell: its lowest point (the "floor" under the centre) is at z = 0.1.
pub const ROOM_RADIUS: f32 = 1.1;
/// Half extents of the `ball` model's box; its surface is a ball of radius 0.2 (0.8 × 0.25).
pub const BALL_HALF: [f32; 3] = [0.25; 3];
/// Half extents of the `stool` model's box; its surface is a ball of radius 0.16.
pub const STOOL_HALF: [f32; 3] = [0.3, 0.2, 0.25];
/// A `room.json` naming the tiny models' objects (`ball_1`, `ball_2`, `stool_3`), all on the floor.
pub const TINY_ROOM_JSON: &str = r#"{"format": "neuroom.room/1", "name": "tiny",
  "background": {"capture": "captures/background"},
  "objects": [
    {"id": 1, "name": "ball_1", "category": "ball", "capture": "captures/ball", "size": [0.4, 0.4, 0.4], "relations": ["floor"]},
    {"id": 2, "name": "ball_2", "category": "ball", "capture": "captures/ball", "size": [0.4, 0.4, 0.4], "relations": ["floor"]},
    {"id": 3, "name": "stool_3", "category": "stool", "capture": "captures/stool", "size": [0.32, 0.32, 0.32], "relations": ["floor"]}]}"#;

/// Light code names, in row order.
pub const LIGHT_NAMES: [&str; 3] = ["capture", "warm", "cold"];

/// A small field over `[lo, hi]` starting as `init`, with distinct light codes: row 0 as initialised,
/// row 1 all +0.5, row 2 all −0.5.
fn field(lo: [f32; 3], hi: [f32; 3], init: GeometricInit, seed: u64) -> NeusField {
    let mut c = NeusConfig::object([0.5; 3]);
    c.hash.levels = 4;
    c.hash.log2_table = 10;
    c.hash.finest_resolution = 64;
    c.bounds_min = lo;
    c.bounds_max = hi;
    c.init = init;
    c.light_codes = LIGHT_NAMES.len();
    c.seed = seed;
    let mut f = NeusField::new(c);
    let d = f.config().code_dim;
    let light = f.params.get_mut(Group::Light);
    light[d..2 * d].fill(0.5);
    light[2 * d..3 * d].fill(-0.5);
    f
}

fn entry(name: &str, kind: ModelKind, ids: &[u16], field: &NeusField) -> ModelEntry {
    let c = field.config();
    ModelEntry {
        name: name.into(),
        path: name.into(),
        kind,
        ids: ids.to_vec(),
        objects: ids.iter().map(|i| format!("{name}_{i}")).collect(),
        bounds: Aabb {
            min: c.bounds_min,
            max: c.bounds_max,
        },
        object_box: None,
        light_codes: LightCodes {
            names: LIGHT_NAMES.iter().map(|s| s.to_string()).collect(),
            capture: 1,
        },
        appearance_codes: c.appearance_codes,
        stats: ModelStats::default(),
    }
}

/// The models: `background`, `ball` (instances 1 and 2) and `stool` (instance 3).
pub fn tiny_models() -> RoomModels {
    let room = field(
        ROOM_MIN,
        ROOM_MAX,
        GeometricInit {
            centre: ROOM_CENTRE,
            radius: ROOM_RADIUS,
            inside_out: true,
            box_half_extent: None,
        },
        1,
    );
    let ball_init = |half: [f32; 3]| GeometricInit {
        centre: [0.0; 3],
        radius: 0.8 * half.iter().copied().fold(f32::INFINITY, f32::min),
        inside_out: false,
        box_half_extent: None,
    };
    let ball = field(BALL_HALF.map(|h| -h), BALL_HALF, ball_init(BALL_HALF), 2);
    let stool = field(STOOL_HALF.map(|h| -h), STOOL_HALF, ball_init(STOOL_HALF), 3);
    let manifest = Manifest {
        format: neuroom_train::room::MANIFEST_FORMAT.into(),
        room: "tiny".into(),
        room_box: Some(Aabb {
            min: ROOM_MIN,
            max: ROOM_MAX,
        }),
        models: vec![
            entry("background", ModelKind::Background, &[], &room),
            entry("ball", ModelKind::Object, &[1, 2], &ball),
            entry("stool", ModelKind::Object, &[3], &stool),
        ],
        complete: true,
        room_folder: None,
    };
    RoomModels {
        manifest,
        fields: vec![room, ball, stool],
        refined_poses: vec![None; 3],
    }
}

/// Writes [`tiny_models`] as a model folder (`manifest.json` and one checkpoint per model) into `dir`.
pub fn write_tiny_models(dir: &Path) -> anyhow::Result<()> {
    let models = tiny_models();
    for (entry, field) in models.manifest.models.iter().zip(&models.fields) {
        checkpoint::save(&dir.join(&entry.path), field, None, serde_json::Value::Null)?;
    }
    neuroom_core::formats::atomic_write(
        dir.join("manifest.json"),
        &serde_json::to_vec_pretty(&models.manifest)?,
    )?;
    Ok(())
}

/// The panorama camera and the three objects resting on the shell's floor: the balls at (1.2, 1.25) and
/// (1.8, 1.25), the stool at (1.5, 1.6), all yawed differently.
pub fn tiny_arrangement() -> Arrangement {
    let object = |id: u16, name: &str, x: f64, y: f64, yaw: f64| {
        let r = if id == 3 { 0.16 } else { 0.2 };
        ArrangedObject {
            id,
            name: name.into(),
            object_to_world: Pose::from_yaw_translation(
                yaw,
                DVec3::new(x, y, resting_height(x, y, r)),
            ),
            extra: Default::default(),
        }
    };
    Arrangement {
        image: "tiny.png".into(),
        camera_to_world: Pose::from_yaw_translation(0.3, DVec3::new(1.5, 1.0, 1.2)),
        objects: vec![
            object(1, "ball_1", 1.2, 1.25, 0.0),
            object(2, "ball_2", 1.8, 1.25, 0.5),
            object(3, "stool_3", 1.5, 1.6, -0.4),
        ],
        lighting: serde_json::Value::Null,
        extra: Default::default(),
    }
}

/// Height of the centre of a ball of `radius` resting in the room shell (a bowl) with its centre above
/// `(x, y)`: its centre lies `ROOM_RADIUS − radius` from the shell's centre.
pub fn resting_height(x: f64, y: f64, radius: f64) -> f64 {
    let c = Vec3::from(ROOM_CENTRE).as_dvec3();
    let r2 = (x - c.x).powi(2) + (y - c.y).powi(2);
    c.z - ((f64::from(ROOM_RADIUS) - radius).powi(2) - r2)
        .max(0.0)
        .sqrt()
}

/// [`tiny_models`] placed by [`tiny_arrangement`], as the face's scene builder places trained models.
pub fn tiny_scene() -> Scene<NeusField> {
    let models = tiny_models();
    let arrangement = tiny_arrangement();
    let half = |m: usize| Vec3::from(models.manifest.models[m].bounds.max);
    let objects = arrangement
        .objects
        .iter()
        .map(|o| {
            let m = if o.id == 3 { 2 } else { 1 };
            SceneObject::new(m, o.id, &o.object_to_world, half(m))
        })
        .collect();
    Scene {
        models: models.fields.into_iter().map(Model::neus).collect(),
        background: Background {
            model: 0,
            bounds_min: Vec3::from(ROOM_MIN),
            bounds_max: Vec3::from(ROOM_MAX),
            codes: Default::default(),
            tone: Default::default(),
        },
        objects,
    }
}

/// Copies the folder `from` into `to`, recursively (plain files and folders; panics on any error).
pub fn copy_folder(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_folder(&entry.path(), &target);
        } else {
            std::fs::copy(entry.path(), &target).unwrap();
        }
    }
}

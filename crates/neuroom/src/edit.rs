//! `neuroom edit`: move, rotate, remove and insert objects of an arrangement, keep the result physically
//! valid by settling every touched object onto the floor or onto what stands under it, write the edited
//! arrangement and render it.
//!
//! An edit file is JSON:
//! ```json
//! { "edits": [
//!     { "op": "move",   "object": "chair", "to": [2.0, 1.5] },
//!     { "op": "move",   "object": 3, "by": [0.2, 0.0, 0.0] },
//!     { "op": "rotate", "object": "desk", "yaw_deg": 90 },
//!     { "op": "remove", "object": "picture" },
//!     { "op": "insert", "model": "chair", "at": [1.0, 2.0], "yaw_deg": 30 },
//!     { "op": "insert", "model": "stool", "models": "../other/models/kitchen", "at": [2.5, 1.0, 0.8] } ],
//!   "settle": true }
//! ```
//! Objects are named by id or name; `to`/`at` with two numbers keep (or start from) the current height.
//! An inserted object records its model by name (`model`, and `models`, the other room's model folder,
//! when it comes from there) so every command can place it again.
//!
//! Settling drops an object along −z until its downward-facing surface (the vertices of a mesh
//! extracted from its SDF whose normals point down) touches a surface facing up, found by sphere
//! tracing the union of the room's and the other objects' SDFs; an object that starts inside a support
//! is first lifted out of it. Objects standing on a moved object are not carried along.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail, ensure};
use glam::{DMat3, DVec3, Vec3};
use neuroom_core::Pose;
use neuroom_core::formats::{ArrangedObject, Arrangement, read_arrangement, write_arrangement};
use neuroom_export::lighting::{SceneLight, fit_report_path};
use neuroom_export::mesh::Geometry;
use neuroom_field::{Field, NeusField, checkpoint};
use neuroom_render::{Model, Scene, SceneObject};
use neuroom_train::{Manifest, ModelKind};
use serde::Deserialize;
use serde_json::{Value, json};

use crate::scene::{build_scene, load_models};
use crate::view::{ViewCamera, render_arrangement, write_view};

/// Names an object of the arrangement.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(untagged)]
pub enum ObjectRef {
    /// By id.
    Id(u16),
    /// By name.
    Name(String),
}

/// One edit.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "op", rename_all = "snake_case", deny_unknown_fields)]
pub enum Edit {
    /// Moves an object to a position (`to`: x, y or x, y, z) or by an offset (`by`: dx, dy, dz).
    Move {
        /// Which object.
        object: ObjectRef,
        /// New centre.
        #[serde(default)]
        to: Option<Vec<f64>>,
        /// Offset.
        #[serde(default)]
        by: Option<[f64; 3]>,
    },
    /// Turns an object about the vertical axis through its centre.
    Rotate {
        /// Which object.
        object: ObjectRef,
        /// Angle, degrees, counter-clockwise seen from above.
        yaw_deg: f64,
    },
    /// Takes an object out.
    Remove {
        /// Which object.
        object: ObjectRef,
    },
    /// Adds an instance of an object model of this room, or of another room's model folder.
    Insert {
        /// The model's name in its manifest.
        model: String,
        /// Another room's model folder (relative to the edit file); absent: this room's.
        #[serde(default)]
        models: Option<PathBuf>,
        /// Its id (default: one more than the largest id in use).
        #[serde(default)]
        id: Option<u16>,
        /// Its name (default `<model>_<id>`).
        #[serde(default)]
        name: Option<String>,
        /// Centre x, y (standing on whatever is below) or x, y, z.
        at: Vec<f64>,
        /// Heading, degrees.
        #[serde(default)]
        yaw_deg: f64,
    },
}

/// An edit file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EditFile {
    /// Edits, applied in order.
    pub edits: Vec<Edit>,
    /// Settle moved, rotated and inserted objects onto their support (default true).
    #[serde(default = "yes")]
    pub settle: bool,
}

fn yes() -> bool {
    true
}

/// Reads an edit file; errors name the file.
pub fn read_edit_file(path: &Path) -> anyhow::Result<EditFile> {
    let text = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_slice(&text).with_context(|| format!("{}: not an edit file", path.display()))
}

/// What the scene's models are, by model index.
#[derive(Clone, Debug, Default)]
pub struct PlacedModels {
    /// Model names (manifest names; a model from another room is `<room>/<name>`).
    pub names: Vec<String>,
    /// Light code names of each model, in row order.
    pub light_names: Vec<Vec<String>>,
    /// The room box of the manifest, when it has one (`min`, `max`).
    pub room_box: Option<(Vec3, Vec3)>,
}

/// The model an arranged object asks for by name (`model`, and `models` for another room's folder).
fn named_model(o: &ArrangedObject) -> anyhow::Result<Option<(Option<PathBuf>, String)>> {
    let Some(model) = o.extra.get("model") else {
        return Ok(None);
    };
    let model = model
        .as_str()
        .with_context(|| format!("object {}: `model` must be a string", o.id))?;
    let dir = match o.extra.get("models") {
        Some(Value::String(d)) => Some(PathBuf::from(d)),
        Some(_) => bail!("object {}: `models` must be a path", o.id),
        None => None,
    };
    Ok(Some((dir, model.to_string())))
}

/// Reads a model folder's manifest.
pub(crate) fn read_manifest(dir: &Path) -> anyhow::Result<Manifest> {
    let path = dir.join("manifest.json");
    let text = std::fs::read(&path).with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_slice(&text)
        .with_context(|| format!("{}: not a model manifest", path.display()))
}

/// Places the models of `models` as `arrangement` says: objects by id as the trained manifest lists
/// them, and objects naming their model (inserted by an edit, possibly from another room's folder) by
/// that name. Returns the scene (objects in the arrangement's order) and what its models are.
pub fn place_models(
    models: &Path,
    arrangement: &Arrangement,
) -> anyhow::Result<(Scene<NeusField>, PlacedModels)> {
    let loaded = load_models(models)?;
    let manifest = loaded.manifest.clone();
    let mut by_id = arrangement.clone();
    let mut named = Vec::new();
    for o in &arrangement.objects {
        named.push(named_model(o)?);
    }
    let mut keep = named.iter().map(Option::is_none);
    by_id.objects.retain(|_| keep.next().unwrap_or(true));
    let mut scene = build_scene(loaded, &by_id)?;
    let mut placed = PlacedModels {
        names: manifest.models.iter().map(|m| m.name.clone()).collect(),
        light_names: manifest
            .models
            .iter()
            .map(|m| m.light_codes.names.clone())
            .collect(),
        room_box: manifest
            .room_box
            .map(|b| (Vec3::from(b.min), Vec3::from(b.max))),
    };
    let mut native = std::mem::take(&mut scene.objects).into_iter();
    let mut loaded_named: HashMap<(PathBuf, String), (usize, Vec3)> = HashMap::new();
    for (o, named) in arrangement.objects.iter().zip(named) {
        let object = match named {
            None => native.next().context("scene objects out of step")?,
            Some((dir, name)) => {
                let dir = dir.unwrap_or_else(|| models.to_path_buf());
                let key = (dir.clone(), name.clone());
                let (model, half) = match loaded_named.get(&key) {
                    Some(v) => *v,
                    None => {
                        let v = load_named_model(&dir, &name, &mut scene, &mut placed)
                            .with_context(|| format!("object {} (`{}`)", o.id, o.name))?;
                        loaded_named.insert(key, v);
                        v
                    }
                };
                SceneObject::new(model, o.id, &o.object_to_world, half)
            }
        };
        scene.objects.push(object);
    }
    Ok((scene, placed))
}

/// Loads object model `name` of the folder `dir` into the scene; returns its index and half extents.
fn load_named_model(
    dir: &Path,
    name: &str,
    scene: &mut Scene<NeusField>,
    placed: &mut PlacedModels,
) -> anyhow::Result<(usize, Vec3)> {
    let manifest = read_manifest(dir)?;
    let entry = manifest
        .models
        .iter()
        .find(|m| m.name == name && m.kind == ModelKind::Object)
        .with_context(|| format!("{} has no object model `{name}`", dir.display()))?;
    let (field, _, _) = checkpoint::load(&dir.join(&entry.path))?;
    let half = Vec3::from(entry.half_extents());
    scene.models.push(Model::neus(field));
    placed.names.push(format!("{}/{name}", manifest.room));
    placed.light_names.push(entry.light_codes.names.clone());
    Ok((scene.models.len() - 1, half))
}

/// Index of the object `r` names.
fn find(arrangement: &Arrangement, r: &ObjectRef) -> anyhow::Result<usize> {
    arrangement
        .objects
        .iter()
        .position(|o| match r {
            ObjectRef::Id(id) => o.id == *id,
            ObjectRef::Name(n) => o.name == *n,
        })
        .with_context(|| format!("the arrangement has no object {r:?}"))
}

/// A centre from 2 or 3 numbers; two keep `z`.
fn position(v: &[f64], z: f64, what: &str) -> anyhow::Result<DVec3> {
    ensure!(
        v.iter().all(|x| x.is_finite()),
        "{what}: numbers must be finite"
    );
    match *v {
        [x, y] => Ok(DVec3::new(x, y, z)),
        [x, y, z] => Ok(DVec3::new(x, y, z)),
        _ => bail!(
            "{what}: expected [x, y] or [x, y, z], found {} numbers",
            v.len()
        ),
    }
}

/// Applies `edits` to `arrangement`; `base` resolves relative model folders. Returns the ids of the
/// objects moved, turned or inserted, in order.
pub fn apply_edits(
    arrangement: &mut Arrangement,
    edits: &[Edit],
    base: &Path,
) -> anyhow::Result<Vec<u16>> {
    let mut touched = Vec::new();
    for (k, edit) in edits.iter().enumerate() {
        apply_edit(arrangement, edit, base, &mut touched).with_context(|| format!("edit {k}"))?;
    }
    let present: Vec<u16> = arrangement.objects.iter().map(|o| o.id).collect();
    touched.retain(|id| present.contains(id));
    touched.dedup();
    Ok(touched)
}

fn apply_edit(
    arrangement: &mut Arrangement,
    edit: &Edit,
    base: &Path,
    touched: &mut Vec<u16>,
) -> anyhow::Result<()> {
    match edit {
        Edit::Move { object, to, by } => {
            let k = find(arrangement, object)?;
            let o = &mut arrangement.objects[k];
            let t = o.object_to_world.translation;
            o.object_to_world.translation = match (to, by) {
                (Some(to), None) => position(to, t.z, "to")?,
                (None, Some(by)) => t + DVec3::from(*by),
                _ => bail!("a move needs exactly one of `to` and `by`"),
            };
            touched.push(o.id);
        }
        Edit::Rotate { object, yaw_deg } => {
            ensure!(yaw_deg.is_finite(), "yaw_deg must be finite");
            let k = find(arrangement, object)?;
            let o = &mut arrangement.objects[k];
            let turn = DMat3::from_rotation_z(yaw_deg.to_radians());
            o.object_to_world.rotation = turn * o.object_to_world.rotation;
            touched.push(o.id);
        }
        Edit::Remove { object } => {
            let k = find(arrangement, object)?;
            arrangement.objects.remove(k);
        }
        Edit::Insert {
            model,
            models,
            id,
            name,
            at,
            yaw_deg,
        } => {
            let o = inserted(
                arrangement,
                model,
                models.as_deref(),
                *id,
                name,
                at,
                *yaw_deg,
                base,
            )?;
            touched.push(o.id);
            arrangement.objects.push(o);
        }
    }
    Ok(())
}

/// The object an insert adds; it copies the solved lighting of another instance of its model if any.
#[allow(clippy::too_many_arguments)]
fn inserted(
    arrangement: &Arrangement,
    model: &str,
    models: Option<&Path>,
    id: Option<u16>,
    name: &Option<String>,
    at: &[f64],
    yaw_deg: f64,
    base: &Path,
) -> anyhow::Result<ArrangedObject> {
    ensure!(yaw_deg.is_finite(), "yaw_deg must be finite");
    let next = arrangement.objects.iter().map(|o| o.id).max().unwrap_or(0);
    let id = match id {
        Some(id) => id,
        None => next.checked_add(1).context("no free object id")?,
    };
    ensure!(id > 0, "object ids start at 1");
    let name = name.clone().unwrap_or_else(|| format!("{model}_{id}"));
    ensure!(
        !arrangement
            .objects
            .iter()
            .any(|o| o.id == id || o.name == name),
        "id {id} or name `{name}` is already in use"
    );
    let centre = position(at, 1.0, "at")?;
    let mut extra = serde_json::Map::new();
    extra.insert("model".into(), json!(model));
    if let Some(dir) = models {
        let dir = base.join(dir);
        let dir = dir
            .canonicalize()
            .with_context(|| format!("model folder {}", dir.display()))?;
        extra.insert("models".into(), json!(dir.to_string_lossy()));
    }
    let twin = arrangement
        .objects
        .iter()
        .find(|o| o.extra.get("model").and_then(Value::as_str) == Some(model));
    for key in ["tone", "light_code"] {
        if let Some(v) = twin.and_then(|t| t.extra.get(key)) {
            extra.insert(key.into(), v.clone());
        }
    }
    Ok(ArrangedObject {
        id,
        name,
        object_to_world: Pose::from_yaw_translation(yaw_deg.to_radians(), centre),
        extra,
    })
}

/// Distance tolerance of a contact (metres).
const CONTACT: f32 = 0.002;
/// Most sphere-tracing steps per point.
const MAX_STEPS: usize = 400;

/// Signed distance from world `points` to the nearest support: the room, and every object but `skip`.
/// Outside the room's box the distance is minus the distance to it (below the floor is inside a
/// support); outside an object's box, the distance to that box bounds it.
fn support_sdf(scene: &Scene<NeusField>, skip: usize, points: &[Vec3]) -> Vec<f32> {
    let bg = &scene.background;
    let mut out = vec![0.0; points.len()];
    scene.models[bg.model].field.sdf(points, &mut out);
    for (s, p) in out.iter_mut().zip(points) {
        let outside = (bg.bounds_min - *p).max(*p - bg.bounds_max).max(Vec3::ZERO);
        if outside != Vec3::ZERO {
            *s = -outside.length();
        }
    }
    for (j, o) in scene.objects.iter().enumerate() {
        if j == skip {
            continue;
        }
        let r = o.rotation().transpose();
        let local: Vec<Vec3> = points.iter().map(|p| r * (*p - o.translation)).collect();
        let inside: Vec<usize> = (0..points.len())
            .filter(|&i| (local[i].abs() - o.half_extents).max_element() < 0.0)
            .collect();
        let mut values = vec![0.0; inside.len()];
        let query: Vec<Vec3> = inside.iter().map(|&i| local[i]).collect();
        scene.models[o.model].field.sdf(&query, &mut values);
        for (i, s) in out.iter_mut().enumerate() {
            let box_distance = (local[i].abs() - o.half_extents).max(Vec3::ZERO).length();
            if box_distance > 0.0 {
                *s = s.min(box_distance);
            }
        }
        for (&i, v) in inside.iter().zip(values) {
            out[i] = out[i].min(v);
        }
    }
    out
}

/// The z component of the unit normal of the support field at `points` (central differences).
fn support_normal_z(scene: &Scene<NeusField>, skip: usize, points: &[Vec3]) -> Vec<f32> {
    let h = 0.005;
    let offsets = [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z];
    let probes: Vec<Vec3> = points
        .iter()
        .flat_map(|p| offsets.iter().map(move |d| *p + h * *d))
        .collect();
    let s = support_sdf(scene, skip, &probes);
    s.chunks(6)
        .map(|v| {
            let g = Vec3::new(v[0] - v[1], v[2] - v[3], v[4] - v[5]);
            g.try_normalize().map_or(0.0, |n| n.z)
        })
        .collect()
}

/// The downward-facing surface points of object `k` in the world (all its vertices if none faces down).
fn bottom_points(scene: &Scene<NeusField>, k: usize) -> anyhow::Result<Vec<Vec3>> {
    let o = &scene.objects[k];
    let g = Geometry::extract(
        &scene.models[o.model].field,
        -o.half_extents,
        o.half_extents,
        24,
    );
    ensure!(
        !g.is_empty(),
        "object {} has no surface to rest on",
        o.instance_id
    );
    let r = o.rotation();
    let world = |p: &Vec3| r * *p + o.translation;
    let down: Vec<Vec3> = g
        .positions
        .iter()
        .zip(&g.normals)
        .filter(|(_, n)| (r * **n).z < -0.3)
        .map(|(p, _)| world(p))
        .collect();
    Ok(if down.is_empty() {
        g.positions.iter().map(world).collect()
    } else {
        down
    })
}

/// How far the points may drop along −z before one of them touches an upward-facing support.
fn drop_distance(scene: &Scene<NeusField>, k: usize, points: &[Vec3], limit: f32) -> Option<f32> {
    let mut t = vec![0.0f32; points.len()];
    let mut active: Vec<usize> = (0..points.len()).collect();
    let mut best = f32::INFINITY;
    for _ in 0..MAX_STEPS {
        active.retain(|&i| t[i] < best.min(limit));
        if active.is_empty() {
            break;
        }
        let q: Vec<Vec3> = active.iter().map(|&i| points[i] - t[i] * Vec3::Z).collect();
        let s = support_sdf(scene, k, &q);
        let near: Vec<usize> = (0..q.len()).filter(|&a| s[a] < CONTACT).collect();
        let up = support_normal_z(scene, k, &near.iter().map(|&a| q[a]).collect::<Vec<_>>());
        let mut facing_up = vec![false; q.len()];
        for (&a, nz) in near.iter().zip(up) {
            facing_up[a] = nz > 0.5;
        }
        for (a, &i) in active.iter().enumerate() {
            if facing_up[a] {
                best = best.min(t[i]);
            } else {
                t[i] += (0.9 * s[a]).max(2.0 * CONTACT);
            }
        }
    }
    best.is_finite().then_some(best)
}

/// Drops object `k` of `scene` onto the support under it (lifting it out of a support it starts in
/// first) and returns the vertical move in metres.
pub fn settle(scene: &mut Scene<NeusField>, k: usize) -> anyhow::Result<f32> {
    let id = scene.objects[k].instance_id;
    let mut points = bottom_points(scene, k)?;
    let limit = scene.background.bounds_max.z - scene.background.bounds_min.z;
    let mut lift = 0.0f32;
    for _ in 0..8 {
        let s = support_sdf(scene, k, &points);
        let inside: Vec<Vec3> = (0..points.len())
            .filter(|&i| s[i] < -CONTACT)
            .map(|i| points[i])
            .collect();
        let up = support_normal_z(scene, k, &inside);
        let depth = s
            .iter()
            .filter(|v| **v < -CONTACT)
            .zip(&up)
            .filter(|(_, nz)| **nz > 0.5)
            .map(|(v, _)| -v)
            .fold(0.0f32, f32::max);
        if depth == 0.0 {
            break;
        }
        lift += depth + CONTACT;
        points.iter_mut().for_each(|p| p.z += depth + CONTACT);
    }
    let drop = drop_distance(scene, k, &points, limit + lift)
        .with_context(|| format!("nothing under object {id} to rest on"))?;
    let dz = lift - drop;
    scene.objects[k].translation.z += dz;
    Ok(dz)
}

/// What an edit wrote.
#[derive(Clone, Debug)]
pub struct EditOutputs {
    /// The edited arrangement.
    pub arrangement: PathBuf,
    /// Its render, when asked for.
    pub render: Option<PathBuf>,
    /// Vertical moves of the settled objects: (id, metres).
    pub settled: Vec<(u16, f32)>,
}

/// Applies the edit file `edit` to `arrangement` placed with `models`, settles the touched objects
/// (unless the edit file says not to), writes the result to `out` (carrying the room's solved lighting
/// along) and, with `camera`, renders it to `<out stem>.png`.
pub fn edit_arrangement(
    models: &Path,
    arrangement: &Path,
    edit: &Path,
    out: &Path,
    camera: Option<&ViewCamera>,
) -> anyhow::Result<EditOutputs> {
    let file = read_edit_file(edit)?;
    let base = edit.parent().unwrap_or(Path::new("."));
    let (mut edited, settled) =
        edit_in_memory(models, &read_arrangement(arrangement)?, &file, base)
            .with_context(|| edit.display().to_string())?;
    carry_room_lighting(&mut edited, arrangement)?;
    write_arrangement(out, &edited)?;
    let render = match camera {
        Some(c) => {
            let png = out.with_extension("png");
            write_view(&render_arrangement(models, out, c)?, &png, None, None)?;
            Some(png)
        }
        None => None,
    };
    Ok(EditOutputs {
        arrangement: out.to_path_buf(),
        render,
        settled,
    })
}

/// Applies the edits of `file` to `arrangement` placed with `models` (another room's model folders
/// named relative to `base`) and settles the touched objects unless the file says not to; returns
/// the edited arrangement and the vertical moves of the settled objects: (id, metres).
pub fn edit_in_memory(
    models: &Path,
    arrangement: &Arrangement,
    file: &EditFile,
    base: &Path,
) -> anyhow::Result<(Arrangement, Vec<(u16, f32)>)> {
    let mut edited = arrangement.clone();
    let touched = apply_edits(&mut edited, &file.edits, base)?;
    let mut settled = Vec::new();
    if file.settle && !touched.is_empty() {
        let (mut scene, _) = place_models(models, &edited)?;
        for id in touched {
            let k = edited
                .objects
                .iter()
                .position(|o| o.id == id)
                .context("touched object vanished")?;
            let dz = settle(&mut scene, k)?;
            edited.objects[k].object_to_world = scene.objects[k].pose();
            settled.push((id, dz));
        }
    }
    Ok((edited, settled))
}

/// Copies the room's solved lighting of the source (its report beside it) into the edited arrangement,
/// which is written elsewhere.
fn carry_room_lighting(edited: &mut Arrangement, source: &Path) -> anyhow::Result<()> {
    let report = fit_report_path(source);
    if !report.exists() {
        return Ok(());
    }
    let light = SceneLight::solved(edited, source, Some(&report))?;
    if let Some(bg) = light.background {
        edited
            .extra
            .insert("background_light_code".into(), json!(bg.code));
        edited
            .extra
            .insert("background_tone".into(), serde_json::to_value(bg.tone)?);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_testing::{resting_height, tiny_arrangement, tiny_scene, write_tiny_models};

    fn ball_at(scene: &mut Scene<NeusField>, k: usize, p: Vec3) {
        scene.objects[k].translation = p;
    }

    #[test]
    fn a_ball_dropped_from_above_rests_on_the_floor() {
        let mut scene = tiny_scene();
        ball_at(&mut scene, 0, Vec3::new(1.5, 0.9, 1.0));
        settle(&mut scene, 0).unwrap();
        let expected = resting_height(1.5, 0.9, 0.2) as f32;
        let z = scene.objects[0].translation.z;
        assert!(
            (z - expected).abs() < 0.03,
            "rests at {z}, expected {expected}"
        );
    }

    #[test]
    fn a_ball_sunk_into_the_floor_is_lifted_onto_it() {
        let mut scene = tiny_scene();
        let rest = resting_height(1.5, 0.9, 0.2) as f32;
        ball_at(&mut scene, 0, Vec3::new(1.5, 0.9, rest - 0.1));
        let dz = settle(&mut scene, 0).unwrap();
        assert!(dz > 0.05, "lifted by {dz}");
        let z = scene.objects[0].translation.z;
        assert!((z - rest).abs() < 0.03, "rests at {z}, expected {rest}");
    }

    #[test]
    fn a_ball_dropped_onto_the_stool_stands_on_it() {
        let mut scene = tiny_scene();
        let stool = scene.objects[2].translation;
        ball_at(&mut scene, 0, stool + Vec3::new(0.0, 0.0, 0.9));
        settle(&mut scene, 0).unwrap();
        // Stool ball radius 0.16, ball radius 0.2.
        let expected = stool.z + 0.16 + 0.2;
        let z = scene.objects[0].translation.z;
        assert!(
            (z - expected).abs() < 0.03,
            "rests at {z}, expected {expected}"
        );
    }

    fn edits(json: &str) -> Vec<Edit> {
        serde_json::from_str::<EditFile>(json).unwrap().edits
    }

    #[test]
    fn edits_move_rotate_remove_and_insert() {
        let mut a = tiny_arrangement();
        let e = edits(
            r#"{ "edits": [
                { "op": "move", "object": "ball_1", "to": [1.4, 1.1] },
                { "op": "move", "object": 2, "by": [0.1, 0.0, 0.0] },
                { "op": "rotate", "object": 3, "yaw_deg": 90 },
                { "op": "remove", "object": "ball_2" },
                { "op": "insert", "model": "ball", "at": [1.6, 0.9], "yaw_deg": 45 } ] }"#,
        );
        let z1 = a.objects[0].object_to_world.translation.z;
        let yaw3 = a.objects[2].object_to_world.yaw();
        let touched = apply_edits(&mut a, &e, Path::new(".")).unwrap();
        assert_eq!(touched, vec![1, 3, 4], "the removed object is not settled");
        assert_eq!(
            a.objects[0].object_to_world.translation,
            DVec3::new(1.4, 1.1, z1)
        );
        assert!(a.objects.iter().all(|o| o.id != 2));
        let turned = a.objects[1].object_to_world.yaw() - yaw3;
        assert!((turned - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
        let new = a.objects.last().unwrap();
        assert_eq!((new.id, new.name.as_str()), (4, "ball_4"));
        assert_eq!(new.extra["model"], "ball");
    }

    #[test]
    fn bad_edits_name_the_problem() {
        let mut a = tiny_arrangement();
        let e = edits(r#"{ "edits": [ { "op": "remove", "object": "sofa" } ] }"#);
        let msg = format!("{:#}", apply_edits(&mut a, &e, Path::new(".")).unwrap_err());
        assert!(msg.contains("edit 0") && msg.contains("sofa"), "{msg}");
        let e = edits(r#"{ "edits": [ { "op": "move", "object": 1 } ] }"#);
        assert!(apply_edits(&mut a, &e, Path::new(".")).is_err());
        let e =
            edits(r#"{ "edits": [ { "op": "insert", "model": "ball", "id": 3, "at": [1, 1] } ] }"#);
        assert!(
            apply_edits(&mut a, &e, Path::new(".")).is_err(),
            "id in use"
        );
        assert!(serde_json::from_str::<EditFile>(r#"{ "edits": [ { "op": "fly" } ] }"#).is_err());
    }

    #[test]
    fn edit_pipeline_inserts_from_another_folder_settles_and_renders() {
        let dir = tempfile::tempdir().unwrap();
        let (here, there) = (dir.path().join("here"), dir.path().join("there"));
        write_tiny_models(&here).unwrap();
        write_tiny_models(&there).unwrap();
        let arrangement = dir.path().join("arr.json");
        write_arrangement(&arrangement, &tiny_arrangement()).unwrap();
        let edit = dir.path().join("edit.json");
        std::fs::write(
            &edit,
            r#"{ "edits": [
                { "op": "insert", "model": "stool", "models": "there", "at": [1.5, 0.8, 1.5] },
                { "op": "move", "object": "ball_1", "to": [1.2, 1.25, 0.9] } ] }"#,
        )
        .unwrap();
        let out = dir.path().join("edited.json");
        let camera = ViewCamera::Panorama { width: 32 };
        let result = edit_arrangement(&here, &arrangement, &edit, &out, Some(&camera)).unwrap();
        assert_eq!(result.settled.len(), 2);
        let edited = read_arrangement(&out).unwrap();
        let stool = edited.objects.iter().find(|o| o.id == 4).unwrap();
        let expected = resting_height(1.5, 0.8, 0.16);
        let z = stool.object_to_world.translation.z;
        assert!(
            (z - expected).abs() < 0.03,
            "stool rests at {z}, expected {expected}"
        );
        let ball = &edited.objects[0];
        let z = ball.object_to_world.translation.z;
        assert!(
            (z - resting_height(1.2, 1.25, 0.2)).abs() < 0.03,
            "ball rests at {z}"
        );
        let (scene, placed) = place_models(&here, &edited).unwrap();
        assert_eq!(
            scene.models.len(),
            4,
            "the other room's stool is a model of its own"
        );
        assert_eq!(placed.names[3], "tiny/stool");
        assert!(result.render.unwrap().exists());
    }
}

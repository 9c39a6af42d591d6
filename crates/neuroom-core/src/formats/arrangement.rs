//! Arrangement files: where the panorama camera and every object stand, and the lighting (docs/formats.md,
//! "Arrangement"). The same schema holds ground truth and the output of understanding a panorama.

use super::json::{
    JsonObject, as_integer_in, as_nonempty_str, as_pose, parse_json, pose_value, write_json,
};
use super::room::nonempty;
use crate::error::{FormatError, FormatResult};
use crate::pose::Pose;
use serde_json::{Map, Value};
use std::path::Path;

/// The format tag this module reads and writes.
pub const ARRANGEMENT_FORMAT: &str = "neuroom.arrangement/1";

/// A solved (or ground-truth) scene for one panorama.
#[derive(Clone, Debug, PartialEq)]
pub struct Arrangement {
    /// The panorama image file name, relative to the arrangement file's folder.
    pub image: String,
    /// Panorama camera pose in docs/formats.md's panorama frame (+x centre column, +y left, +z up).
    pub camera_to_world: Pose,
    /// The objects placed in the room.
    pub objects: Vec<ArrangedObject>,
    /// Free-form lighting description; `Value::Null` when absent (and then not written).
    pub lighting: Value,
    /// Top-level fields this reader does not know (scores, timings, …), written back unchanged.
    pub extra: Map<String, Value>,
}

/// One object's placement.
#[derive(Clone, Debug, PartialEq)]
pub struct ArrangedObject {
    /// Instance id from room.json (1..=65535).
    pub id: u16,
    /// Object name from room.json.
    pub name: String,
    /// Maps the object's canonical frame to the world frame.
    pub object_to_world: Pose,
    /// Per-object fields this reader does not know (scores, tone adjusters, …), written back unchanged.
    pub extra: Map<String, Value>,
}

/// Reads an arrangement file, rejecting a wrong format tag, bad poses, and duplicate ids or names.
pub fn read_arrangement(path: impl AsRef<Path>) -> FormatResult<Arrangement> {
    let file = path.as_ref();
    let bytes =
        std::fs::read(file).map_err(|e| FormatError::file(file, format!("cannot read: {e}")))?;
    parse_arrangement(file, &bytes)
}

/// Parses the bytes of the arrangement file `file`, validating as [`read_arrangement`] does.
pub fn parse_arrangement(file: &Path, bytes: &[u8]) -> FormatResult<Arrangement> {
    let value = parse_json(file, bytes)?;
    let top = JsonObject::root(file, &value)?;
    top.check_format(ARRANGEMENT_FORMAT)?;
    let objects = top
        .objects("objects")?
        .iter()
        .map(read_object)
        .collect::<FormatResult<Vec<_>>>()?;
    super::check_unique(file, objects.iter().map(|o| (o.id, o.name.as_str())))?;
    Ok(Arrangement {
        image: top.required("image", as_nonempty_str)?.to_string(),
        camera_to_world: top.required("camera_to_world", as_pose)?,
        objects,
        lighting: top.get("lighting").cloned().unwrap_or(Value::Null),
        extra: top.unknown_fields(&["format", "image", "camera_to_world", "objects", "lighting"]),
    })
}

/// Reads one entry of `objects`.
fn read_object(o: &JsonObject) -> FormatResult<ArrangedObject> {
    Ok(ArrangedObject {
        id: o.required("id", as_integer_in(1, 65535))? as u16,
        name: o.required("name", as_nonempty_str)?.to_string(),
        object_to_world: o.required("object_to_world", as_pose)?,
        extra: o.unknown_fields(&["id", "name", "object_to_world"]),
    })
}

/// Writes `arrangement` to `path` atomically, checking what the reader checks.
pub fn write_arrangement(path: impl AsRef<Path>, arrangement: &Arrangement) -> FormatResult<()> {
    let file = path.as_ref();
    write_json(file, &arrangement_value(file, arrangement)?)
}

/// `arrangement` as the JSON value its file holds, checking what the reader checks; errors name
/// `file`, the file it is meant for.
pub fn arrangement_value(file: &Path, arrangement: &Arrangement) -> FormatResult<Value> {
    super::check_unique(
        file,
        arrangement.objects.iter().map(|o| (o.id, o.name.as_str())),
    )?;
    nonempty(file, "image", &arrangement.image)?;
    let mut top = Map::new();
    top.insert("format".into(), ARRANGEMENT_FORMAT.into());
    top.insert("image".into(), arrangement.image.clone().into());
    top.insert(
        "camera_to_world".into(),
        pose_value(file, "camera_to_world", &arrangement.camera_to_world)?,
    );
    let objects = arrangement
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| object_value(file, i, o))
        .collect::<FormatResult<Vec<_>>>()?;
    top.insert("objects".into(), objects.into());
    if !arrangement.lighting.is_null() {
        top.insert("lighting".into(), arrangement.lighting.clone());
    }
    for (k, v) in &arrangement.extra {
        top.entry(k.clone()).or_insert_with(|| v.clone());
    }
    Ok(Value::Object(top))
}

/// One entry of `objects`, for writing.
fn object_value(file: &Path, i: usize, o: &ArrangedObject) -> FormatResult<Value> {
    let at = format!("objects[{i}]");
    if o.id == 0 {
        return Err(FormatError::field(
            file,
            format!("{at}.id"),
            "ids start at 1 (0 means no object)",
        ));
    }
    nonempty(file, &format!("{at}.name"), &o.name)?;
    let mut m = Map::new();
    m.insert("id".into(), o.id.into());
    m.insert("name".into(), o.name.clone().into());
    m.insert(
        "object_to_world".into(),
        pose_value(file, &format!("{at}.object_to_world"), &o.object_to_world)?,
    );
    for (k, v) in &o.extra {
        m.entry(k.clone()).or_insert_with(|| v.clone());
    }
    Ok(Value::Object(m))
}

//! `room.json`: the closed scene, its background capture and its movable objects (docs/formats.md, "A room").

use super::json::{
    JsonObject, as_integer_in, as_nonempty_str, as_pose, as_positive_vec3, as_strings, parse_json,
    pose_value, write_json,
};
use crate::error::{FormatError, FormatResult};
use crate::pose::Pose;
use glam::DVec3;
use serde_json::{Map, Value, json};
use std::path::{Path, PathBuf};

/// The format tag this module reads and writes.
pub const ROOM_FORMAT: &str = "neuroom.room/1";

/// A room: where it lives on disk, its background capture and its movable objects.
#[derive(Clone, Debug, PartialEq)]
pub struct Room {
    /// The room folder (holding `room.json`); capture paths are relative to it.
    pub root: PathBuf,
    /// Human-readable room name.
    pub name: String,
    /// The capture of the empty room.
    pub background: BackgroundSpec,
    /// The movable objects, in file order.
    pub objects: Vec<RoomObject>,
    /// Top-level fields this reader does not know (e.g. `room_box`), written back unchanged.
    pub extra: Map<String, Value>,
}

/// Where the background (empty room) capture lives.
#[derive(Clone, Debug, PartialEq)]
pub struct BackgroundSpec {
    /// Capture folder relative to the room folder.
    pub capture: PathBuf,
}

/// One movable object of a room.
#[derive(Clone, Debug, PartialEq)]
pub struct RoomObject {
    /// Instance id in 1..=65535, the value of its pixels in instance masks.
    pub id: u16,
    /// Unique name.
    pub name: String,
    /// Free-form category (e.g. "chair").
    pub category: String,
    /// Capture folder relative to the room folder; shared by instances of one model.
    pub capture: PathBuf,
    /// Full extents of the bounding box in the canonical frame, metres.
    pub size: DVec3,
    /// Maps the capture frame to the object's canonical frame.
    pub capture_to_object: Pose,
    /// Optional relation hints such as `"floor"`, `"wall"`, `"on:cabinet"`.
    pub relations: Vec<String>,
}

impl Room {
    /// The absolute (or working-directory-relative) folder of a capture named relative to the room.
    pub fn capture_dir(&self, capture: &Path) -> PathBuf {
        self.root.join(capture)
    }

    /// Where docs/formats.md puts the optional ground-truth mesh of `object`: `meshes/<name>.ply`.
    pub fn truth_mesh_path(&self, object: &RoomObject) -> PathBuf {
        self.root
            .join("meshes")
            .join(format!("{}.ply", object.name))
    }

    /// The object with instance id `id`.
    pub fn object_by_id(&self, id: u16) -> Option<&RoomObject> {
        self.objects.iter().find(|o| o.id == id)
    }

    /// The object called `name`.
    pub fn object_by_name(&self, name: &str) -> Option<&RoomObject> {
        self.objects.iter().find(|o| o.name == name)
    }

    /// Objects grouped by the capture they name, in order of first appearance: every group is one model
    /// to learn, and each object in it is an instance of that model.
    pub fn objects_by_capture(&self) -> Vec<(&Path, Vec<&RoomObject>)> {
        let mut groups: Vec<(&Path, Vec<&RoomObject>)> = Vec::new();
        for o in &self.objects {
            match groups.iter_mut().find(|(c, _)| *c == o.capture.as_path()) {
                Some((_, members)) => members.push(o),
                None => groups.push((o.capture.as_path(), vec![o])),
            }
        }
        groups
    }
}

/// Reads a room from its folder or from its `room.json`, validating every field: format tag, ids in
/// 1..=65535 and unique, names unique, sizes positive, poses rigid, capture paths relative.
pub fn read_room(path: impl AsRef<Path>) -> FormatResult<Room> {
    let path = path.as_ref();
    let file = if path.is_dir() {
        path.join("room.json")
    } else {
        path.to_path_buf()
    };
    let bytes =
        std::fs::read(&file).map_err(|e| FormatError::file(&file, format!("cannot read: {e}")))?;
    parse_room(&file, &bytes)
}

/// Parses the bytes of the room file `file` (its folder becomes [`Room::root`]), validating as
/// [`read_room`] does.
pub fn parse_room(file: &Path, bytes: &[u8]) -> FormatResult<Room> {
    let root = file.parent().map(Path::to_path_buf).unwrap_or_default();
    let value = parse_json(file, bytes)?;
    let top = JsonObject::root(file, &value)?;
    top.check_format(ROOM_FORMAT)?;
    let background = top.object("background")?;
    let background = BackgroundSpec {
        capture: relative_path(&background, "capture")?,
    };
    let objects = top
        .objects("objects")?
        .iter()
        .map(read_object)
        .collect::<FormatResult<Vec<_>>>()?;
    super::check_unique(file, objects.iter().map(|o| (o.id, o.name.as_str())))?;
    Ok(Room {
        root,
        name: top.required("name", as_nonempty_str)?.to_string(),
        background,
        objects,
        extra: top.unknown_fields(&["format", "name", "background", "objects"]),
    })
}

/// Reads one entry of `objects`.
fn read_object(o: &JsonObject) -> FormatResult<RoomObject> {
    Ok(RoomObject {
        id: o.required("id", as_integer_in(1, 65535))? as u16,
        name: o.required("name", as_nonempty_str)?.to_string(),
        category: o.required("category", as_nonempty_str)?.to_string(),
        capture: relative_path(o, "capture")?,
        size: o.required("size", as_positive_vec3)?,
        capture_to_object: o
            .optional("capture_to_object", as_pose)?
            .unwrap_or(Pose::IDENTITY),
        relations: o.optional("relations", as_strings)?.unwrap_or_default(),
    })
}

/// A required path field that must be relative to the room folder.
fn relative_path(o: &JsonObject, key: &str) -> FormatResult<PathBuf> {
    let p = PathBuf::from(o.required(key, as_nonempty_str)?);
    if p.is_absolute() {
        return Err(o.error(
            key,
            format!("must be relative to the room folder, found {}", p.display()),
        ));
    }
    Ok(p)
}

/// Writes `room` as `dir/room.json` (the room's own `root` is not consulted), atomically. Writing checks
/// what reading checks, so the file written always reads back.
pub fn write_room(dir: impl AsRef<Path>, room: &Room) -> FormatResult<()> {
    let file = dir.as_ref().join("room.json");
    super::check_unique(&file, room.objects.iter().map(|o| (o.id, o.name.as_str())))?;
    let objects = room
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| object_value(&file, i, o))
        .collect::<FormatResult<Vec<_>>>()?;
    nonempty(&file, "name", &room.name)?;
    let mut top = Map::new();
    top.insert("format".into(), ROOM_FORMAT.into());
    top.insert("name".into(), room.name.clone().into());
    top.insert(
        "background".into(),
        json!({ "capture": path_string(&file, "background.capture", &room.background.capture)? }),
    );
    top.insert("objects".into(), objects.into());
    for (k, v) in &room.extra {
        top.entry(k.clone()).or_insert_with(|| v.clone());
    }
    write_json(&file, &Value::Object(top))
}

/// One entry of `objects`, for writing.
fn object_value(file: &Path, i: usize, o: &RoomObject) -> FormatResult<Value> {
    let field = |name: &str| format!("objects[{i}].{name}");
    nonempty(file, &field("name"), &o.name)?;
    nonempty(file, &field("category"), &o.category)?;
    if o.id == 0 {
        return Err(FormatError::field(
            file,
            field("id"),
            "ids start at 1 (0 means no object)",
        ));
    }
    if !(o.size.min_element() > 0.0 && o.size.is_finite()) {
        return Err(FormatError::field(
            file,
            field("size"),
            format!("expected three positive numbers, found {}", o.size),
        ));
    }
    Ok(json!({
        "id": o.id,
        "name": o.name,
        "category": o.category,
        "capture": path_string(file, &field("capture"), &o.capture)?,
        "size": o.size.to_array(),
        "capture_to_object": pose_value(file, &field("capture_to_object"), &o.capture_to_object)?,
        "relations": o.relations,
    }))
}

/// A path as a string for JSON.
pub(crate) fn path_string(file: &Path, field: &str, p: &Path) -> FormatResult<String> {
    let s = p
        .to_str()
        .ok_or_else(|| FormatError::field(file, field, "path is not valid UTF-8"))?;
    if s.is_empty() {
        return Err(FormatError::field(file, field, "path is empty"));
    }
    Ok(s.to_string())
}

/// Fails naming `field` when a string that readers require to be non-empty is empty.
pub(crate) fn nonempty(file: &Path, field: &str, s: &str) -> FormatResult<()> {
    if s.is_empty() {
        Err(FormatError::field(file, field, "must not be empty"))
    } else {
        Ok(())
    }
}

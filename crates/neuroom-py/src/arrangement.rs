//! Arrangements (docs/formats.md): the camera and every placed object, read from and written to the
//! project's JSON, with each object's box size (from the room) and locate's score when known.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use neuroom::formats::{
    Arrangement, arrangement_value, parse_arrangement, read_arrangement, write_arrangement,
};
use numpy::PyArray2;
use pyo3::prelude::*;

use crate::arrays::pose_to_numpy;
use crate::error::to_py;
use crate::room::{BoxSizes, room_from_python};

/// The name errors give an arrangement that comes from no file.
const IN_MEMORY: &str = "<arrangement>";

/// A solved (or ground-truth) arrangement: the panorama's camera and the objects placed in the room.
#[pyclass(name = "Arrangement", module = "neuroom", frozen)]
pub struct ArrangementPy {
    /// The arrangement itself.
    pub arrangement: Arrangement,
    /// Box sizes by object id, when the room is known.
    pub sizes: BoxSizes,
}

impl ArrangementPy {
    /// `arrangement` with the box sizes of its room.
    pub fn new(arrangement: Arrangement, sizes: BoxSizes) -> Self {
        Self { arrangement, sizes }
    }

    /// Locate's score of each object by id, from the arrangement's `locate` record (first view).
    fn scores(&self) -> BTreeMap<u16, f64> {
        let found = self
            .arrangement
            .extra
            .get("locate")
            .and_then(|l| l.get(0))
            .and_then(|l| l.get("found"))
            .and_then(|f| f.as_array());
        found
            .into_iter()
            .flatten()
            .filter_map(|f| {
                let id = u16::try_from(f.get("id")?.as_u64()?).ok()?;
                Some((id, f.get("score")?.as_f64()?))
            })
            .collect()
    }
}

/// Box sizes of the room given (a `Room` or its folder), or none.
fn sizes_from(room: Option<&Bound<'_, PyAny>>) -> PyResult<BoxSizes> {
    room.map(|r| room_from_python(r).map(|room| BoxSizes::of(&room)))
        .transpose()
        .map(Option::unwrap_or_default)
}

#[pymethods]
impl ArrangementPy {
    /// Parses an arrangement from its JSON text; `room` (a `Room` or its folder) gives the objects'
    /// box sizes.
    #[staticmethod]
    #[pyo3(signature = (text, room=None))]
    fn from_json(text: &str, room: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let arrangement = parse_arrangement(Path::new(IN_MEMORY), text.as_bytes())
            .map_err(|e| to_py(e.into()))?;
        Ok(Self::new(arrangement, sizes_from(room)?))
    }

    /// Reads an arrangement file; `room` gives the objects' box sizes.
    #[staticmethod]
    #[pyo3(signature = (path, room=None))]
    fn read(path: PathBuf, room: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let arrangement = read_arrangement(&path).map_err(|e| to_py(e.into()))?;
        Ok(Self::new(arrangement, sizes_from(room)?))
    }

    /// The arrangement as the project's JSON text.
    fn to_json(&self) -> PyResult<String> {
        let value = arrangement_value(Path::new(IN_MEMORY), &self.arrangement)
            .map_err(|e| to_py(e.into()))?;
        serde_json::to_string_pretty(&value).map_err(|e| to_py(e.into()))
    }

    /// Writes the arrangement file (atomically).
    fn write(&self, path: PathBuf) -> PyResult<()> {
        write_arrangement(&path, &self.arrangement).map_err(|e| to_py(e.into()))
    }

    /// The panorama's file name.
    #[getter]
    fn image(&self) -> String {
        self.arrangement.image.clone()
    }

    /// The panorama camera's pose, 4×4 (docs/formats.md: +x the centre column, +y left, +z up).
    #[getter]
    fn camera_to_world<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_to_numpy(py, &self.arrangement.camera_to_world)
    }

    /// The placed objects.
    #[getter]
    fn objects(&self) -> Vec<PlacedObjectPy> {
        let scores = self.scores();
        self.arrangement
            .objects
            .iter()
            .map(|o| PlacedObjectPy {
                id: o.id,
                name: o.name.clone(),
                pose: o.object_to_world,
                size: self.sizes.get(o.id),
                score: scores.get(&o.id).copied(),
            })
            .collect()
    }

    /// How sure locate is of the camera, in [0, 1]; `None` when not located.
    #[getter]
    fn camera_confidence(&self) -> Option<f64> {
        self.arrangement
            .extra
            .get("camera_confidence")
            .and_then(|c| c.as_f64())
    }

    /// Locate's warnings (a camera whose evidence is weak), empty when none.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        let listed = self.arrangement.extra.get("warnings");
        listed
            .and_then(|w| w.as_array())
            .into_iter()
            .flatten()
            .filter_map(|w| w.as_str().map(str::to_string))
            .collect()
    }

    fn __len__(&self) -> usize {
        self.arrangement.objects.len()
    }

    fn __repr__(&self) -> String {
        let names: Vec<&str> = self
            .arrangement
            .objects
            .iter()
            .map(|o| o.name.as_str())
            .collect();
        format!(
            "Arrangement(image={:?}, objects={names:?})",
            self.arrangement.image
        )
    }
}

/// One placed object: its id and name in room.json, its pose, box size and locate's score.
#[pyclass(name = "PlacedObject", module = "neuroom", frozen)]
pub struct PlacedObjectPy {
    id: u16,
    name: String,
    pose: neuroom::Pose,
    size: Option<[f64; 3]>,
    score: Option<f64>,
}

#[pymethods]
impl PlacedObjectPy {
    /// The instance id (room.json).
    #[getter]
    fn id(&self) -> u16 {
        self.id
    }

    /// The object's name (room.json).
    #[getter]
    fn name(&self) -> String {
        self.name.clone()
    }

    /// Object to world, 4×4.
    #[getter]
    fn pose<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_to_numpy(py, &self.pose)
    }

    /// Full extents of its box in its own frame (metres), when the room is known.
    #[getter]
    fn size(&self) -> Option<(f64, f64, f64)> {
        self.size.map(|[x, y, z]| (x, y, z))
    }

    /// Locate's score of the object, when the arrangement records one.
    #[getter]
    fn score(&self) -> Option<f64> {
        self.score
    }

    fn __repr__(&self) -> String {
        let t = self.pose.translation;
        format!(
            "PlacedObject(id={}, name={:?}, at=({:.3}, {:.3}, {:.3}))",
            self.id, self.name, t.x, t.y, t.z
        )
    }
}

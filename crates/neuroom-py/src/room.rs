//! A room folder (room.json and its captures and test panoramas).

use std::collections::BTreeMap;
use std::path::PathBuf;

use neuroom::{Room, read_room};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

use crate::arrangement::ArrangementPy;
use crate::error::to_py;

/// A room: its folder, name, objects and test panoramas.
#[pyclass(name = "Room", module = "neuroom", frozen)]
pub struct RoomPy {
    /// room.json as read.
    pub room: Room,
}

/// Object box sizes by instance id.
#[derive(Clone, Debug, Default)]
pub struct BoxSizes(BTreeMap<u16, [f64; 3]>);

impl BoxSizes {
    /// The sizes of every object of `room`.
    pub fn of(room: &Room) -> Self {
        Self(
            room.objects
                .iter()
                .map(|o| (o.id, o.size.to_array()))
                .collect(),
        )
    }

    /// The size of object `id`.
    pub fn get(&self, id: u16) -> Option<[f64; 3]> {
        self.0.get(&id).copied()
    }
}

/// Reads the room a Python value names: a `Room`, or the path of its folder.
pub fn room_from_python(value: &Bound<'_, PyAny>) -> PyResult<Room> {
    if let Ok(room) = value.cast::<RoomPy>() {
        return Ok(room.get().room.clone());
    }
    let path: PathBuf = value
        .extract()
        .map_err(|_| PyTypeError::new_err("room: expected a neuroom.Room or a folder path"))?;
    read_room(&path).map_err(|e| to_py(e.into()))
}

#[pymethods]
impl RoomPy {
    /// Reads the room in `path` (the folder holding room.json).
    #[new]
    fn new(path: PathBuf) -> PyResult<Self> {
        Ok(Self {
            room: read_room(&path).map_err(|e| to_py(e.into()))?,
        })
    }

    /// The room folder.
    #[getter]
    fn path(&self) -> PathBuf {
        self.room.root.clone()
    }

    /// The room's name.
    #[getter]
    fn name(&self) -> String {
        self.room.name.clone()
    }

    /// The movable objects: `{"id", "name", "category", "size"}` each.
    #[getter]
    fn objects<'py>(&self, py: Python<'py>) -> PyResult<Vec<Bound<'py, pyo3::types::PyDict>>> {
        self.room
            .objects
            .iter()
            .map(|o| {
                let d = pyo3::types::PyDict::new(py);
                d.set_item("id", o.id)?;
                d.set_item("name", &o.name)?;
                d.set_item("category", &o.category)?;
                d.set_item("size", (o.size.x, o.size.y, o.size.z))?;
                Ok(d)
            })
            .collect()
    }

    /// The names of the models the room needs, `background` first: what `Models.train(only=…)` takes.
    #[getter]
    fn model_names(&self) -> Vec<String> {
        neuroom::train::model_names(&self.room)
    }

    /// The test panoramas with their ground truth: `(panorama path, Arrangement)` pairs.
    fn test_panoramas(&self) -> PyResult<Vec<(PathBuf, ArrangementPy)>> {
        let sizes = BoxSizes::of(&self.room);
        let listed = neuroom::locate::test_panoramas(&self.room.root).map_err(to_py)?;
        Ok(listed
            .into_iter()
            .map(|(path, truth)| (path, ArrangementPy::new(truth, sizes.clone())))
            .collect())
    }

    fn __repr__(&self) -> String {
        format!(
            "Room(name={:?}, path={:?}, objects={})",
            self.room.name,
            self.room.root,
            self.room.objects.len()
        )
    }
}

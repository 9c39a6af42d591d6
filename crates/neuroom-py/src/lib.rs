//! neuroom from Python: the extension module `neuroom._neuroom` behind the `neuroom` package
//! (`python/`), built with maturin. It calls the face crate `neuroom` only: a room (`Room`), its
//! trained models (`Models`: train, open, locate, fit, render, edit), arrangements, pinhole cameras,
//! rendered images as numpy arrays, and the paper's metrics (`evaluate`). Long calls run on a worker
//! thread with the interpreter released, report progress through a callback and stop on Ctrl-C
//! (`worker`); errors arrive as `neuroom.NeuroomError` naming the file and the problem.

use pyo3::prelude::*;

mod arrangement;
mod arrays;
mod camera;
mod error;
mod evaluate;
mod models;
mod room;
mod worker;

/// The extension module.
#[pymodule]
fn _neuroom(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("NeuroomError", m.py().get_type::<error::NeuroomError>())?;
    m.add_class::<room::RoomPy>()?;
    m.add_class::<models::ModelsPy>()?;
    m.add_class::<arrangement::ArrangementPy>()?;
    m.add_class::<arrangement::PlacedObjectPy>()?;
    m.add_class::<camera::PinholePy>()?;
    m.add_class::<camera::RenderedImagePy>()?;
    m.add_function(wrap_pyfunction!(evaluate::evaluate, m)?)?;
    m.add_function(wrap_pyfunction!(arrays::read_image, m)?)?;
    Ok(())
}

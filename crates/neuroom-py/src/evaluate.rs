//! The paper's metrics of solved arrangements against a room's ground truth.

use std::path::PathBuf;

use neuroom::eval::{EvalOptions, evaluate as evaluate_room};
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;

use crate::arrangement::ArrangementPy;
use crate::error::to_py;
use crate::models::ModelsPy;
use crate::room::room_from_python;
use crate::worker::{LongCall, OnInterrupt};

/// Scores solved `arrangements` (each an `Arrangement` or a file) of the test panoramas of `room`
/// (a `Room` or its folder) against their ground truth: 3D IoU, rotation and position errors,
/// identification precision and recall, the camera's error and, with `models` (a `Models` or its
/// folder), PSNR / SSIM / LPIPS of the re-rendered panorama `render_width` pixels wide. Returns
/// `{"rows": [...], "mean": {...}, "lpips_unavailable": ...}` as `neuroom eval --json` prints it.
/// `progress`: a callable `("evaluate", arrangements done, arrangements)` or a `tqdm` bar.
#[pyfunction]
#[pyo3(signature = (room, arrangements, models=None, render_width=512, progress=None))]
pub fn evaluate(
    py: Python<'_>,
    room: &Bound<'_, PyAny>,
    arrangements: Vec<Bound<'_, PyAny>>,
    models: Option<&Bound<'_, PyAny>>,
    render_width: u32,
    progress: Option<Py<PyAny>>,
) -> PyResult<Py<PyAny>> {
    let room = room_from_python(room)?.root;
    let models = match models {
        None => None,
        Some(m) => Some(match m.cast::<ModelsPy>() {
            Ok(models) => models.get().folder().to_path_buf(),
            Err(_) => m.extract::<PathBuf>().map_err(|_| {
                PyTypeError::new_err("models: expected a neuroom.Models or a folder path")
            })?,
        }),
    };
    let scratch = tempfile::tempdir().map_err(|e| to_py(e.into()))?;
    let mut paths = Vec::with_capacity(arrangements.len());
    for (i, item) in arrangements.iter().enumerate() {
        if let Ok(a) = item.cast::<ArrangementPy>() {
            let path = scratch.path().join(format!("arrangement-{i}.json"));
            neuroom::formats::write_arrangement(&path, &a.get().arrangement)
                .map_err(|e| to_py(e.into()))?;
            paths.push(path);
        } else {
            paths.push(item.extract::<PathBuf>().map_err(|_| {
                PyTypeError::new_err(format!(
                    "arrangements[{i}]: expected a neuroom.Arrangement or a file path"
                ))
            })?);
        }
    }
    let options = EvalOptions {
        models,
        render_width,
    };
    let (call, progress) = LongCall::new(py, progress, "evaluate", OnInterrupt::Abandon)?;
    let text = call.run(py, move || {
        let total = paths.len() as u64;
        let mut done = 0;
        let mut each = |_: &std::path::Path| {
            progress.report(done, total);
            done += 1;
        };
        let evaluation = evaluate_room(&room, &paths, &options, &mut each)?;
        progress.report(total, total);
        drop(scratch);
        Ok(serde_json::to_string(&evaluation)?)
    })?;
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

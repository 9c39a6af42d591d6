//! A room's trained models and what they do: train, open, locate, fit, render, edit.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use neuroom::Room;
use neuroom::edit::{Edit, EditFile, edit_in_memory};
use neuroom::fit::{FitConfig, ImageFit, fit_image, relation_hints};
use neuroom::formats::Arrangement;
use neuroom::image::RgbImage;
use neuroom::locate::{
    LocateConfig, LocateContext, LocateStage, LocateStep, QueryImage, locate_image, record_located,
};
use neuroom::train::{Manifest, TrainOptions, read_manifest, train_room};
use neuroom::view::{RenderedShare, placed_scene, render_camera};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use crate::arrangement::ArrangementPy;
use crate::arrays::rgb_from_numpy;
use crate::camera::{PinholePy, RenderedImagePy, resolve_camera};
use crate::error::{NeuroomError, to_py};
use crate::room::{BoxSizes, RoomPy, room_from_python};
use crate::worker::{LongCall, OnInterrupt};

/// Locate's context of a model folder, loaded by the first call that needs it and kept.
type SharedContext = Arc<Mutex<Option<Arc<LocateContext>>>>;

/// A room's trained models (a model folder `<out>/<room name>` with its `manifest.json`).
#[pyclass(name = "Models", module = "neuroom", frozen)]
pub struct ModelsPy {
    folder: PathBuf,
    room: Room,
    manifest: Manifest,
    context: SharedContext,
}

impl ModelsPy {
    fn open_with(folder: PathBuf, room: Room) -> PyResult<Self> {
        let manifest = read_manifest(&folder).map_err(|e| to_py(e.into()))?;
        Ok(Self {
            folder,
            room,
            manifest,
            context: Arc::default(),
        })
    }

    /// The model folder.
    pub fn folder(&self) -> &Path {
        &self.folder
    }

    fn sizes(&self) -> BoxSizes {
        BoxSizes::of(&self.room)
    }

    /// What a worker needs to load (or reuse) locate's context.
    fn context_source(&self) -> ContextSource {
        ContextSource {
            room: self.room.root.clone(),
            folder: self.folder.clone(),
            shared: self.context.clone(),
        }
    }
}

/// Where locate's context comes from, moved into a worker.
struct ContextSource {
    room: PathBuf,
    folder: PathBuf,
    shared: SharedContext,
}

impl ContextSource {
    /// The context, loaded once per `Models`.
    fn get(&self) -> anyhow::Result<Arc<LocateContext>> {
        let mut slot = self.shared.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(ctx) = slot.as_ref() {
            return Ok(ctx.clone());
        }
        let ctx = Arc::new(LocateContext::load(
            &self.room,
            &self.folder,
            &LocateConfig::default(),
        )?);
        *slot = Some(ctx.clone());
        Ok(ctx)
    }
}

/// The query a Python value names: a panorama file, or an `H×W×3` array; with the name the
/// arrangement gives its image.
fn query_from_python(
    image: &Bound<'_, PyAny>,
    name: Option<String>,
) -> PyResult<(QueryImage, String)> {
    if let Ok(path) = image.extract::<PathBuf>() {
        let query = neuroom::locate::read_query(&path, None).map_err(to_py)?;
        let file = path.file_name().map(|n| n.to_string_lossy().into_owned());
        return Ok((query, name.or(file).unwrap_or_default()));
    }
    let rgb = panorama_from_numpy(image)?;
    Ok((
        QueryImage::Panorama(rgb),
        name.unwrap_or_else(|| "panorama".into()),
    ))
}

/// A panorama from a numpy array, twice as wide as high.
fn panorama_from_numpy(image: &Bound<'_, PyAny>) -> PyResult<RgbImage> {
    let rgb = rgb_from_numpy(image)?;
    if rgb.width != 2 * rgb.height {
        return Err(PyValueError::new_err(format!(
            "image: a panorama is twice as wide as it is high, found {}×{}",
            rgb.width, rgb.height
        )));
    }
    Ok(rgb)
}

/// The panorama a Python value names (a file or an array), with its name.
fn panorama_from_python(
    image: &Bound<'_, PyAny>,
    name: Option<String>,
) -> PyResult<(RgbImage, String)> {
    match query_from_python(image, name)? {
        (QueryImage::Panorama(rgb), name) => Ok((rgb, name)),
        (QueryImage::Photo { .. }, _) => Err(PyValueError::new_err("image: expected a panorama")),
    }
}

#[pymethods]
impl ModelsPy {
    /// Trains (or resumes) the models of `room` into `out/<room name>` and returns them. `steps`:
    /// optimisation steps per model (`background_steps` for the room's own, default `steps`);
    /// `only`: the names of the models to train (the others may train elsewhere, in any order;
    /// the manifest is complete once all are there); `progress`: a callable `(model, step,
    /// total)` or a `tqdm` bar. Ctrl-C stops it with the checkpoint saved: the next call resumes.
    #[staticmethod]
    #[pyo3(signature = (room, out, steps=None, background_steps=None, progress=None, only=None, threads=0, seed=None))]
    #[allow(clippy::too_many_arguments)]
    fn train(
        py: Python<'_>,
        room: &Bound<'_, PyAny>,
        out: PathBuf,
        steps: Option<u64>,
        background_steps: Option<u64>,
        progress: Option<Py<PyAny>>,
        only: Option<Vec<String>>,
        threads: usize,
        seed: Option<u64>,
    ) -> PyResult<Self> {
        let room = room_from_python(room)?;
        let options = TrainOptions {
            object_steps: steps,
            background_steps: background_steps.or(steps),
            threads,
            seed,
            only: only.unwrap_or_default(),
            ..TrainOptions::default()
        };
        let (call, progress) = LongCall::new(py, progress, "", OnInterrupt::WaitForStop)?;
        let root = room.root.clone();
        let summary = call.run(py, move || {
            train_room(&root, &out, &options, progress.as_ref())
        })?;
        Self::open_with(summary.dir, room)
    }

    /// Opens a model folder (`<out>/<room name>`). `room` (a `Room` or its folder) defaults to the
    /// folder the models were trained from, as their manifest records it.
    #[staticmethod]
    #[pyo3(signature = (path, room=None))]
    fn open(path: PathBuf, room: Option<&Bound<'_, PyAny>>) -> PyResult<Self> {
        let room = match room {
            Some(r) => room_from_python(r)?,
            None => {
                let manifest = read_manifest(&path).map_err(|e| to_py(e.into()))?;
                let folder = manifest.room_folder.ok_or_else(|| {
                    NeuroomError::new_err(format!(
                        "{}: records no room folder (trained before it was recorded); pass room=",
                        path.join("manifest.json").display()
                    ))
                })?;
                neuroom::read_room(&folder).map_err(|e| to_py(e.into()))?
            }
        };
        Self::open_with(path, room)
    }

    /// The model folder.
    #[getter]
    fn path(&self) -> PathBuf {
        self.folder.clone()
    }

    /// The room the models are of.
    #[getter]
    fn room(&self) -> RoomPy {
        RoomPy {
            room: self.room.clone(),
        }
    }

    /// The names of the trained models (`background` first).
    #[getter]
    fn names(&self) -> Vec<String> {
        self.manifest
            .models
            .iter()
            .map(|m| m.name.clone())
            .collect()
    }

    /// Whether every model of the room is trained.
    #[getter]
    fn complete(&self) -> bool {
        self.manifest.complete
    }

    /// Finds the camera and the objects with their initial poses in a panorama (a file path, or
    /// an `H×W×3` uint8 / float32 array); `name` is the image name the arrangement records. The
    /// same as `neuroom locate --no-fit`. `progress`: a callable `(stage, done, total)` told each
    /// stage as it starts (`"camera"`, `"placing objects"`, …; `"located"` at the end), or a
    /// `tqdm` bar.
    #[pyo3(signature = (image, name=None, progress=None))]
    fn locate(
        &self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        name: Option<String>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<ArrangementPy> {
        let (query, name) = query_from_python(image, name)?;
        let source = self.context_source();
        let (call, progress) = LongCall::new(py, progress, "locate", OnInterrupt::Abandon)?;
        let arrangement = call.run(py, move || {
            let stages = LocateStage::PLANNED.len() as u64;
            progress.tell("loading models", 0, stages);
            let ctx = source.get()?;
            let mut report = |step: LocateStep| {
                let stage = step.stage.map_or("located", LocateStage::name);
                progress.tell(stage, step.done as u64, step.total as u64);
            };
            let (mut arrangement, located, _) =
                locate_image(&ctx, &query, &name, &LocateConfig::default(), &mut report)?;
            record_located(&mut arrangement, &[located])?;
            Ok(arrangement)
        })?;
        Ok(ArrangementPy::new(arrangement, self.sizes()))
    }

    /// The holistic fit: solves poses, light codes and tone adjusters that explain the panorama
    /// `image` from the `initial` arrangement (from `locate`), then keeps each object's initial
    /// pose where it explains the panorama better, as `neuroom locate` does. `progress`: a
    /// callable `("fit", iteration, total)` or a `tqdm` bar.
    #[pyo3(signature = (image, initial, pose_iterations=None, appearance_iterations=None, progress=None))]
    fn fit(
        &self,
        py: Python<'_>,
        image: &Bound<'_, PyAny>,
        initial: &ArrangementPy,
        pose_iterations: Option<usize>,
        appearance_iterations: Option<usize>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<ArrangementPy> {
        let (rgb, name) = panorama_from_python(image, Some(initial.arrangement.image.clone()))?;
        let mut config = FitConfig::refinement();
        config.pose_iterations = pose_iterations.unwrap_or(config.pose_iterations);
        config.appearance_iterations =
            appearance_iterations.unwrap_or(config.appearance_iterations);
        let total = (config.pose_iterations + config.appearance_iterations) as u64;
        let (call, progress) = LongCall::new(py, progress, "fit", OnInterrupt::Abandon)?;
        let (source, start) = (self.context_source(), initial.arrangement.clone());
        let solved = call.run(py, move || {
            let ctx = source.get()?;
            let hints = relation_hints(&ctx.room);
            let input = ImageFit {
                models: &source.folder,
                image: &rgb,
                name: &name,
                start: &start,
                hints: &hints,
                object_light: None,
                check: Some(&ctx),
            };
            let report = |log: &neuroom::fit::IterationLog| {
                progress.report(log.iteration as u64 + 1, total);
            };
            Ok(fit_image(&input, &config, &mut { report })?.arrangement)
        })?;
        Ok(ArrangementPy::new(solved, self.sizes()))
    }

    /// Renders the room as `arrangement` places it, under its solved light: from `camera` (a
    /// `Pinhole`), or as a panorama `width` pixels wide from the arrangement's camera.
    /// `progress`: a callable `("render", pixels done, pixels)` or a `tqdm` bar.
    #[pyo3(signature = (arrangement, camera=None, width=512, progress=None))]
    fn render(
        &self,
        py: Python<'_>,
        arrangement: &ArrangementPy,
        camera: Option<PyRef<'_, PinholePy>>,
        width: u32,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<RenderedImagePy> {
        let (camera, pose) = resolve_camera(
            camera.as_deref(),
            width,
            &arrangement.arrangement.camera_to_world,
        )?;
        let folder = self.folder.clone();
        let placed = arrangement.arrangement.clone();
        let (call, progress) = LongCall::new(py, progress, "render", OnInterrupt::Abandon)?;
        let view = call.run(py, move || {
            let scene = placed_scene(&folder, placed, Path::new("<arrangement>"), None)?;
            let report =
                |share: RenderedShare| progress.report(share.done as u64, share.total as u64);
            Ok(render_camera(&scene, &camera, &pose, &report))
        })?;
        Ok(RenderedImagePy { view })
    }

    /// Applies `edits` (the edit file's list: `{"op": "move", "object": 1, "to": [x, y]}`,
    /// `rotate`, `remove`, `insert`; docs/formats.md) to `arrangement`, settling the touched objects
    /// onto what stands below them unless `settle` is false; returns the edited arrangement.
    #[pyo3(signature = (arrangement, edits, settle=true))]
    fn edit(
        &self,
        py: Python<'_>,
        arrangement: &ArrangementPy,
        edits: &Bound<'_, PyAny>,
        settle: bool,
    ) -> PyResult<ArrangementPy> {
        let text: String = py
            .import("json")?
            .call_method1("dumps", (edits,))?
            .extract()?;
        let edits: Vec<Edit> = serde_json::from_str(&text)
            .map_err(|e| PyValueError::new_err(format!("edits: {e}")))?;
        let file = EditFile { edits, settle };
        let folder = self.folder.clone();
        let start = arrangement.arrangement.clone();
        let (call, _) = LongCall::new(py, None, "edit", OnInterrupt::Abandon)?;
        let edited: Arrangement = call.run(py, move || {
            Ok(edit_in_memory(&folder, &start, &file, Path::new("."))?.0)
        })?;
        Ok(ArrangementPy::new(edited, self.sizes()))
    }

    fn __repr__(&self) -> String {
        format!(
            "Models(path={:?}, room={:?}, models={:?})",
            self.folder,
            self.room.name,
            self.names()
        )
    }
}

//! Training a whole room, and the model directory it writes:
//! ```text
//! <models>/<room>/manifest.json                     which ids use which model, room box, codes, stats
//! <models>/<room>/background/{config.json, weights.safetensors}
//! <models>/<room>/objects/<capture name>/{config.json, weights.safetensors}
//! <models>/<room>/<model>/checkpoint/               resumable state while that model trains
//! ```
//! A model is finished when its `config.json` exists (it is written last, atomically). `train_room` skips
//! finished models, resumes the one with a checkpoint, and rewrites the manifest after every model; a
//! finished model or checkpoint made with another budget (table, resolution, steps) is refused, not
//! reused. Objects that name the same capture are instances of one model, trained once. Each model is
//! an independent job: `train_room` told to train only some models (`only`) lists every model finished
//! so far, whichever process finished it, so several processes can train one room's models side by
//! side; the manifest is complete once every model is there.

use crate::augment::Augmentation;
use crate::config::TrainConfig;
use crate::dataset::{Aabb, Dataset, LoadOptions, Role};
use crate::eval::{EvalReport, evaluate, extract_mesh};
use crate::frame_corrections::{CorrectionSummary, FrameCorrections};
use crate::lanes::{lane_threads, run_in_lanes};
use crate::losses::LossParts;
use crate::progress::Progress;
use crate::reuse::check_saved_budget;
use crate::trainer::{LightCodes, ModelKind, Trainer, field_config};
use neuroom_core::formats::{
    REFINED_POSES_FILE, RefinedPoses, Room, atomic_write, read_capture, read_refined_poses,
    read_room, write_refined_poses,
};
use neuroom_core::mesh::read_ply;
use neuroom_core::surface::{Chamfer, chamfer};
use neuroom_core::{FormatError, Pose};
use neuroom_field::NeusField;
use neuroom_field::checkpoint::{self, CheckpointError};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::time::Instant;

/// Format tag of `manifest.json`.
pub const MANIFEST_FORMAT: &str = "neuroom.models/1";

/// What can go wrong training or loading a room's models.
#[derive(Debug, thiserror::Error)]
pub enum TrainError {
    /// Bad input files (room, capture, images, environment maps).
    #[error(transparent)]
    Format(#[from] FormatError),
    /// A checkpoint or model that cannot be read or written.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// The optimisation kept producing non-finite or exploding losses, even with smaller steps.
    #[error(
        "{model}: training diverged at step {step} ({faults} faulty steps in a row, learning rate scaled \
         down to {lr_scale:e}); the last checkpoint is kept"
    )]
    Diverged {
        /// The model.
        model: String,
        /// The step it gave up at.
        step: u64,
        /// Faulty steps in a row.
        faults: u64,
        /// The learning-rate scale reached.
        lr_scale: f32,
    },
    /// The run was asked to stop ([`Progress::interrupted`]); the model's checkpoint is saved, and the
    /// next run resumes from it.
    #[error(
        "{model}: interrupted at step {step}; its checkpoint is saved and training resumes from it"
    )]
    Interrupted {
        /// The model.
        model: String,
        /// The step it stopped after.
        step: u64,
    },
    /// Names asked to be trained that are no model of the room.
    #[error("{room}: no model named {unknown:?} (the room's models: {known:?})")]
    UnknownModels {
        /// The room's `room.json`.
        room: PathBuf,
        /// The names asked for that no model has.
        unknown: Vec<String>,
        /// The names of the room's models.
        known: Vec<String>,
    },
    /// A problem with a file that is not one of the above, e.g. the manifest.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// One model of a room: what it learns from and where it lives.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelSpec {
    /// `background` or the capture folder's name.
    pub name: String,
    /// Object or background.
    pub kind: ModelKind,
    /// The capture folder.
    pub capture: PathBuf,
    /// Pixel classes and frame.
    pub role: Role,
    /// The model's box (object box, or the room box when `room.json` gives one).
    pub bounds: Option<Aabb>,
    /// Names of the objects using the model.
    pub objects: Vec<String>,
    /// Folder of the model relative to the room's model folder.
    pub path: String,
    /// Ground-truth mesh of the object (`meshes/<first object>.ply`, object frame), when the room has it.
    pub truth_mesh: Option<PathBuf>,
}

/// The models a room needs: the background first, then one per distinct object capture.
pub fn model_specs(room: &Room) -> Vec<ModelSpec> {
    let mut specs = vec![ModelSpec {
        name: "background".into(),
        kind: ModelKind::Background,
        capture: room.capture_dir(&room.background.capture),
        role: Role::Background,
        bounds: room_box(room),
        objects: Vec::new(),
        path: "background".into(),
        truth_mesh: None,
    }];
    for (capture, members) in room.objects_by_capture() {
        let first = members[0];
        let name = capture
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| first.name.clone());
        let half = first.size.as_vec3() * 0.5;
        specs.push(ModelSpec {
            path: format!("objects/{name}"),
            name,
            kind: ModelKind::Object,
            capture: room.capture_dir(capture),
            role: Role::Object {
                ids: members.iter().map(|o| o.id).collect(),
                capture_to_object: first.capture_to_object,
            },
            bounds: Some(Aabb {
                min: (-half).to_array(),
                max: half.to_array(),
            }),
            objects: members.iter().map(|o| o.name.clone()).collect(),
            truth_mesh: Some(room.truth_mesh_path(first)).filter(|p| p.is_file()),
        });
    }
    specs
}

/// The room box of `room.json`'s extra field `room_box` (`{min, max}`), when present and well formed.
fn room_box(room: &Room) -> Option<Aabb> {
    let b = room.extra.get("room_box")?;
    let corner = |k: &str| -> Option<[f32; 3]> {
        let v = b.get(k)?.as_array()?;
        (v.len() == 3).then(|| std::array::from_fn(|a| v[a].as_f64().unwrap_or(f64::NAN) as f32))
    };
    let (min, max) = (corner("min")?, corner("max")?);
    (0..3).all(|a| min[a] < max[a]).then_some(Aabb { min, max })
}

/// Figures of a trained model, stored in the manifest.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelStats {
    /// Optimisation steps.
    pub steps: u64,
    /// Seconds spent in steps.
    pub train_seconds: f64,
    /// Seconds reading the capture.
    pub load_seconds: f64,
    /// Training rays.
    pub rays: usize,
    /// Loss of the last step.
    pub final_loss: LossParts,
    /// Learned NeuS sharpness.
    pub inv_s: f32,
    /// Held-out figures, when evaluated.
    pub eval: Option<EvalReport>,
    /// Chamfer distance (metres) of the extracted mesh to the ground-truth mesh, when the room has one.
    #[serde(default)]
    pub chamfer_m: Option<Chamfer>,
    /// Steps skipped because their loss or gradient was not finite or exploded.
    #[serde(default)]
    pub faulty_steps: u64,
    /// How far the per-frame colour gains and pose corrections went (captures from a phone).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frame_corrections: Option<CorrectionSummary>,
}

/// One model in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModelEntry {
    /// `background` or the capture name.
    pub name: String,
    /// Folder relative to the manifest.
    pub path: String,
    /// Object or background.
    pub kind: ModelKind,
    /// Instance ids drawn by this model.
    pub ids: Vec<u16>,
    /// Object names drawn by this model.
    pub objects: Vec<String>,
    /// The field's box in the model frame (the object's box plus a training margin).
    pub bounds: Aabb,
    /// An object model's own box (room.json `size`, centred at the origin), without the training margin:
    /// surfaces the field holds outside it are floaters of training, not the object. Absent for the
    /// background and in manifests written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub object_box: Option<Aabb>,
    /// Light codes (capture lightings, then augmentation maps).
    pub light_codes: LightCodes,
    /// Number of appearance codes.
    pub appearance_codes: usize,
    /// Training figures.
    pub stats: ModelStats,
}

/// `manifest.json` of a room's model folder.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Manifest {
    /// `neuroom.models/1`.
    pub format: String,
    /// Room name.
    pub room: String,
    /// The background model's box (world frame).
    pub room_box: Option<Aabb>,
    /// Finished models, background first.
    pub models: Vec<ModelEntry>,
    /// Whether every model of the room is finished.
    pub complete: bool,
    /// The room folder the models were trained from (absolute), so that a model folder opened alone
    /// finds its `room.json`; absent in folders written before it was recorded.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub room_folder: Option<PathBuf>,
}

impl ModelEntry {
    /// Half extents of the box the model's object occupies: its own box when recorded, else the field's.
    pub fn half_extents(&self) -> [f32; 3] {
        self.object_box
            .as_ref()
            .unwrap_or(&self.bounds)
            .centred_half_extents()
    }
}

impl Manifest {
    /// The model drawing instance `id`.
    pub fn model_for(&self, id: u16) -> Option<&ModelEntry> {
        self.models.iter().find(|m| m.ids.contains(&id))
    }
}

/// What [`train_room`] did.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainSummary {
    /// The room's model folder.
    pub dir: PathBuf,
    /// The manifest written.
    pub manifest: Manifest,
    /// Models trained (or resumed) in this call; the others were already finished.
    pub trained: Vec<String>,
    /// Wall-clock seconds of the call.
    pub seconds: f64,
}

/// Trains the background and every distinct object model of the room at `room_dir`, into
/// `models_out/<room name>/`; resumable (see the module documentation). With `only` non-empty, trains
/// just the models of those names and lists every model finished so far in the manifest.
pub fn train_room(
    room_dir: &Path,
    models_out: &Path,
    config: &TrainConfig,
    only: &[String],
    progress: &dyn Progress,
) -> Result<TrainSummary, TrainError> {
    let start = Instant::now();
    let room = read_room(room_dir)?;
    let specs = model_specs(&room);
    check_names(room_dir, &specs, only)?;
    let dir = models_out.join(&room.name);
    let augmentation = Augmentation::load(&config.env_maps)?;
    let mut todo = Vec::new();
    for spec in specs
        .iter()
        .filter(|s| only.is_empty() || only.contains(&s.name))
    {
        check_saved_budget(&dir.join(&spec.path), config.budget(spec.kind))?;
        if read_entry(&dir, spec)?.is_none() {
            todo.push(spec);
        }
    }
    let threads = match config.threads {
        0 => rayon::current_num_threads(),
        n => n,
    };
    let lanes = lane_threads(threads, todo.len(), config.lanes());
    let manifest_lock = Mutex::new(());
    let train_one = |spec: &&ModelSpec| -> Result<(), TrainError> {
        train_model(spec, &dir.join(&spec.path), config, &augmentation, progress)?;
        let _written = manifest_lock.lock().unwrap_or_else(|e| e.into_inner());
        write_manifest(&dir, &finished_manifest(&room, &dir, &specs)?)
    };
    run_in_lanes(&todo, &lanes, train_one)?;
    let manifest = finished_manifest(&room, &dir, &specs)?;
    write_manifest(&dir, &manifest)?;
    Ok(TrainSummary {
        dir,
        manifest,
        trained: todo.iter().map(|s| s.name.clone()).collect(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

/// An error naming the models of `only` the room does not have.
fn check_names(room_dir: &Path, specs: &[ModelSpec], only: &[String]) -> Result<(), TrainError> {
    let known: Vec<String> = specs.iter().map(|s| s.name.clone()).collect();
    let unknown: Vec<String> = only
        .iter()
        .filter(|n| !known.contains(n))
        .cloned()
        .collect();
    if unknown.is_empty() {
        return Ok(());
    }
    Err(TrainError::UnknownModels {
        room: room_dir.join("room.json"),
        unknown,
        known,
    })
}

/// The manifest of the models of `specs` finished in `dir` so far (read back from their saved
/// configs, so models another process finished are listed too), complete when every one is.
fn finished_manifest(room: &Room, dir: &Path, specs: &[ModelSpec]) -> Result<Manifest, TrainError> {
    let mut manifest = Manifest {
        format: MANIFEST_FORMAT.into(),
        room: room.name.clone(),
        room_box: None,
        models: Vec::new(),
        complete: true,
        room_folder: std::path::absolute(&room.root).ok(),
    };
    for spec in specs {
        match read_entry(dir, spec)? {
            Some(entry) => {
                if spec.kind == ModelKind::Background {
                    manifest.room_box = Some(entry.bounds);
                }
                manifest.models.push(entry);
            }
            None => manifest.complete = false,
        }
    }
    Ok(manifest)
}

/// Runs `f` on a pool of `threads` workers (0 = the global pool).
pub fn with_threads<R: Send>(threads: usize, f: impl FnOnce() -> R + Send) -> R {
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(pool) if threads > 0 => pool.install(f),
        _ => f(),
    }
}

/// The manifest entry of a finished model (from its saved config), or `None` when it is not finished.
fn read_entry(room_dir: &Path, spec: &ModelSpec) -> Result<Option<ModelEntry>, TrainError> {
    let dir = room_dir.join(&spec.path);
    if !dir.join("config.json").exists() {
        return Ok(None);
    }
    let meta = checkpoint::read_meta(&dir)?;
    let entry =
        serde_json::from_value(meta.trainer["entry"].clone()).map_err(|e| TrainError::File {
            path: dir.join("config.json"),
            message: format!("trainer.entry: {e}"),
        })?;
    Ok(Some(entry))
}

/// Reads the capture of `spec` into a dataset; returns it with the model's box (the room box falls back to
/// the observed bounds) and the seconds it took.
pub fn load_model_data(
    spec: &ModelSpec,
    config: &TrainConfig,
) -> Result<(Dataset, Aabb, f64), TrainError> {
    let t0 = Instant::now();
    let capture = read_capture(&spec.capture)?;
    let load_bounds = spec
        .bounds
        .filter(|_| spec.kind == ModelKind::Object)
        .map(|b| {
            let fc = field_config(spec.kind, b, &config.object, config.object_start, 1, 1, 0);
            Aabb {
                min: fc.bounds_min,
                max: fc.bounds_max,
            }
        });
    let options = LoadOptions {
        holdout: config.holdout,
        bounds: load_bounds,
    };
    let data = Dataset::load(&capture, &spec.role, &options)?;
    let bounds = spec.bounds.unwrap_or(data.observed);
    Ok((data, bounds, t0.elapsed().as_secs_f64()))
}

/// Loads the data of `spec`, trains (or resumes) its model into `model_dir`, evaluates it and writes the
/// final model. Returns the manifest entry and the trained field.
pub fn train_model(
    spec: &ModelSpec,
    model_dir: &Path,
    config: &TrainConfig,
    augmentation: &Augmentation,
    progress: &dyn Progress,
) -> Result<(ModelEntry, NeusField<f32>), TrainError> {
    let (data, bounds, load_seconds) = load_model_data(spec, config)?;
    let ckpt = model_dir.join("checkpoint");
    let mut trainer = if ckpt.join("config.json").exists() {
        Trainer::resume(&data, augmentation, config, spec.kind, &ckpt)?
    } else {
        Trainer::new(&data, augmentation, config, spec.kind, bounds)
    };
    trainer.run(&spec.name, Some(&ckpt), progress)?;
    let fc = trainer.field.config();
    let field_bounds = Aabb {
        min: fc.bounds_min,
        max: fc.bounds_max,
    };
    let lights = trainer.light_codes().clone();
    let eval = (!data.held_out.is_empty()).then(|| {
        evaluate(
            &trainer.field,
            &data.held_out,
            &field_bounds,
            augmentation,
            lights.capture,
        )
    });
    let chamfer_m = truth_chamfer(spec, &trainer.field, &field_bounds, None)?;
    let entry = ModelEntry {
        name: spec.name.clone(),
        path: spec.path.clone(),
        kind: spec.kind,
        ids: match &spec.role {
            Role::Object { ids, .. } => ids.clone(),
            Role::Background => Vec::new(),
        },
        objects: spec.objects.clone(),
        bounds: field_bounds,
        object_box: match spec.kind {
            ModelKind::Object => spec.bounds,
            ModelKind::Background => None,
        },
        light_codes: lights,
        appearance_codes: fc.appearance_codes,
        stats: ModelStats {
            steps: trainer.state.step,
            train_seconds: trainer.state.elapsed_s,
            load_seconds,
            rays: data.rays.len(),
            final_loss: trainer.state.last,
            inv_s: trainer.field.inv_s(),
            eval,
            chamfer_m,
            faulty_steps: trainer.state.health.faults,
            frame_corrections: trainer.corrections().map(FrameCorrections::summary),
        },
    };
    write_refined_poses_of(spec, &data, trainer.corrections(), model_dir)?;
    let mut meta = trainer.trainer_json();
    meta["entry"] = serde_json::to_value(&entry).map_err(|e| TrainError::File {
        path: model_dir.join("config.json"),
        message: e.to_string(),
    })?;
    checkpoint::save(model_dir, &trainer.field, None, meta)?;
    let _ = std::fs::remove_dir_all(&ckpt);
    let _ = std::fs::remove_file(model_dir.join("adam.safetensors"));
    Ok((entry, trainer.field))
}

/// Writes the corrected poses of `spec`'s training frames beside its model (`refined_poses.json`)
/// when training corrected them, and takes away a file of an earlier training that did not.
fn write_refined_poses_of(
    spec: &ModelSpec,
    data: &Dataset,
    corrections: Option<&FrameCorrections>,
    model_dir: &Path,
) -> Result<(), TrainError> {
    let path = model_dir.join(REFINED_POSES_FILE);
    let capture = read_capture(&spec.capture)?;
    let refined = corrections
        .and_then(|c| c.refined_poses(&capture, spec.role.capture_to_model(), &data.frame_index));
    match refined {
        Some(poses) => write_refined_poses(&path, &poses)?,
        None if path.exists() => {
            std::fs::remove_file(&path).map_err(|e| TrainError::File {
                path: path.clone(),
                message: format!("cannot remove a stale file: {e}"),
            })?;
        }
        None => {}
    }
    Ok(())
}

/// A trained model scored on the held-out views of `spec`'s capture, which need not be the capture
/// it was trained on: a model trained on a degraded copy of a room is scored on the original's views
/// and ground-truth mesh, so the two trainings are judged on the same truth. `entry` is the model's
/// manifest entry (its light codes); no light-code check is run.
///
/// A model whose frames' poses were refined keeps the frame its capture's poses average to, which a
/// tracker leaves a few millimetres and a tenth of a degree from the truth's: `gauge` (capture
/// frame), when given, maps the truth's poses into the frame the model settled in, and the views and
/// the ground-truth mesh are moved by it before scoring, as pose-refining methods are judged once
/// their poses are aligned to the truth's ([`neuroom_core::Pose::aligning`]).
pub fn evaluate_on_capture(
    spec: &ModelSpec,
    entry: &ModelEntry,
    field: &NeusField<f32>,
    config: &TrainConfig,
    gauge: Option<Pose>,
) -> Result<ModelScore, TrainError> {
    let (mut data, _, _) = load_model_data(spec, config)?;
    let to_model = spec.role.capture_to_model();
    let moved = gauge.map(|g| to_model.compose(&g).compose(&to_model.inverse()));
    if let Some(m) = moved {
        for view in &mut data.held_out {
            view.move_by(&m);
        }
    }
    let eval = (!data.held_out.is_empty()).then(|| {
        evaluate(
            field,
            &data.held_out,
            &entry.bounds,
            &Augmentation::default(),
            entry.light_codes.capture,
        )
    });
    Ok(ModelScore {
        eval,
        chamfer_m: truth_chamfer(spec, field, &entry.bounds, moved)?,
    })
}

/// What [`evaluate_on_capture`] measured.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ModelScore {
    /// Held-out figures (`None` without held-out views).
    pub eval: Option<EvalReport>,
    /// Chamfer distance to the ground-truth mesh, when there is one.
    pub chamfer_m: Option<Chamfer>,
}

/// Grid cells per side of the mesh extracted for the Chamfer distance.
pub const MESH_CELLS: u32 = 192;
/// Points sampled on each mesh for the Chamfer distance.
pub const CHAMFER_SAMPLES: usize = 50_000;

/// Chamfer distance between the zero level set of `field` and the spec's ground-truth mesh, when it
/// has one; `moved` (model frame), when given, moves the truth first.
pub fn truth_chamfer(
    spec: &ModelSpec,
    field: &NeusField<f32>,
    bounds: &Aabb,
    moved: Option<Pose>,
) -> Result<Option<Chamfer>, TrainError> {
    let Some(path) = &spec.truth_mesh else {
        return Ok(None);
    };
    let mut truth = read_ply(path)?;
    if let Some(m) = moved {
        for p in &mut truth.positions {
            *p = m.transform_point(p.as_dvec3()).as_vec3();
        }
    }
    let learned = extract_mesh(field, bounds, MESH_CELLS);
    Ok(Some(chamfer(&learned, &truth, CHAMFER_SAMPLES)))
}

/// File name of the model manifest inside a model folder.
pub const MANIFEST_FILE: &str = "manifest.json";

fn write_manifest(dir: &Path, manifest: &Manifest) -> Result<(), TrainError> {
    let path = dir.join(MANIFEST_FILE);
    let text = serde_json::to_vec_pretty(manifest).map_err(|e| TrainError::File {
        path: path.clone(),
        message: e.to_string(),
    })?;
    atomic_write(&path, &text)?;
    Ok(())
}

/// A room's trained models, loaded.
#[derive(Clone, Debug)]
pub struct RoomModels {
    /// The manifest.
    pub manifest: Manifest,
    /// One field per manifest entry, in the same order.
    pub fields: Vec<NeusField<f32>>,
    /// Per manifest entry, the corrected poses of its capture's training frames, when training
    /// corrected them (`refined_poses.json` in the model's folder).
    pub refined_poses: Vec<Option<RefinedPoses>>,
}

impl RoomModels {
    /// The background field and its entry.
    pub fn background(&self) -> Option<(&ModelEntry, &NeusField<f32>)> {
        self.manifest
            .models
            .iter()
            .zip(&self.fields)
            .find(|(m, _)| m.kind == ModelKind::Background)
    }

    /// The field drawing instance `id`, with its entry.
    pub fn object(&self, id: u16) -> Option<(&ModelEntry, &NeusField<f32>)> {
        self.manifest
            .models
            .iter()
            .zip(&self.fields)
            .find(|(m, _)| m.ids.contains(&id))
    }
}

/// Reads the manifest of a room's model folder (`<models>/<room>/manifest.json`) alone.
pub fn read_manifest(dir: &Path) -> Result<Manifest, TrainError> {
    let path = dir.join(MANIFEST_FILE);
    let text = std::fs::read(&path).map_err(|e| TrainError::File {
        path: path.clone(),
        message: format!("cannot read: {e}"),
    })?;
    let manifest: Manifest = serde_json::from_slice(&text).map_err(|e| TrainError::File {
        path: path.clone(),
        message: e.to_string(),
    })?;
    if manifest.format != MANIFEST_FORMAT {
        return Err(TrainError::File {
            path,
            message: format!("format {:?}, expected {MANIFEST_FORMAT:?}", manifest.format),
        });
    }
    Ok(manifest)
}

/// Reads a room's model folder (`<models>/<room>`): the manifest, every model it lists and their
/// refined capture poses.
pub fn load_room_models(dir: &Path) -> Result<RoomModels, TrainError> {
    let manifest = read_manifest(dir)?;
    let fields = manifest
        .models
        .iter()
        .map(|m| checkpoint::load(&dir.join(&m.path)).map(|(f, _, _)| f))
        .collect::<Result<Vec<_>, _>>()?;
    let refined_poses = manifest
        .models
        .iter()
        .map(|m| {
            let path = dir.join(&m.path).join(REFINED_POSES_FILE);
            path.is_file()
                .then(|| read_refined_poses(&path))
                .transpose()
        })
        .collect::<Result<Vec<_>, _>>()?;
    Ok(RoomModels {
        manifest,
        fields,
        refined_poses,
    })
}

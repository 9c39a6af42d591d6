//! Object masks without annotation ([`neuroom_import::masks`]) for a capture of an object standing
//! in its room, cut by the room's trained empty-room model: written into the capture
//! (`neuroom masks`), or scored against a room's true masks (`neuroom bench masks`).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::Vec3;
use neuroom_core::formats::{
    Capture, RoomObject, read_capture, read_depth, read_mask, write_capture, write_mask,
};
use neuroom_core::image::MaskImage;
use neuroom_field::{Field, NeusField};
use neuroom_import::masks::{
    DepthFrame, MaskOptions, ObjectMasks, RoomSurface, mask_iou, object_masks,
};
use rayon::prelude::*;
use serde::Serialize;

pub use neuroom_import::masks::WorldBox;

use crate::Room;

/// Points per parallel field query: big enough for the field's batched MLP, many enough chunks for
/// every core.
const SDF_CHUNK: usize = 4096;

/// The empty room's trained surface.
pub struct BackgroundSurface {
    field: NeusField<f32>,
}

impl RoomSurface for BackgroundSurface {
    fn signed_distance(&self, points: &[Vec3], out: &mut [f32]) {
        out.par_chunks_mut(SDF_CHUNK)
            .zip(points.par_chunks(SDF_CHUNK))
            .for_each(|(out, points)| self.field.sdf(points, out));
    }
}

/// Loads the background model of the model folder `models` (and no other).
pub fn load_background_surface(models: &Path) -> anyhow::Result<BackgroundSurface> {
    let context = || format!("reading the background model in {}", models.display());
    let manifest = crate::train::read_manifest(models).with_context(context)?;
    let entry = manifest
        .models
        .iter()
        .find(|m| m.kind == neuroom_train::ModelKind::Background)
        .with_context(|| {
            format!(
                "{}: has no background model (train it first: neuroom train ROOM --only background)",
                models.join("manifest.json").display()
            )
        })?;
    let (field, _, _) =
        neuroom_field::checkpoint::load(&models.join(&entry.path)).with_context(context)?;
    Ok(BackgroundSurface { field })
}

/// The object named `name` of `room`, and its capture.
fn object_capture(room: &Room, name: &str) -> anyhow::Result<(RoomObject, Capture)> {
    let object = room
        .objects
        .iter()
        .find(|o| o.name == name)
        .with_context(|| {
            let names: Vec<&str> = room.objects.iter().map(|o| o.name.as_str()).collect();
            format!(
                "{}: has no object `{name}` (it has {})",
                room.root.join("room.json").display(),
                names.join(", ")
            )
        })?
        .clone();
    let capture = read_capture(room.root.join(&object.capture))?;
    Ok((object, capture))
}

/// The capture's frames with their depth, the capture's frame taken as the room's world.
fn depth_frames(capture: &Capture) -> anyhow::Result<Vec<DepthFrame>> {
    capture
        .frames
        .iter()
        .map(|frame| {
            let relative = frame.depth.as_ref().with_context(|| {
                format!(
                    "{}: frame {} has no depth: automatic masks need it",
                    capture.dir.join("transforms.json").display(),
                    frame.image.display()
                )
            })?;
            let depth = read_depth(capture.resolve(relative), capture.depth_unit_scale_factor)?;
            anyhow::ensure!(
                (depth.width, depth.height) == (frame.camera.width, frame.camera.height),
                "{}: {}x{} depth for a {}x{} frame",
                capture.resolve(relative).display(),
                depth.width,
                depth.height,
                frame.camera.width,
                frame.camera.height
            );
            Ok(DepthFrame {
                camera: frame.camera,
                camera_to_world: frame.camera_to_world,
                depth: depth.data,
            })
        })
        .collect()
}

/// The automatic masks of `capture` (its poses in the room's world), cut by the background model
/// of `models`, inside `bounds` or the box they propose.
fn capture_masks(
    capture: &Capture,
    models: &Path,
    bounds: Option<WorldBox>,
) -> anyhow::Result<ObjectMasks> {
    let surface = load_background_surface(models)?;
    object_masks(
        &depth_frames(capture)?,
        &surface,
        bounds,
        &MaskOptions::default(),
    )
    .with_context(|| format!("masking {}", capture.dir.display()))
}

/// What [`write_capture_masks`] wrote.
#[derive(Clone, Debug, Serialize)]
pub struct WrittenMasks {
    /// The capture folder.
    pub capture: PathBuf,
    /// Frames masked.
    pub frames: usize,
    /// The share of all pixels on the object.
    pub coverage: f64,
    /// The box the masks were cut in, `[min, max]`, metres.
    pub bounds: [[f64; 3]; 2],
    /// How far from the room's surface a point had to lie to count, millimetres.
    pub tolerance_mm: f64,
}

/// Makes the automatic masks of object `name`'s capture (its poses in the room's world), cut by the
/// background model of `models` inside `bounds` or the box they propose, and writes them into the
/// capture (`masks/`, the object's id on it; transforms.json names them). Frames' existing masks
/// are replaced.
pub fn write_capture_masks(
    room: &Room,
    models: &Path,
    name: &str,
    bounds: Option<WorldBox>,
) -> anyhow::Result<WrittenMasks> {
    let (object, mut capture) = object_capture(room, name)?;
    let found = capture_masks(&capture, models, bounds)?;
    let mut on_object = 0usize;
    let mut pixels = 0usize;
    for (i, (frame, mask)) in capture.frames.iter_mut().zip(&found.masks).enumerate() {
        let relative = PathBuf::from("masks").join(format!("auto-{i:04}.png"));
        let image = MaskImage {
            width: mask.width,
            height: mask.height,
            data: mask
                .pixels
                .iter()
                .map(|&p| if p { object.id } else { 0 })
                .collect(),
        };
        write_mask(capture.dir.join(&relative), &image)?;
        on_object += mask.pixels.iter().filter(|p| **p).count();
        pixels += mask.pixels.len();
        frame.instance = Some(relative);
    }
    write_capture(&capture.dir, &capture)?;
    Ok(WrittenMasks {
        capture: capture.dir.clone(),
        frames: found.masks.len(),
        coverage: on_object as f64 / pixels.max(1) as f64,
        bounds: [found.bounds.min.to_array(), found.bounds.max.to_array()],
        tolerance_mm: found.tolerance * 1e3,
    })
}

/// One object's automatic masks against its true ones.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectMaskScore {
    /// The object (room.json).
    pub name: String,
    /// Frames scored.
    pub frames: usize,
    /// Intersection over union over all frames.
    pub iou: f64,
    /// The measured tolerance, millimetres.
    pub tolerance_mm: f64,
}

/// `neuroom bench masks`: every object whose capture has true masks.
#[derive(Clone, Debug, Serialize)]
pub struct MaskBenchReport {
    /// The room's name.
    pub room: String,
    /// One row per scored object.
    pub objects: Vec<ObjectMaskScore>,
    /// The mean of the objects' IoU.
    pub mean_iou: f64,
    /// The lowest.
    pub worst_iou: f64,
}

/// Makes the automatic masks (box proposed, not given) of every object capture of `room` whose
/// frames all have true masks, and scores them; objects sharing a capture are scored once.
pub fn bench_masks(
    room: &Room,
    models: &Path,
    note: &mut dyn FnMut(&str),
) -> anyhow::Result<MaskBenchReport> {
    let surface = load_background_surface(models)?;
    let mut seen_captures = Vec::new();
    let mut objects = Vec::new();
    for object in &room.objects {
        if seen_captures.contains(&object.capture) {
            continue;
        }
        seen_captures.push(object.capture.clone());
        let capture = read_capture(room.root.join(&object.capture))?;
        let frames = depth_frames(&capture)?;
        let Some(truth) = true_masks(&capture, &frames)? else {
            note(&format!(
                "{}: its capture has no true masks, or shows it alone: skipped",
                object.name
            ));
            continue;
        };
        let found = object_masks(&frames, &surface, None, &MaskOptions::default())
            .with_context(|| format!("masking {}", capture.dir.display()))?;
        let score = ObjectMaskScore {
            name: object.name.clone(),
            frames: truth.len(),
            iou: mask_iou(&found.masks, &truth),
            tolerance_mm: found.tolerance * 1e3,
        };
        note(&format!(
            "{}: IoU {:.4} over {} frames",
            score.name, score.iou, score.frames
        ));
        objects.push(score);
    }
    anyhow::ensure!(
        !objects.is_empty(),
        "{}: no object capture has true masks to score",
        room.root.display()
    );
    let mean_iou = objects.iter().map(|o| o.iou).sum::<f64>() / objects.len() as f64;
    let worst_iou = objects.iter().map(|o| o.iou).fold(f64::INFINITY, f64::min);
    Ok(MaskBenchReport {
        room: room.name.clone(),
        objects,
        mean_iou,
        worst_iou,
    })
}

/// Every frame's true mask (any id on the object), `None` when a frame has none or the capture
/// shows the object alone (no depth off the object: no room to tell it from).
fn true_masks(capture: &Capture, frames: &[DepthFrame]) -> anyhow::Result<Option<Vec<Vec<bool>>>> {
    let mut masks = Vec::new();
    let mut room_seen = false;
    for (frame, depth) in capture.frames.iter().zip(frames) {
        let Some(relative) = &frame.instance else {
            return Ok(None);
        };
        let mask = read_mask(capture.resolve(relative))?;
        anyhow::ensure!(
            mask.data.len() == depth.depth.len(),
            "{}: the mask's size is not its frame's",
            capture.resolve(relative).display()
        );
        let on: Vec<bool> = mask.data.iter().map(|&id| id != 0).collect();
        room_seen |= on.iter().zip(&depth.depth).any(|(o, d)| !o && *d > 0.0);
        masks.push(on);
    }
    Ok(room_seen.then_some(masks))
}

/// The background model `bench masks` cuts with when no model folder is given: trained alone with
/// `background_steps` (seed 0) into `cache/masks-bg<steps>/<room name>`, or found there.
pub fn bench_background_models(
    room_dir: &Path,
    cache: &Path,
    background_steps: u64,
    threads: usize,
    progress: &dyn crate::train::TrainProgress,
) -> anyhow::Result<PathBuf> {
    let options = crate::train::TrainOptions {
        only: vec!["background".into()],
        ..crate::train::TrainOptions::steps_only(0, background_steps, 0, threads)
    };
    let out = cache.join(format!("masks-bg{background_steps}"));
    Ok(crate::train::train_room(room_dir, &out, &options, progress)?.dir)
}

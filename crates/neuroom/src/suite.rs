//! The validation suite behind `neuroom bench locate --suite DIR…`: rooms rendered by other tools, each
//! trained with step budgets (cached, so a second run only locates), every test panorama located and
//! scored, then the figures per room, their mean over the rooms and the worst room.
//!
//! Every room counts once in the mean, however many panoramas it has: a room with more test panoramas
//! must not hide a room the pipeline fails in.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use crate::locate::{LocateConfig, LocateMean, PanoramaScore, bench_locate};
use crate::train::{RefineWhen, TrainOptions, TrainProgress, train_room};
use neuroom_core::camera_effects::CameraEffect;
use neuroom_core::formats::Capture;
use neuroom_fit::FitConfig;

/// The step budgets the suite trains every room with. Counted in steps, not seconds, so the same
/// budgets give the same models on any machine load.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SuiteTraining {
    /// Steps per object model.
    pub object_steps: u64,
    /// Steps of the background model.
    pub background_steps: u64,
    /// Seed of sampling and initialisation.
    pub seed: u64,
    /// Worker threads (0 = all cores); the models do not depend on it.
    pub threads: usize,
    /// Which per-frame corrections the models learn.
    pub frame_corrections: RefineWhen,
}

impl Default for SuiteTraining {
    /// `neuroom train`'s default step budgets, so the suite measures the models a user gets.
    fn default() -> Self {
        Self {
            object_steps: neuroom_train::config::OBJECT_STEPS,
            background_steps: neuroom_train::config::BACKGROUND_STEPS,
            seed: 1,
            threads: 0,
            frame_corrections: RefineWhen::FromCapture,
        }
    }
}

impl SuiteTraining {
    /// The training options of these budgets: steps only, no identification network (the suite
    /// measures the default detector).
    pub fn options(&self) -> TrainOptions {
        let (objects, background) = (self.object_steps, self.background_steps);
        TrainOptions {
            frame_corrections: self.frame_corrections,
            ..TrainOptions::steps_only(objects, background, self.seed, self.threads)
        }
    }
}

/// What `neuroom bench locate --suite` runs.
#[derive(Clone, Debug)]
pub struct SuiteSpec {
    /// Room folders, or folders whose sub-folders are rooms.
    pub dirs: Vec<PathBuf>,
    /// Where trained models are kept between runs (one folder per room and training key).
    pub cache: PathBuf,
    /// Training budgets.
    pub training: SuiteTraining,
    /// The locate pipeline.
    pub locate: LocateConfig,
    /// The holistic fit after the initial poses, as `neuroom locate` runs it; `None`: initial poses only.
    pub fit: Option<FitConfig>,
    /// A real camera's effect applied to every panorama first ([`CameraEffect::named`]).
    pub effect: Option<CameraEffect>,
}

/// One room's figures.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SuiteRoom {
    /// The room's name (room.json).
    pub room: String,
    /// Its folder, as given.
    pub dir: PathBuf,
    /// Means over its test panoramas.
    pub mean: LocateMean,
    /// Seconds spent training it in this run (0 when its models were cached).
    pub train_seconds: f64,
}

/// The whole suite's figures.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SuiteReport {
    /// The camera effect the panoramas were given, if any.
    pub effect: Option<CameraEffect>,
    /// Per room, in the order run.
    pub rooms: Vec<SuiteRoom>,
    /// The mean over the rooms, each counted once; the largest camera errors are the largest of any
    /// panorama.
    pub mean: LocateMean,
    /// The room with the lowest mean IoU.
    pub worst: SuiteRoom,
}

/// What the suite reports as it goes.
pub enum SuiteEvent<'a> {
    /// A room's models are being trained (or found in the cache).
    Training { room: &'a str, models: &'a Path },
    /// One panorama was located and scored.
    Panorama {
        room: &'a str,
        score: &'a PanoramaScore,
    },
    /// A room is done.
    Room(&'a SuiteRoom),
}

/// The room folders named by `dirs`: each folder holding a `room.json`, or else each of its
/// sub-folders that holds one, in name order. Two rooms of one name are an error (their models would
/// share a folder).
pub fn suite_rooms(dirs: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut rooms = Vec::new();
    for dir in dirs {
        if dir.join("room.json").is_file() {
            rooms.push(dir.clone());
            continue;
        }
        let entries = std::fs::read_dir(dir).with_context(|| {
            format!("{}: cannot list (not a room folder either)", dir.display())
        })?;
        let mut found: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.join("room.json").is_file())
            .collect();
        anyhow::ensure!(
            !found.is_empty(),
            "{}: neither a room (no room.json) nor a folder of rooms",
            dir.display()
        );
        found.sort();
        rooms.extend(found);
    }
    let mut names = std::collections::BTreeMap::new();
    for dir in &rooms {
        let name = crate::read_room(dir)?.name;
        if let Some(other) = names.insert(name.clone(), dir.clone()) {
            anyhow::bail!(
                "{} and {} are both named `{name}` in their room.json",
                other.display(),
                dir.display()
            );
        }
    }
    Ok(rooms)
}

/// The cache folder of `room`'s models under `cache`: keyed by the training configuration, the
/// training code's revision ([`neuroom_train::TRAINING_REVISION`]) and the bytes of room.json, of
/// every capture's transforms.json and of every frame's image, depth map and mask, so changed
/// budgets, a build that trains other bits or a regenerated room (its poses kept or not) train anew
/// instead of reusing stale models. The per-frame corrections' settings are left out of a
/// configuration's serialised form while they are the defaults; a room whose captures come from a
/// phone (corrections learned) is keyed by them too, so a change of those defaults retrains it, and
/// a room with noisy-depth captures by [`neuroom_train::NOISY_DEPTH_REVISION`].
pub fn cached_models_dir(
    cache: &Path,
    room: &Path,
    training: &SuiteTraining,
) -> anyhow::Result<PathBuf> {
    cached_models_dir_of_revision(cache, room, training, neuroom_train::TRAINING_REVISION)
}

/// [`cached_models_dir`] for the training code's revision `revision`. Revision 0 adds nothing to the
/// key: the caches made before revisions were counted hold its models, and keep their folders.
fn cached_models_dir_of_revision(
    cache: &Path,
    room: &Path,
    training: &SuiteTraining,
    revision: u32,
) -> anyhow::Result<PathBuf> {
    let parsed = crate::read_room(room)?;
    let config = training.options().config();
    let mut hash = Sha256::new();
    hash.update(serde_json::to_vec(&config)?);
    if revision > 0 {
        hash.update(revision.to_le_bytes());
    }
    let room_json = room.join("room.json");
    hash.update(std::fs::read(&room_json).with_context(|| format!("{}", room_json.display()))?);
    let mut captures: Vec<&Path> = std::iter::once(parsed.background.capture.as_path())
        .chain(parsed.objects.iter().map(|o| o.capture.as_path()))
        .collect();
    captures.sort_unstable();
    captures.dedup();
    let (mut corrected, mut noisy) = (false, false);
    for capture in captures {
        let transforms = room.join(capture).join("transforms.json");
        let bytes =
            std::fs::read(&transforms).with_context(|| format!("{}", transforms.display()))?;
        hash.update(&bytes);
        let parsed = neuroom_core::formats::parse_capture(&transforms, &bytes)?;
        hash_frame_files(&mut hash, &room.join(capture), &parsed)?;
        corrected |= parsed.device.auto_exposure || parsed.device.tracked_poses;
        noisy |= parsed.device.depth_noise.is_some();
    }
    if corrected {
        hash.update(serde_json::to_vec(&config.frame_refinement)?);
    }
    // Where depthless rays are sampled, and how noisy depth trains, change only captures that
    // declare their depth noise.
    if noisy {
        hash.update(serde_json::to_vec(&config.unobserved_samples)?);
        hash.update(neuroom_train::NOISY_DEPTH_REVISION.to_le_bytes());
    }
    let key: String = hash.finalize()[..8]
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    Ok(cache.join(format!("{}-{key}", parsed.name)))
}

/// Adds the bytes of every image, depth map and mask of `capture` (in the folder `dir`) to `hash`: a
/// capture whose frames were rendered or degraded anew under the same poses trains other models.
fn hash_frame_files(hash: &mut Sha256, dir: &Path, capture: &Capture) -> anyhow::Result<()> {
    for frame in &capture.frames {
        let files = std::iter::once(&frame.image)
            .chain(&frame.depth)
            .chain(&frame.instance);
        for file in files {
            let path = dir.join(file);
            hash.update(std::fs::read(&path).with_context(|| format!("{}", path.display()))?);
        }
    }
    Ok(())
}

/// One suite room's models, trained in this run or found in the cache.
pub struct SuiteModels {
    /// The room's name (room.json).
    pub room: String,
    /// The model folder (holds the manifest).
    pub models: PathBuf,
    /// Seconds spent training them in this run (0 when they were cached).
    pub train_seconds: f64,
}

/// Trains the models of the room in `dir` with the suite's budgets into the cache of `spec`, or finds
/// them there; an interrupted training resumes from its checkpoints. `announce` sees the room's name
/// and model folder before the training starts.
pub fn suite_models(
    spec: &SuiteSpec,
    dir: &Path,
    progress: &dyn TrainProgress,
    announce: &mut dyn FnMut(&str, &Path),
) -> anyhow::Result<SuiteModels> {
    let name = crate::read_room(dir)?.name;
    let parent = cached_models_dir(&spec.cache, dir, &spec.training)?;
    let models = parent.join(&name);
    announce(&name, &models);
    let start = Instant::now();
    let trained = train_room(dir, &parent, &spec.training.options(), progress)?;
    anyhow::ensure!(
        trained.manifest.complete,
        "{}: training stopped before every model was done",
        models.display()
    );
    let train_seconds = if trained.trained.is_empty() {
        0.0
    } else {
        start.elapsed().as_secs_f64()
    };
    Ok(SuiteModels {
        room: name,
        models,
        train_seconds,
    })
}

/// Trains (or finds in the cache) the models of every room of `spec` without locating anything: a
/// cache made ready before the suite is run. `announce` sees each room as in [`suite_models`].
pub fn train_suite(
    spec: &SuiteSpec,
    progress: &dyn TrainProgress,
    announce: &mut dyn FnMut(&str, &Path),
) -> anyhow::Result<Vec<SuiteModels>> {
    suite_rooms(&spec.dirs)?
        .iter()
        .map(|dir| suite_models(spec, dir, progress, announce))
        .collect()
}

/// Trains (or finds in the cache) and locates every room of `spec`; `progress` shows the training,
/// `each` sees the suite as it goes.
pub fn bench_suite(
    spec: &SuiteSpec,
    progress: &dyn TrainProgress,
    each: &mut dyn FnMut(SuiteEvent),
) -> anyhow::Result<SuiteReport> {
    let rooms = suite_rooms(&spec.dirs)?;
    let mut results = Vec::new();
    for dir in &rooms {
        let trained = suite_models(spec, dir, progress, &mut |room, models| {
            each(SuiteEvent::Training { room, models })
        })?;
        let fit = spec.fit.as_ref();
        let effect = spec.effect.as_ref();
        let (_, mean) = bench_locate(dir, &trained.models, &spec.locate, fit, effect, &mut |s| {
            each(SuiteEvent::Panorama {
                room: &trained.room,
                score: s,
            })
        })?;
        let room = SuiteRoom {
            room: trained.room,
            dir: dir.clone(),
            mean,
            train_seconds: trained.train_seconds,
        };
        each(SuiteEvent::Room(&room));
        results.push(room);
    }
    let means: Vec<LocateMean> = results.iter().map(|r| r.mean.clone()).collect();
    let worst = results
        .iter()
        .min_by(|a, b| a.mean.iou_percent.total_cmp(&b.mean.iou_percent))
        .cloned()
        .context("the suite has no room")?;
    Ok(SuiteReport {
        effect: spec.effect,
        mean: mean_over_rooms(&means),
        rooms: results,
        worst,
    })
}

/// The mean of per-room means, every room counted once; the largest camera errors are the largest
/// over all rooms, and the panorama count is their sum.
pub fn mean_over_rooms(rooms: &[LocateMean]) -> LocateMean {
    let n = rooms.len().max(1) as f64;
    let mean = |f: &dyn Fn(&LocateMean) -> f64| rooms.iter().map(f).sum::<f64>() / n;
    let max = |f: &dyn Fn(&LocateMean) -> f64| rooms.iter().map(f).fold(0.0, f64::max);
    LocateMean {
        panoramas: rooms.iter().map(|r| r.panoramas).sum(),
        camera_position_error_cm: mean(&|r| r.camera_position_error_cm),
        camera_position_error_max_cm: max(&|r| r.camera_position_error_max_cm),
        camera_rotation_error_deg: mean(&|r| r.camera_rotation_error_deg),
        camera_rotation_error_max_deg: max(&|r| r.camera_rotation_error_max_deg),
        precision: mean(&|r| r.precision),
        recall: mean(&|r| r.recall),
        iou_percent: mean(&|r| r.iou_percent),
        are_deg: mean(&|r| r.are_deg),
        are_up_to_symmetry_deg: mean(&|r| r.are_up_to_symmetry_deg),
        ape_cm: mean(&|r| r.ape_cm),
        placed_share: mean(&|r| r.placed_share),
        seconds: mean(&|r| r.seconds),
        initial: rooms
            .iter()
            .all(|r| r.initial.is_some())
            .then(|| std::array::from_fn(|k| mean(&|r| r.initial.map_or(0.0, |i| i[k])))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room_mean(iou: f64, camera_max_cm: f64, panoramas: usize) -> LocateMean {
        LocateMean {
            panoramas,
            iou_percent: iou,
            camera_position_error_max_cm: camera_max_cm,
            placed_share: iou / 100.0,
            ..LocateMean::default()
        }
    }

    #[test]
    fn every_room_counts_once_in_the_mean_and_the_largest_camera_error_is_kept() {
        let mean = mean_over_rooms(&[room_mean(90.0, 1.0, 10), room_mean(30.0, 250.0, 2)]);
        assert_eq!(mean.iou_percent, 60.0);
        assert_eq!(mean.placed_share, 0.6);
        assert_eq!(mean.camera_position_error_max_cm, 250.0);
        assert_eq!(mean.panoramas, 12);
        assert!(mean.initial.is_none());
    }

    #[test]
    fn a_build_that_trains_other_bits_caches_into_another_folder() {
        let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../suite/dining");
        let (cache, training) = (Path::new("cache"), SuiteTraining::default());
        let at =
            |revision| cached_models_dir_of_revision(cache, &room, &training, revision).unwrap();
        assert_eq!(at(0), at(0));
        assert_ne!(at(1), at(0));
        assert_ne!(at(2), at(1));
        assert!(at(1).starts_with(cache.join("")), "{}", at(1).display());
    }

    #[test]
    fn a_room_whose_images_changed_caches_into_another_folder() {
        let scratch = tempfile::tempdir().unwrap();
        let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny");
        let room = scratch.path().join("tiny");
        neuroom_testing::copy_folder(&tiny, &room);
        let (cache, training) = (Path::new("cache"), SuiteTraining::default());
        let before = cached_models_dir(cache, &room, &training).unwrap();
        let spec = crate::read_room(&room).unwrap();
        let capture = room.join(&spec.background.capture);
        let frame = &neuroom_core::formats::read_capture(&capture)
            .unwrap()
            .frames[0];
        let image = capture.join(&frame.image);
        let mut bytes = std::fs::read(&image).unwrap();
        bytes.push(0);
        std::fs::write(&image, bytes).unwrap();
        assert_ne!(cached_models_dir(cache, &room, &training).unwrap(), before);
    }

    #[test]
    fn rooms_are_found_in_a_folder_of_rooms_and_named_once() {
        let dir = tempfile::tempdir().unwrap();
        let write = |sub: &str, name: &str| {
            let room = dir.path().join(sub);
            std::fs::create_dir_all(&room).unwrap();
            let json = neuroom_testing::TINY_ROOM_JSON.replacen("tiny", name, 1);
            assert!(json.contains(name));
            std::fs::write(room.join("room.json"), json).unwrap();
            room
        };
        let b = write("b", "second");
        let a = write("a", "first");
        std::fs::create_dir_all(dir.path().join("notes")).unwrap();
        let found = suite_rooms(&[dir.path().to_path_buf()]).unwrap();
        assert_eq!(found, [a.clone(), b]);
        assert_eq!(
            suite_rooms(std::slice::from_ref(&a)).unwrap(),
            std::slice::from_ref(&a)
        );
        let twice = format!("{:#}", suite_rooms(&[a.clone(), a]).unwrap_err());
        assert!(twice.contains("both named `first`"), "{twice}");
        let empty = tempfile::tempdir().unwrap();
        let none = format!("{:#}", suite_rooms(&[empty.path().into()]).unwrap_err());
        assert!(none.contains("neither a room"), "{none}");
    }
}

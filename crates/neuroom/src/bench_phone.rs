//! `neuroom bench phone ROOM`: what phone data costs. The room and its `--phone` copy
//! ([`crate::degrade`]) are trained with the same step budgets; each model trained on the copy is
//! scored on the original's held-out views and ground-truth mesh, and both rooms' models locate the
//! same test panoramas, so every difference is the phone's.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::DVec3;
use neuroom_core::formats::{Capture, RefinedPoses, read_capture};
use neuroom_core::metrics::rotation_error_deg;
use neuroom_core::pose::Pose;
use neuroom_field::NeusField;
use neuroom_train::room::{ModelScore, evaluate_on_capture, load_room_models, model_specs};
use neuroom_train::{ModelEntry, RoomModels};
use serde::{Deserialize, Serialize};

use crate::locate::{LocateConfig, LocateMean, bench_locate};
use crate::suite::{SuiteSpec, SuiteTraining, suite_models};
use crate::train::TrainProgress;

/// What `neuroom bench phone` runs.
#[derive(Clone, Debug)]
pub struct PhoneBenchSpec {
    /// The room folder.
    pub room: PathBuf,
    /// Where the degraded copy and both rooms' models are kept between runs.
    pub cache: PathBuf,
    /// Step budgets of both trainings.
    pub training: SuiteTraining,
    /// Seed of the degradation.
    pub seed: u64,
    /// The locate pipeline (initial poses, no fit); `None` compares the trainings only.
    pub locate: Option<LocateConfig>,
}

/// One model's figures on the original room's views and mesh.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HeldOutFigures {
    /// Held-out PSNR (dB).
    pub psnr_db: Option<f64>,
    /// Held-out PSNR (dB) with each view's exposure and white balance matched: what the phone's
    /// arbitrary mean exposure does not decide
    /// ([`neuroom_train::eval::exposure_matched_error`]).
    #[serde(default)]
    pub psnr_exposure_matched_db: Option<f64>,
    /// Median held-out depth error (mm).
    pub median_depth_error_mm: Option<f64>,
    /// Median signed held-out depth error (mm): negative where the model's surfaces stand nearer the
    /// cameras than the room's (a room that shrank, an object that grew).
    #[serde(default)]
    pub median_depth_offset_mm: Option<f64>,
    /// Mean Chamfer distance to the ground-truth mesh (mm).
    pub chamfer_mm: Option<f64>,
}

impl HeldOutFigures {
    fn of(score: &ModelScore) -> Self {
        let eval = score.eval.as_ref();
        Self {
            psnr_db: eval.map(|e| e.psnr_db),
            psnr_exposure_matched_db: eval.and_then(|e| e.psnr_exposure_matched_db),
            median_depth_error_mm: eval.map(|e| e.median_depth_error_m as f64 * 1000.0),
            median_depth_offset_mm: eval.map(|e| e.median_depth_offset_m as f64 * 1000.0),
            chamfer_mm: score.chamfer_m.map(|c| c.mean as f64 * 1000.0),
        }
    }
}

/// One model trained on the room and on its phone copy.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhoneModelRow {
    /// The model's name (`background` or the capture's).
    pub name: String,
    /// Trained on the room.
    pub clean: HeldOutFigures,
    /// Trained on the phone copy.
    pub phone: HeldOutFigures,
    /// Trained on the phone copy, scored with the room's views and mesh moved into the frame the
    /// copy's refined poses settled in (the rigid motion that best maps the room's poses of the
    /// training frames onto their refined ones); absent without refined poses.
    #[serde(default)]
    pub phone_aligned: Option<HeldOutFigures>,
    /// How far the copy's training frames are from the room's poses, as tracked and as refined.
    #[serde(default)]
    pub poses: Option<FramePoseErrors>,
}

/// How far ahead of each camera the second point of its pair lies in [`alignment_gauge`] (metres):
/// about where a capture's surfaces are, so the alignment weighs where the frames look as well as
/// where they stand.
const GAUGE_LOOK_AHEAD_M: f64 = 1.0;

/// The rigid motion (capture frame) that best maps the room's own poses of the refined frames onto
/// their refined poses: the frame a model trained on tracked poses settled in, which no phone can
/// know (corrections are relative). Each frame gives two point pairs, its centre and a point ahead
/// of it.
fn alignment_gauge(truth: &Capture, refined: &RefinedPoses) -> Option<Pose> {
    let pairs = |pose: &Pose| {
        let ahead = pose.transform_point(DVec3::new(0.0, 0.0, -GAUGE_LOOK_AHEAD_M));
        [pose.translation, ahead]
    };
    let (mut from, mut to) = (Vec::new(), Vec::new());
    for f in &refined.frames {
        from.extend(pairs(&truth.frames.get(f.index)?.camera_to_world));
        to.extend(pairs(&f.camera_to_world));
    }
    Pose::aligning(&from, &to)
}

impl PhoneModelRow {
    /// The phone copy's figures that judge its training: with the truth aligned when the model
    /// refined its poses, else as scored.
    pub fn judged(&self) -> &HeldOutFigures {
        self.phone_aligned.as_ref().unwrap_or(&self.phone)
    }
}

/// The camera error of a capture's frames against the room's own poses, mean over the frames.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct CameraPoseError {
    /// Mean distance of the camera centres (cm).
    pub position_cm: f64,
    /// Mean angle between the camera rotations (degrees).
    pub rotation_deg: f64,
}

/// A phone copy's training frames against the room's own poses: as the tracker left them and as
/// training refined them (`refined_poses.json`; absent for a model that wrote none).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FramePoseErrors {
    /// Frames compared (the model's training frames, or every frame without refined poses).
    pub frames: usize,
    /// The copy's capture poses.
    pub tracked: CameraPoseError,
    /// The refined poses.
    pub refined: Option<CameraPoseError>,
}

impl FramePoseErrors {
    /// The errors of the phone copy's capture `phone` and of `refined` against the room's capture
    /// `truth` (frames matched by their index).
    fn of(truth: &Capture, phone: &Capture, refined: Option<&RefinedPoses>) -> Self {
        let indices: Vec<usize> = match refined {
            Some(r) => r.frames.iter().map(|f| f.index).collect(),
            None => (0..phone.frames.len()).collect(),
        };
        let mean_error = |pose: &dyn Fn(usize, usize) -> Pose| {
            let mut e = CameraPoseError::default();
            for (k, &i) in indices.iter().enumerate() {
                let (got, want) = (pose(k, i), truth.frames[i].camera_to_world);
                e.position_cm += (got.translation - want.translation).length() * 100.0;
                e.rotation_deg += rotation_error_deg(want.rotation, got.rotation);
            }
            let n = indices.len().max(1) as f64;
            CameraPoseError {
                position_cm: e.position_cm / n,
                rotation_deg: e.rotation_deg / n,
            }
        };
        Self {
            frames: indices.len(),
            tracked: mean_error(&|_, i| phone.frames[i].camera_to_world),
            refined: refined.map(|r| mean_error(&|k, _| r.frames[k].camera_to_world)),
        }
    }
}

/// What phone data cost.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhoneBenchReport {
    /// The room's name.
    pub room: String,
    /// Per model.
    pub models: Vec<PhoneModelRow>,
    /// The largest held-out PSNR loss of any model (dB; positive: the phone's is worse).
    pub worst_psnr_loss_db: f64,
    /// The same with every view's exposure matched (the figure that judges the training: a phone
    /// capture fixes no exposure).
    #[serde(default)]
    pub worst_exposure_matched_psnr_loss_db: f64,
    /// The largest Chamfer increase of any model (mm).
    pub worst_chamfer_increase_mm: f64,
    /// The largest exposure-matched PSNR loss with the truth aligned to each refined model's frame
    /// (the plain one for a model without refined poses): the figure that judges the training.
    #[serde(default)]
    pub worst_aligned_psnr_loss_db: f64,
    /// The largest Chamfer increase with the truth aligned likewise (mm).
    #[serde(default)]
    pub worst_aligned_chamfer_increase_mm: f64,
    /// Locate with both rooms' models (absent when the spec asked for the trainings only).
    pub locate: Option<PhoneLocate>,
}

/// Locate on the room's test panoramas with either room's models.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhoneLocate {
    /// With the room's models.
    pub clean: LocateMean,
    /// With the phone copy's models (the same panoramas).
    pub phone: LocateMean,
    /// IoU lost to the phone (points).
    pub iou_loss_points: f64,
}

/// `neuroom bench phone` over several rooms: each room's report and what holds over all of them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhoneBenchSummary {
    /// Per room.
    pub rooms: Vec<PhoneBenchReport>,
    /// The largest held-out PSNR loss of any model of any room (dB).
    pub worst_psnr_loss_db: f64,
    /// The same with every view's exposure matched (dB).
    pub worst_exposure_matched_psnr_loss_db: f64,
    /// The largest Chamfer increase of any model of any room (mm).
    pub worst_chamfer_increase_mm: f64,
    /// The largest exposure-matched PSNR loss, truth aligned, of any model of any room (dB).
    #[serde(default)]
    pub worst_aligned_psnr_loss_db: f64,
    /// The largest Chamfer increase, truth aligned, of any model of any room (mm).
    #[serde(default)]
    pub worst_aligned_chamfer_increase_mm: f64,
    /// Locate over every room's panoramas (absent when the rooms were not located).
    pub locate: Option<PhoneLocateSummary>,
}

/// Locate's IoU with the rooms' models and with their phone copies', over several rooms.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PhoneLocateSummary {
    /// Panoramas located with either set of models.
    pub panoramas: usize,
    /// Mean IoU over every panorama with the rooms' models (percent).
    pub clean_iou_percent: f64,
    /// Mean IoU over the same panoramas with the phone copies' models (percent).
    pub phone_iou_percent: f64,
    /// `clean_iou_percent − phone_iou_percent` (points).
    pub iou_loss_points: f64,
    /// The largest IoU loss of one room (points).
    pub worst_room_iou_loss_points: f64,
}

impl PhoneBenchSummary {
    /// The worst figures over `rooms`, and locate's IoU pooled over their panoramas.
    pub fn of(rooms: Vec<PhoneBenchReport>) -> Self {
        let worst = |f: &dyn Fn(&PhoneBenchReport) -> f64| {
            rooms.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
        };
        let located: Option<Vec<&PhoneLocate>> = rooms.iter().map(|r| r.locate.as_ref()).collect();
        let locate = located.filter(|l| !l.is_empty()).map(|located| {
            let panoramas: usize = located.iter().map(|l| l.clean.panoramas).sum();
            let pooled = |iou: &dyn Fn(&PhoneLocate) -> &LocateMean| {
                located
                    .iter()
                    .map(|l| iou(l).iou_percent * iou(l).panoramas as f64)
                    .sum::<f64>()
                    / panoramas.max(1) as f64
            };
            let (clean, phone) = (pooled(&|l| &l.clean), pooled(&|l| &l.phone));
            PhoneLocateSummary {
                panoramas,
                clean_iou_percent: clean,
                phone_iou_percent: phone,
                iou_loss_points: clean - phone,
                worst_room_iou_loss_points: located
                    .iter()
                    .map(|l| l.iou_loss_points)
                    .fold(f64::NEG_INFINITY, f64::max),
            }
        });
        Self {
            worst_psnr_loss_db: worst(&|r| r.worst_psnr_loss_db),
            worst_exposure_matched_psnr_loss_db: worst(&|r| r.worst_exposure_matched_psnr_loss_db),
            worst_chamfer_increase_mm: worst(&|r| r.worst_chamfer_increase_mm),
            worst_aligned_psnr_loss_db: worst(&|r| r.worst_aligned_psnr_loss_db),
            worst_aligned_chamfer_increase_mm: worst(&|r| r.worst_aligned_chamfer_increase_mm),
            locate,
            rooms,
        }
    }
}

/// Degrades the room (once, cached), trains both (cached), scores both on the original's truth.
/// `progress` shows the training; `note` hears each stage.
pub fn bench_phone(
    spec: &PhoneBenchSpec,
    progress: &dyn TrainProgress,
    note: &mut dyn FnMut(&str),
) -> anyhow::Result<PhoneBenchReport> {
    let room = crate::read_room(&spec.room)?;
    let phone_room = spec.cache.join(format!(
        "{}-phone-r{}-seed{}",
        room.name,
        neuroom_synth::phone::PHONE_MODEL_REVISION,
        spec.seed
    ));
    if !phone_room.join("room.json").is_file() {
        note(&format!("degrading into {}", phone_room.display()));
        crate::degrade::degrade_room(&spec.room, &phone_room, spec.seed, &mut |_, _| {})?;
    }
    let suite = SuiteSpec {
        dirs: Vec::new(),
        cache: spec.cache.clone(),
        training: spec.training.clone(),
        locate: spec.locate.clone().unwrap_or_default(),
        fit: None,
        effect: None,
    };
    let mut trained = |dir: &Path, what: &str| {
        suite_models(&suite, dir, progress, &mut |_, models| {
            note(&format!("{what}: models in {}", models.display()))
        })
    };
    let clean = trained(&spec.room, "room")?;
    let phone = trained(&phone_room, "phone copy")?;
    note("scoring the phone copy's models on the room's views and meshes");
    let models = compare_models(
        [&spec.room, &phone_room],
        &clean.models,
        &phone.models,
        &spec.training,
    )?;
    let locate = match &spec.locate {
        Some(config) => Some(locate_both(
            [(&spec.room, &clean.models), (&phone_room, &phone.models)],
            config,
            note,
        )?),
        None => None,
    };
    let worst = |f: &dyn Fn(&PhoneModelRow) -> Option<f64>| {
        models
            .iter()
            .filter_map(f)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    Ok(PhoneBenchReport {
        room: room.name,
        worst_psnr_loss_db: worst(&|m| Some(m.clean.psnr_db? - m.phone.psnr_db?)),
        worst_exposure_matched_psnr_loss_db: worst(&|m| {
            Some(m.clean.psnr_exposure_matched_db? - m.phone.psnr_exposure_matched_db?)
        }),
        worst_chamfer_increase_mm: worst(&|m| Some(m.phone.chamfer_mm? - m.clean.chamfer_mm?)),
        worst_aligned_psnr_loss_db: worst(&|m| {
            Some(m.clean.psnr_exposure_matched_db? - m.judged().psnr_exposure_matched_db?)
        }),
        worst_aligned_chamfer_increase_mm: worst(&|m| {
            Some(m.judged().chamfer_mm? - m.clean.chamfer_mm?)
        }),
        models,
        locate,
    })
}

/// Locate with the room's models (`rooms[0]`: room folder, model folder) and the phone copy's
/// (`rooms[1]`).
fn locate_both(
    rooms: [(&Path, &Path); 2],
    config: &LocateConfig,
    note: &mut dyn FnMut(&str),
) -> anyhow::Result<PhoneLocate> {
    let mut mean = |(room, models): (&Path, &Path), whose: &str| {
        note(&format!("locating with the {whose} models"));
        bench_locate(room, models, config, None, None, &mut |_| {}).map(|(_, mean)| mean)
    };
    let clean = mean(rooms[0], "room's")?;
    let phone = mean(rooms[1], "phone copy's")?;
    Ok(PhoneLocate {
        iou_loss_points: clean.iou_percent - phone.iou_percent,
        clean,
        phone,
    })
}

/// Every model of the room, trained on it (`clean`) and on the phone copy (`phone`), both scored on
/// the room's held-out views and meshes (the room's models anew, so that both are scored by the same
/// code, whatever version wrote their manifest).
fn compare_models(
    rooms: [&Path; 2],
    clean: &Path,
    phone: &Path,
    training: &SuiteTraining,
) -> anyhow::Result<Vec<PhoneModelRow>> {
    let specs = model_specs(&crate::read_room(rooms[0])?);
    let phone_specs = model_specs(&crate::read_room(rooms[1])?);
    let (clean, phone) = (load_room_models(clean)?, load_room_models(phone)?);
    let config = training.options().config();
    specs
        .iter()
        .zip(&phone_specs)
        .map(|(spec, phone_spec)| {
            let (clean_entry, clean_field) = model_named(&clean, &spec.name)?;
            let (phone_entry, phone_field) = model_named(&phone, &spec.name)?;
            let refined = phone
                .manifest
                .models
                .iter()
                .position(|m| m.name == spec.name)
                .and_then(|k| phone.refined_poses[k].as_ref());
            let truth = read_capture(&spec.capture)?;
            let score = |entry, field, gauge| {
                evaluate_on_capture(spec, entry, field, &config, gauge)
                    .map(|s| HeldOutFigures::of(&s))
            };
            let gauge = refined.and_then(|r| alignment_gauge(&truth, r));
            Ok(PhoneModelRow {
                name: spec.name.clone(),
                clean: score(clean_entry, clean_field, None)?,
                phone: score(phone_entry, phone_field, None)?,
                phone_aligned: gauge
                    .map(|g| score(phone_entry, phone_field, Some(g)))
                    .transpose()?,
                poses: Some(FramePoseErrors::of(
                    &truth,
                    &read_capture(&phone_spec.capture)?,
                    refined,
                )),
            })
        })
        .collect()
}

/// The model named `name` of `models`, with its field.
fn model_named<'a>(
    models: &'a RoomModels,
    name: &str,
) -> anyhow::Result<(&'a ModelEntry, &'a NeusField<f32>)> {
    models
        .manifest
        .models
        .iter()
        .zip(&models.fields)
        .find(|(m, _)| m.name == name)
        .with_context(|| format!("model `{name}` missing from the manifest"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn room(psnr_loss: f64, chamfer: f64, located: Option<[(usize, f64); 2]>) -> PhoneBenchReport {
        let mean = |(panoramas, iou_percent): (usize, f64)| LocateMean {
            panoramas,
            iou_percent,
            ..LocateMean::default()
        };
        PhoneBenchReport {
            room: "room".into(),
            models: Vec::new(),
            worst_psnr_loss_db: psnr_loss,
            worst_exposure_matched_psnr_loss_db: psnr_loss - 1.0,
            worst_chamfer_increase_mm: chamfer,
            worst_aligned_psnr_loss_db: psnr_loss - 1.5,
            worst_aligned_chamfer_increase_mm: chamfer - 1.0,
            locate: located.map(|[clean, phone]| PhoneLocate {
                iou_loss_points: clean.1 - phone.1,
                clean: mean(clean),
                phone: mean(phone),
            }),
        }
    }

    #[test]
    fn several_rooms_give_their_worst_figures_and_locate_over_every_panorama() {
        let summary = PhoneBenchSummary::of(vec![
            room(3.0, 2.0, Some([(4, 80.0), (4, 70.0)])),
            room(2.0, 6.0, Some([(1, 60.0), (1, 60.0)])),
        ]);
        assert_eq!(summary.worst_psnr_loss_db, 3.0);
        assert_eq!(summary.worst_exposure_matched_psnr_loss_db, 2.0);
        assert_eq!(summary.worst_chamfer_increase_mm, 6.0);
        assert_eq!(summary.worst_aligned_psnr_loss_db, 1.5);
        assert_eq!(summary.worst_aligned_chamfer_increase_mm, 5.0);
        let locate = summary.locate.expect("both rooms located");
        assert_eq!(locate.panoramas, 5);
        assert!((locate.clean_iou_percent - 76.0).abs() < 1e-9);
        assert!((locate.phone_iou_percent - 68.0).abs() < 1e-9);
        assert!((locate.iou_loss_points - 8.0).abs() < 1e-9);
        assert_eq!(locate.worst_room_iou_loss_points, 10.0);
        // A room not located leaves no pooled figure.
        let partial = PhoneBenchSummary::of(vec![room(1.0, 1.0, None), room(1.0, 1.0, None)]);
        assert!(partial.locate.is_none());
    }

    /// The tiny room's background capture with every pose moved by `shift` metres along x and
    /// turned by `yaw` radians.
    fn moved_capture(shift: f64, yaw: f64) -> Capture {
        let tiny = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../neuroom-core/tests/rooms/tiny/captures/background");
        let mut capture = read_capture(tiny).unwrap();
        let motion = Pose::from_yaw_translation(yaw, glam::DVec3::new(shift, 0.0, 0.0));
        for f in &mut capture.frames {
            f.camera_to_world = motion.compose(&f.camera_to_world);
        }
        capture
    }

    #[test]
    fn pose_errors_compare_tracked_and_refined_frames_with_the_truth() {
        let truth = moved_capture(0.0, 0.0);
        let phone = moved_capture(0.01, 0.0);
        let refined = RefinedPoses {
            frames: [0, 1]
                .iter()
                .map(|&index| neuroom_core::formats::RefinedFrame {
                    index,
                    image: truth.frames[index].image.clone(),
                    camera_to_world: moved_capture(0.0, 0.5f64.to_radians()).frames[index]
                        .camera_to_world,
                })
                .collect(),
        };
        let errors = FramePoseErrors::of(&truth, &phone, Some(&refined));
        assert_eq!(errors.frames, 2);
        assert!(
            (errors.tracked.position_cm - 1.0).abs() < 1e-9,
            "{errors:?}"
        );
        assert!(errors.tracked.rotation_deg < 1e-6, "{errors:?}");
        let refined = errors.refined.unwrap();
        assert!((refined.rotation_deg - 0.5).abs() < 1e-6, "{errors:?}");
        let untracked = FramePoseErrors::of(&truth, &phone, None);
        assert_eq!(untracked.frames, truth.frames.len());
        assert!(untracked.refined.is_none());
    }

    #[test]
    fn the_gauge_is_the_motion_between_the_truth_and_the_refined_poses() {
        let truth = moved_capture(0.0, 0.0);
        let motion =
            Pose::from_yaw_translation(0.2f64.to_radians(), DVec3::new(0.004, -0.002, 0.001));
        let refined = RefinedPoses {
            frames: truth
                .frames
                .iter()
                .enumerate()
                .map(|(index, f)| neuroom_core::formats::RefinedFrame {
                    index,
                    image: f.image.clone(),
                    camera_to_world: motion.compose(&f.camera_to_world),
                })
                .collect(),
        };
        let gauge = alignment_gauge(&truth, &refined).unwrap();
        let d = gauge.to_mat4() - motion.to_mat4();
        assert!(
            d.to_cols_array().iter().all(|x| x.abs() < 1e-9),
            "{gauge:?}"
        );
    }
}

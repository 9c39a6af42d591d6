//! `neuroom bench phone ROOM`: what phone data costs. The room and its `--phone` copy
//! ([`crate::degrade`]) are trained with the same step budgets; each model trained on the copy is
//! scored on the original's held-out views and ground-truth mesh, and both rooms' models locate the
//! same test panoramas, so every difference is the phone's.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
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
    let models = compare_models(&spec.room, &clean.models, &phone.models, &spec.training)?;
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
    room: &Path,
    clean: &Path,
    phone: &Path,
    training: &SuiteTraining,
) -> anyhow::Result<Vec<PhoneModelRow>> {
    let specs = model_specs(&crate::read_room(room)?);
    let (clean, phone) = (load_room_models(clean)?, load_room_models(phone)?);
    let config = training.options().config();
    specs
        .iter()
        .map(|spec| {
            let (clean_entry, clean_field) = model_named(&clean, &spec.name)?;
            let (phone_entry, phone_field) = model_named(&phone, &spec.name)?;
            let own = evaluate_on_capture(spec, clean_entry, clean_field, &config)?;
            let crossed = evaluate_on_capture(spec, phone_entry, phone_field, &config)?;
            Ok(PhoneModelRow {
                name: spec.name.clone(),
                clean: HeldOutFigures::of(&own),
                phone: HeldOutFigures::of(&crossed),
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
}

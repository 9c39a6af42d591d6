//! `neuroom bench fit`: the holistic fit measured on a room's trained models and its test panoramas.
//!
//! - Poses: for every test panorama with a ground-truth arrangement, initial poses = ground truth +
//!   seeded noise ([`PoseNoise`]), the camera known, then the fit; IoU / ARE / APE before and after, and
//!   with `ablations` the paper's ablation on the same noise.
//! - Light adaptation (the paper's Table 2): at the ground-truth poses, the PSNR of the re-rendered
//!   panorama against the input with no adaptation, tone only, light codes only, both.
//! - Sampling (the pose-convergence half of Table 3): one case fitted with safe-region and with classical
//!   sampling, same noise, rays and iterations.
//! - Timing: 500 iterations of 1024 rays with 5 objects of the trained room.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use glam::Vec3;
use neuroom_core::formats::{Arrangement, Room, read_rgb, read_room};
use neuroom_core::image::RgbImage;
use neuroom_core::metrics::{ArrangementScore, psnr};
use neuroom_field::NeusField;
pub use neuroom_fit::bench::PoseNoise;
use neuroom_fit::bench::{ABLATIONS, BenchObject, run_case};
use neuroom_fit::{AdaptSwitches, FitConfig, Hint, ObjectInit, RoomBox, fit, render_panorama};
use neuroom_render::{Sampling, Scene};
use neuroom_train::RoomModels;
use serde::{Deserialize, Serialize};

use crate::locate::listed_test_panoramas;
use crate::scene::{build_scene, load_models};

/// What `neuroom bench fit` runs.
#[derive(Clone, Debug)]
pub struct FitBench {
    /// Room folder (room.json, `panoramas/*.png` with ground-truth `*.json`).
    pub room: PathBuf,
    /// The room's trained models.
    pub models: PathBuf,
    /// Panorama names (file stems) to run; empty: every panorama with a ground truth.
    pub panoramas: Vec<String>,
    /// Seed of the pose noise (and of the fit's ray sampling).
    pub seed: u64,
    /// The noise added to the ground-truth poses (the issue's: ±25 cm, ±20° yaw, ±5° tilt).
    pub noise: PoseNoise,
    /// The fit's settings for the pose runs.
    pub config: FitConfig,
    /// Run the pose cases (off: only the other sections asked for).
    pub poses: bool,
    /// Run the paper's ablation on the same cases.
    pub ablations: bool,
    /// Run the light-adaptation table, re-rendering at this many rows (`None`: skip it).
    pub light_height: Option<u32>,
    /// Stage-2 iterations of the light-adaptation runs.
    pub light_iterations: usize,
    /// Run safe-region against classical sampling on the first panorama with these rays and pose
    /// iterations (`None`: skip it).
    pub sampling: Option<(usize, usize)>,
    /// Run the timing case: this many pose iterations of 1024 rays with 5 objects (`None`: skip it).
    pub timing_iterations: Option<usize>,
}

/// Mean IoU / ARE / yaw / APE of one arrangement.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Scores {
    /// Mean box IoU, percent.
    pub iou_percent: f64,
    /// Mean geodesic rotation error, degrees.
    pub are_deg: f64,
    /// Mean heading error, degrees.
    pub yaw_deg: f64,
    /// Mean centre distance, centimetres.
    pub ape_cm: f64,
}

impl Scores {
    fn of(s: &ArrangementScore) -> Self {
        Self {
            iou_percent: s.mean_iou_percent.unwrap_or(0.0),
            are_deg: s.mean_rotation_error_deg.unwrap_or(f64::NAN),
            yaw_deg: s.mean_yaw_error_deg.unwrap_or(f64::NAN),
            ape_cm: s.mean_position_error_cm.unwrap_or(f64::NAN),
        }
    }

    fn mean(all: &[Scores]) -> Self {
        let n = all.len().max(1) as f64;
        let sum = |f: fn(&Scores) -> f64| all.iter().map(f).sum::<f64>() / n;
        Self {
            iou_percent: sum(|s| s.iou_percent),
            are_deg: sum(|s| s.are_deg),
            yaw_deg: sum(|s| s.yaw_deg),
            ape_cm: sum(|s| s.ape_cm),
        }
    }
}

/// One fit of one panorama from a noisy start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CaseRow {
    /// `"case"`.
    pub kind: String,
    /// The variant (`complete`, an ablation row, or a sampling).
    pub variant: String,
    /// Panorama file stem.
    pub panorama: String,
    /// Objects fitted (those of the panorama's ground truth).
    pub objects: usize,
    /// Pose iterations and rays per iteration.
    pub pose_iterations: usize,
    /// Rays on the objects per iteration.
    pub rays: usize,
    /// Scores of the noisy start.
    pub before: Scores,
    /// Scores after the fit.
    pub after: Scores,
    /// Wall time of the fit, seconds.
    pub seconds: f64,
    /// Per-object scores after the fit.
    pub after_objects: ArrangementScore,
}

/// The mean over the panoramas of one variant.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeanRow {
    /// `"mean"`.
    pub kind: String,
    /// The variant.
    pub variant: String,
    /// Panoramas averaged.
    pub panoramas: usize,
    /// Mean scores before.
    pub before: Scores,
    /// Mean scores after.
    pub after: Scores,
    /// Mean wall time per fit, seconds.
    pub seconds: f64,
}

/// PSNR of the re-rendered panorama with each kind of light adaptation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LightRow {
    /// `"light"`.
    pub kind: String,
    /// Panorama file stem (or `mean`).
    pub panorama: String,
    /// Rows of the comparison (the input is box-filtered to them).
    pub height: u32,
    /// Stage-2 iterations.
    pub iterations: usize,
    /// PSNR without adaptation, dB.
    pub none_db: f64,
    /// Tone adjusters only.
    pub tone_db: f64,
    /// Light and appearance codes only.
    pub codes_db: f64,
    /// Both.
    pub both_db: f64,
}

/// The timing case.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TimingRow {
    /// `"timing"`.
    pub kind: String,
    /// Panorama file stem.
    pub panorama: String,
    /// Pose iterations.
    pub iterations: usize,
    /// Rays on the objects per iteration (plus the background fraction).
    pub rays: usize,
    /// Objects fitted.
    pub objects: usize,
    /// Worker threads.
    pub threads: usize,
    /// Wall time of the fit (setup and stage 1, no search), seconds.
    pub seconds: f64,
}

/// One line of the benchmark's output.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum FitBenchRow {
    /// A fit.
    Case(CaseRow),
    /// A variant's mean.
    Mean(MeanRow),
    /// Light adaptation.
    Light(LightRow),
    /// Timing.
    Timing(TimingRow),
}

/// A test panorama with its ground truth.
struct TestCase {
    name: String,
    image: RgbImage,
    truth: Arrangement,
}

/// Everything the cases share.
struct Bench {
    room: Room,
    room_box: RoomBox,
    models: RoomModels,
    cases: Vec<TestCase>,
}

/// Runs the benchmark; every finished row goes to `emit` as soon as it exists.
pub fn fit_bench(spec: &FitBench, emit: &mut dyn FnMut(&FitBenchRow)) -> anyhow::Result<()> {
    let bench = Bench::load(spec)?;
    let variants = match (spec.poses, spec.ablations) {
        (false, _) => Vec::new(),
        (true, false) => vec![("complete", spec.config.losses)],
        (true, true) => ABLATIONS.to_vec(),
    };
    for (variant, losses) in variants {
        let config = FitConfig {
            losses,
            ..spec.config
        };
        let mut rows = Vec::new();
        for (k, case) in bench.cases.iter().enumerate() {
            let row = bench.run(case, variant, &config, &spec.noise, case_seed(spec.seed, k))?;
            emit(&FitBenchRow::Case(row.clone()));
            rows.push(row);
        }
        emit(&FitBenchRow::Mean(mean_row(variant, &rows)));
    }
    if let Some(height) = spec.light_height {
        let mut rows = Vec::new();
        for case in &bench.cases {
            let row = bench.light(case, height, spec.light_iterations, &spec.config)?;
            emit(&FitBenchRow::Light(row.clone()));
            rows.push(row);
        }
        emit(&FitBenchRow::Light(mean_light(&rows)));
    }
    if let Some((rays, iterations)) = spec.sampling {
        let case = &bench.cases[0];
        for (variant, sampling) in [
            ("safe-region", Sampling::SAFE_REGION),
            ("classical", Sampling::CLASSICAL),
        ] {
            let mut config = FitConfig {
                rays,
                pose_iterations: iterations,
                ..spec.config
            };
            config.render.sampling = sampling;
            let row = bench.run(case, variant, &config, &spec.noise, case_seed(spec.seed, 0))?;
            emit(&FitBenchRow::Case(row));
        }
    }
    if let Some(iterations) = spec.timing_iterations {
        emit(&FitBenchRow::Timing(bench.timing(
            &bench.cases[0],
            iterations,
            &spec.config,
            &spec.noise,
            spec.seed,
        )?));
    }
    Ok(())
}

/// The noise seed of the `k`-th panorama: the same for every variant of one run.
fn case_seed(seed: u64, k: usize) -> u64 {
    seed.wrapping_mul(1000).wrapping_add(k as u64)
}

impl Bench {
    fn load(spec: &FitBench) -> anyhow::Result<Self> {
        let room = read_room(&spec.room)?;
        let models = load_models(&spec.models)?;
        let room_box = room_box(&room, &models)?;
        let cases = test_cases(&spec.room, &spec.panoramas)?;
        Ok(Self {
            room,
            room_box,
            models,
            cases,
        })
    }

    /// The scene of `truth`'s objects (objects absent from it are not fitted) and their bench entries.
    fn scene(&self, truth: &Arrangement) -> anyhow::Result<(Scene<NeusField>, Vec<BenchObject>)> {
        let scene = build_scene(self.models.clone(), truth)?;
        let objects = truth
            .objects
            .iter()
            .map(|o| {
                let spec = self.room.object_by_id(o.id).with_context(|| {
                    format!("object {} (`{}`) is not in room.json", o.id, o.name)
                })?;
                Ok(BenchObject {
                    truth: ObjectInit {
                        id: o.id,
                        name: o.name.clone(),
                        pose: o.object_to_world,
                        upright: true,
                        hints: spec
                            .relations
                            .iter()
                            .filter_map(|r| Hint::parse(r))
                            .collect(),
                    },
                    model: spec.capture.to_string_lossy().into_owned(),
                    size: spec.size,
                })
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        Ok((scene, objects))
    }

    fn run(
        &self,
        case: &TestCase,
        variant: &str,
        config: &FitConfig,
        noise: &PoseNoise,
        seed: u64,
    ) -> anyhow::Result<CaseRow> {
        let (scene, objects) = self.scene(&case.truth)?;
        let config = FitConfig {
            preview_height: None,
            seed,
            ..*config
        };
        let report = run_case(
            scene,
            &self.room_box,
            &case.image,
            &case.truth.camera_to_world,
            &objects,
            noise,
            seed,
            &config,
        )?;
        Ok(CaseRow {
            kind: "case".into(),
            variant: variant.into(),
            panorama: case.name.clone(),
            objects: report.objects,
            pose_iterations: report.pose_iterations,
            rays: report.rays,
            before: Scores::of(&report.before),
            after: Scores::of(&report.after),
            seconds: report.seconds,
            after_objects: report.after,
        })
    }

    /// Stage 2 alone at the ground-truth poses with each kind of adaptation; PSNR of the re-render.
    fn light(
        &self,
        case: &TestCase,
        height: u32,
        iterations: usize,
        config: &FitConfig,
    ) -> anyhow::Result<LightRow> {
        let target = box_downsample(&case.image, height)
            .with_context(|| format!("panorama {}", case.name))?;
        let psnr_of = |tone: bool, codes: bool| -> anyhow::Result<f64> {
            let (scene, objects) = self.scene(&case.truth)?;
            let config = FitConfig {
                pose_iterations: 0,
                appearance_iterations: if tone || codes { iterations } else { 0 },
                adapt: AdaptSwitches { tone, codes },
                preview_height: None,
                ..*config
            };
            let init: Vec<ObjectInit> = objects.into_iter().map(|o| o.truth).collect();
            let result = fit(
                scene,
                &self.room_box,
                &case.image,
                &case.truth.camera_to_world,
                &init,
                &config,
                &mut |_| {},
            )?;
            let rendered =
                render_panorama(&result.scene, &case.truth.camera_to_world, height, &config);
            Ok(psnr(&rendered, &target))
        };
        Ok(LightRow {
            kind: "light".into(),
            panorama: case.name.clone(),
            height,
            iterations,
            none_db: psnr_of(false, false)?,
            tone_db: psnr_of(true, false)?,
            codes_db: psnr_of(false, true)?,
            both_db: psnr_of(true, true)?,
        })
    }

    /// Stage 1 with the first 5 objects of `case` (1024 rays), timed without the search (the issue's
    /// figure counts the gradient iterations).
    fn timing(
        &self,
        case: &TestCase,
        iterations: usize,
        config: &FitConfig,
        noise: &PoseNoise,
        seed: u64,
    ) -> anyhow::Result<TimingRow> {
        let mut truth = case.truth.clone();
        truth.objects.truncate(5);
        let (scene, objects) = self.scene(&truth)?;
        let config = FitConfig {
            rays: 1024,
            pose_iterations: iterations,
            appearance_iterations: 0,
            preview_height: None,
            search: None,
            ..*config
        };
        let report = run_case(
            scene,
            &self.room_box,
            &case.image,
            &truth.camera_to_world,
            &objects,
            noise,
            seed,
            &config,
        )?;
        Ok(TimingRow {
            kind: "timing".into(),
            panorama: case.name.clone(),
            iterations,
            rays: config.rays,
            objects: report.objects,
            threads: rayon::current_num_threads(),
            seconds: report.seconds,
        })
    }
}

/// The free space: room.json's `room_box` where the room has one (rooms made by `neuroom synth` do),
/// else the models' manifest box.
fn room_box(room: &Room, models: &RoomModels) -> anyhow::Result<RoomBox> {
    #[derive(Deserialize)]
    struct Aabb {
        min: [f32; 3],
        max: [f32; 3],
    }
    if let Some(value) = room.extra.get("room_box") {
        let b: Aabb = serde_json::from_value(value.clone()).with_context(|| {
            format!(
                "{}: `room_box` is not {{min, max}}",
                room.root.join("room.json").display()
            )
        })?;
        return Ok(RoomBox {
            min: Vec3::from(b.min),
            max: Vec3::from(b.max),
        });
    }
    let b = models
        .manifest
        .room_box
        .as_ref()
        .context("neither room.json nor the models' manifest has a room box")?;
    Ok(RoomBox {
        min: Vec3::from(b.min),
        max: Vec3::from(b.max),
    })
}

/// The panoramas of `room/panoramas` with a ground-truth arrangement (as
/// `neuroom::locate::test_panoramas` lists them), sorted by name, or those whose file stems are named.
fn test_cases(room: &Path, names: &[String]) -> anyhow::Result<Vec<TestCase>> {
    let mut cases: Vec<(String, PathBuf, Arrangement)> = listed_test_panoramas(room)?
        .into_iter()
        .map(|(path, truth)| {
            let file = path.file_name().unwrap_or_default().to_string_lossy();
            (crate::inspect::image_stem(&file).to_string(), path, truth)
        })
        .collect();
    for n in names {
        anyhow::ensure!(
            cases.iter().any(|(stem, _, _)| stem == n),
            "{}: no panorama `{n}` (PNG or JPEG) with a ground truth `{n}.json`",
            room.join("panoramas").display()
        );
    }
    if !names.is_empty() {
        cases.retain(|(stem, _, _)| names.contains(stem));
    }
    anyhow::ensure!(
        !cases.is_empty(),
        "{}: no panorama with a ground-truth arrangement",
        room.join("panoramas").display()
    );
    cases
        .into_iter()
        .map(|(name, path, truth)| {
            let image = read_rgb(&path)?.image;
            Ok(TestCase { name, image, truth })
        })
        .collect()
}

/// `image` box-filtered to `height` rows (its height must be a multiple of `height`).
fn box_downsample(image: &RgbImage, height: u32) -> anyhow::Result<RgbImage> {
    anyhow::ensure!(
        height > 0 && image.height.is_multiple_of(height),
        "{} rows cannot be box-filtered to {height}",
        image.height
    );
    let f = image.height / height;
    let mut out = RgbImage::filled(image.width / f, height, [0.0; 3]);
    let norm = 1.0 / (f * f) as f32;
    for v in 0..out.height {
        for u in 0..out.width {
            let mut sum = [0.0f32; 3];
            for dv in 0..f {
                for du in 0..f {
                    let p = image.get(u * f + du, v * f + dv);
                    (0..3).for_each(|c| sum[c] += p[c]);
                }
            }
            out.set(u, v, sum.map(|s| s * norm));
        }
    }
    Ok(out)
}

fn mean_row(variant: &str, rows: &[CaseRow]) -> MeanRow {
    let before: Vec<Scores> = rows.iter().map(|r| r.before).collect();
    let after: Vec<Scores> = rows.iter().map(|r| r.after).collect();
    MeanRow {
        kind: "mean".into(),
        variant: variant.into(),
        panoramas: rows.len(),
        before: Scores::mean(&before),
        after: Scores::mean(&after),
        seconds: rows.iter().map(|r| r.seconds).sum::<f64>() / rows.len().max(1) as f64,
    }
}

fn mean_light(rows: &[LightRow]) -> LightRow {
    let n = rows.len().max(1) as f64;
    let mean = |f: fn(&LightRow) -> f64| rows.iter().map(f).sum::<f64>() / n;
    LightRow {
        kind: "light".into(),
        panorama: "mean".into(),
        height: rows.first().map_or(0, |r| r.height),
        iterations: rows.first().map_or(0, |r| r.iterations),
        none_db: mean(|r| r.none_db),
        tone_db: mean(|r| r.tone_db),
        codes_db: mean(|r| r.codes_db),
        both_db: mean(|r| r.both_db),
    }
}

/// One line of text for a row.
pub fn describe(row: &FitBenchRow) -> String {
    let s = |s: &Scores| {
        format!(
            "IoU {:5.1} %, ARE {:5.2}° (yaw {:5.2}°), APE {:5.2} cm",
            s.iou_percent, s.are_deg, s.yaw_deg, s.ape_cm
        )
    };
    match row {
        FitBenchRow::Case(r) => format!(
            "fit {:<16} {:<14} {} objects, {} its × {} rays: before {} → after {} ({:.1} s)",
            r.variant,
            r.panorama,
            r.objects,
            r.pose_iterations,
            r.rays,
            s(&r.before),
            s(&r.after),
            r.seconds
        ),
        FitBenchRow::Mean(r) => format!(
            "mean {:<16} over {} panoramas: before {} → after {} ({:.1} s per fit)",
            r.variant,
            r.panoramas,
            s(&r.before),
            s(&r.after),
            r.seconds
        ),
        FitBenchRow::Light(r) => format!(
            "light {:<14} {}×{}, {} its: PSNR none {:.2} dB, tone {:.2} dB, codes {:.2} dB, both {:.2} dB",
            r.panorama,
            2 * r.height,
            r.height,
            r.iterations,
            r.none_db,
            r.tone_db,
            r.codes_db,
            r.both_db
        ),
        FitBenchRow::Timing(r) => format!(
            "timing {}: {} pose iterations × {} rays, {} objects, {} threads: {:.1} s",
            r.panorama, r.iterations, r.rays, r.objects, r.threads, r.seconds
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_downsampling_averages_blocks_and_rejects_other_heights() {
        let mut image = RgbImage::filled(4, 2, [0.0; 3]);
        image.set(0, 0, [1.0, 0.0, 0.0]);
        image.set(3, 1, [0.0, 0.0, 0.4]);
        let half = box_downsample(&image, 1).unwrap();
        assert_eq!((half.width, half.height), (2, 1));
        assert_eq!(*half.get(0, 0), [0.25, 0.0, 0.0]);
        assert_eq!(*half.get(1, 0), [0.0, 0.0, 0.1]);
        assert!(box_downsample(&image, 3).is_err());
    }

    #[test]
    fn noise_seeds_differ_per_panorama_and_repeat_per_run() {
        assert_ne!(case_seed(3, 0), case_seed(3, 1));
        assert_eq!(case_seed(3, 1), case_seed(3, 1));
        assert_ne!(case_seed(3, 0), case_seed(4, 0));
    }

    #[test]
    fn missing_panoramas_are_an_error_naming_the_folder() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("panoramas")).unwrap();
        let err = test_cases(dir.path(), &[]).err().unwrap().to_string();
        assert!(err.contains("panoramas"), "{err}");
        let err = test_cases(dir.path(), &["x".into()])
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("`x`"), "{err}");
    }
}

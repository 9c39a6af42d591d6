//! `neuroom eval`: solved arrangements of a room's test panoramas against their ground truth, with the
//! paper's metrics — 3D IoU, rotation and position errors, identification precision and recall, the
//! camera's error, and PSNR / SSIM / LPIPS of the solved scene re-rendered from the panorama camera.

use std::path::{Path, PathBuf};

use neuroom_core::formats::{Arrangement, Room, read_arrangement, read_rgb, read_room};
use neuroom_core::metrics::{ArrangementScore, psnr, rotation_error_deg, ssim};
use neuroom_lpips::Lpips;
use serde::Serialize;

use crate::score::ShapeSymmetries;
use crate::view::{ViewCamera, render_view, solved_scene};

/// How to evaluate.
#[derive(Clone, Debug)]
pub struct EvalOptions {
    /// A room's model folder: with it, every arrangement is re-rendered and compared with its panorama.
    pub models: Option<PathBuf>,
    /// Width of the re-rendered panorama (the input is averaged down to it; it must divide the input's).
    pub render_width: u32,
}

impl Default for EvalOptions {
    fn default() -> Self {
        Self {
            models: None,
            render_width: 512,
        }
    }
}

/// Agreement of the re-rendered panorama with the input.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct ImageScores {
    /// Width the two were compared at.
    pub width: u32,
    /// PSNR, dB.
    pub psnr_db: f64,
    /// SSIM.
    pub ssim: f64,
    /// LPIPS (AlexNet); `None` when its weights are not installed.
    pub lpips: Option<f64>,
}

/// One solved arrangement against its ground truth.
#[derive(Clone, Debug, Serialize)]
pub struct EvalRow {
    /// The solved arrangement file.
    pub arrangement: PathBuf,
    /// The panorama it explains.
    pub panorama: String,
    /// Distance between the solved and the true camera centre, cm.
    pub camera_position_error_cm: f64,
    /// Angle between the solved and the true camera rotation, degrees.
    pub camera_rotation_error_deg: f64,
    /// Identification and pose scores (docs/formats.md metrics).
    pub objects: ArrangementScore,
    /// The re-rendered panorama against the input, when the models were given.
    pub image: Option<ImageScores>,
}

/// Means over the arrangements of one room: the paper's table row.
#[derive(Clone, Debug, Default, Serialize)]
pub struct EvalMean {
    /// The room's name.
    pub room: String,
    /// Arrangements evaluated.
    pub arrangements: usize,
    /// Mean 3D IoU (missed objects count 0), percent.
    pub iou_percent: f64,
    /// Mean rotation error of the found objects, degrees.
    pub are_deg: Option<f64>,
    /// Mean rotation error of the found objects up to their shape symmetry, degrees.
    pub are_up_to_symmetry_deg: Option<f64>,
    /// Mean position error of the found objects, cm.
    pub ape_cm: Option<f64>,
    /// Identification precision.
    pub precision: f64,
    /// Identification recall.
    pub recall: f64,
    /// Mean camera position error, cm.
    pub camera_position_error_cm: f64,
    /// Mean camera rotation error, degrees.
    pub camera_rotation_error_deg: f64,
    /// Mean PSNR of the re-rendered panoramas, dB.
    pub psnr_db: Option<f64>,
    /// Mean SSIM.
    pub ssim: Option<f64>,
    /// Mean LPIPS.
    pub lpips: Option<f64>,
}

/// Everything `neuroom eval` measured.
#[derive(Clone, Debug, Serialize)]
pub struct Evaluation {
    /// One row per arrangement, in the order given.
    pub rows: Vec<EvalRow>,
    /// Their means.
    pub mean: EvalMean,
    /// Why LPIPS is missing, when it is.
    pub lpips_unavailable: Option<String>,
}

/// Evaluates solved `arrangements` of the room at `room`. Each arrangement's `image` names its panorama;
/// the ground truth is the arrangement JSON beside that panorama in `room/panoramas/`. `progress` names
/// each arrangement as it starts.
pub fn evaluate(
    room: &Path,
    arrangements: &[PathBuf],
    options: &EvalOptions,
    progress: &mut dyn FnMut(&Path),
) -> anyhow::Result<Evaluation> {
    let room_json = read_room(room.join("room.json"))?;
    let symmetries = ShapeSymmetries::of_room(&room_json)?;
    let (lpips, lpips_unavailable) = match options.models {
        Some(_) => match Lpips::load_default() {
            Ok(l) => (Some(l), None),
            Err(e) => (None, Some(e.to_string())),
        },
        None => (None, Some("no models given, nothing re-rendered".into())),
    };
    let mut rows = Vec::new();
    for path in arrangements {
        progress(path);
        rows.push(evaluate_one(
            room,
            (&room_json, &symmetries),
            path,
            options,
            lpips.as_ref(),
        )?);
    }
    let mean = mean_row(&room_json.name, &rows);
    Ok(Evaluation {
        rows,
        mean,
        lpips_unavailable,
    })
}

/// The panorama and ground truth an arrangement names, in the room's `panoramas/`.
fn ground_truth(
    room: &Path,
    path: &Path,
    solved: &Arrangement,
) -> anyhow::Result<(PathBuf, Arrangement)> {
    anyhow::ensure!(
        !solved.image.is_empty(),
        "{}: names no panorama (`image`), so its ground truth cannot be found",
        path.display()
    );
    let panorama = room.join("panoramas").join(&solved.image);
    let truth = panorama.with_extension("json");
    anyhow::ensure!(
        truth.is_file(),
        "{}: its panorama `{}` has no ground truth {} in this room",
        path.display(),
        solved.image,
        truth.display()
    );
    Ok((panorama, read_arrangement(&truth)?))
}

fn evaluate_one(
    room: &Path,
    (room_json, symmetries): (&Room, &ShapeSymmetries),
    path: &Path,
    options: &EvalOptions,
    lpips: Option<&Lpips>,
) -> anyhow::Result<EvalRow> {
    let solved = read_arrangement(path)?;
    let (panorama, truth) = ground_truth(room, path, &solved)?;
    let image = match &options.models {
        Some(models) => Some(image_scores(
            models,
            path,
            &panorama,
            options.render_width,
            lpips,
        )?),
        None => None,
    };
    Ok(EvalRow {
        arrangement: path.to_path_buf(),
        panorama: solved.image.clone(),
        camera_position_error_cm: 100.0
            * solved
                .camera_to_world
                .translation
                .distance(truth.camera_to_world.translation),
        camera_rotation_error_deg: rotation_error_deg(
            truth.camera_to_world.rotation,
            solved.camera_to_world.rotation,
        ),
        objects: crate::score::score_in_room(room_json, symmetries, &truth, &solved),
        image,
    })
}

/// Re-renders the solved scene from its panorama camera and compares it with the input.
fn image_scores(
    models: &Path,
    arrangement: &Path,
    panorama: &Path,
    width: u32,
    lpips: Option<&Lpips>,
) -> anyhow::Result<ImageScores> {
    let input = read_rgb(panorama)?.image;
    let width = width.min(input.width);
    let input = input.box_downsample(width, width / 2).ok_or_else(|| {
        anyhow::anyhow!(
            "{}: its width {} is not a multiple of the render width {width}",
            panorama.display(),
            input.width
        )
    })?;
    let scene = solved_scene(models, arrangement)?;
    let render = render_view(&scene, &ViewCamera::Panorama { width })?.rgb;
    // AlexNet needs a few dozen pixels a side: smaller comparisons go without LPIPS.
    let lpips = lpips
        .filter(|_| render.height >= neuroom_lpips::MIN_SIDE)
        .map(|l| l.distance(&input, &render))
        .transpose()
        .map_err(|e| anyhow::anyhow!("{}: LPIPS: {e}", panorama.display()))?;
    Ok(ImageScores {
        width,
        psnr_db: psnr(&input, &render),
        ssim: ssim(&input, &render),
        lpips,
    })
}

/// Mean of `f` over the rows where it is known.
fn mean_of(rows: &[EvalRow], f: impl Fn(&EvalRow) -> Option<f64>) -> Option<f64> {
    let values: Vec<f64> = rows.iter().filter_map(f).collect();
    (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
}

fn mean_row(room: &str, rows: &[EvalRow]) -> EvalMean {
    let all = |f: &dyn Fn(&EvalRow) -> f64| mean_of(rows, |r| Some(f(r))).unwrap_or(0.0);
    EvalMean {
        room: room.to_string(),
        arrangements: rows.len(),
        iou_percent: all(&|r| r.objects.mean_iou_percent.unwrap_or(0.0)),
        are_deg: mean_of(rows, |r| r.objects.mean_rotation_error_deg),
        are_up_to_symmetry_deg: mean_of(rows, |r| r.objects.mean_rotation_error_up_to_symmetry_deg),
        ape_cm: mean_of(rows, |r| r.objects.mean_position_error_cm),
        precision: all(&|r| r.objects.precision),
        recall: all(&|r| r.objects.recall),
        camera_position_error_cm: all(&|r| r.camera_position_error_cm),
        camera_rotation_error_deg: all(&|r| r.camera_rotation_error_deg),
        psnr_db: mean_of(rows, |r| r.image.map(|i| i.psnr_db)),
        ssim: mean_of(rows, |r| r.image.map(|i| i.ssim)),
        lpips: mean_of(rows, |r| r.image.and_then(|i| i.lpips)),
    }
}

fn cell(v: Option<f64>, digits: usize) -> String {
    v.map_or("–".into(), |x| format!("{x:.digits$}"))
}

/// The paper's table as text: one line per arrangement, then the room's mean. Beside ARE, the rotation
/// error up to each object's shape symmetry (`ARE sym`).
pub fn table(evaluation: &Evaluation) -> String {
    let mut out = format!(
        "{:<28} {:>6} {:>7} {:>7} {:>7} {:>5} {:>5} {:>8} {:>7} {:>6} {:>6} {:>6}\n",
        "panorama",
        "IoU %",
        "ARE °",
        "ARE sym",
        "APE cm",
        "P %",
        "R %",
        "cam cm",
        "cam °",
        "PSNR",
        "SSIM",
        "LPIPS"
    );
    for r in &evaluation.rows {
        let o = &r.objects;
        out += &line(
            &r.panorama,
            o.mean_iou_percent.unwrap_or(0.0),
            [
                o.mean_rotation_error_deg,
                o.mean_rotation_error_up_to_symmetry_deg,
            ],
            o.mean_position_error_cm,
            (o.precision, o.recall),
            (r.camera_position_error_cm, r.camera_rotation_error_deg),
            [
                r.image.map(|i| i.psnr_db),
                r.image.map(|i| i.ssim),
                r.image.and_then(|i| i.lpips),
            ],
        );
    }
    let m = &evaluation.mean;
    out += &line(
        &format!("{} (mean of {})", m.room, m.arrangements),
        m.iou_percent,
        [m.are_deg, m.are_up_to_symmetry_deg],
        m.ape_cm,
        (m.precision, m.recall),
        (m.camera_position_error_cm, m.camera_rotation_error_deg),
        [m.psnr_db, m.ssim, m.lpips],
    );
    if let Some(why) = &evaluation.lpips_unavailable {
        out += &format!("LPIPS not measured: {why}\n");
    }
    out
}

fn line(
    name: &str,
    iou: f64,
    [are, are_symmetric]: [Option<f64>; 2],
    ape: Option<f64>,
    (precision, recall): (f64, f64),
    (cam_cm, cam_deg): (f64, f64),
    [psnr, ssim, lpips]: [Option<f64>; 3],
) -> String {
    format!(
        "{:<28} {:>6.1} {:>7} {:>7} {:>7} {:>5.0} {:>5.0} {:>8.1} {:>7.2} {:>6} {:>6} {:>6}\n",
        name,
        iou,
        cell(are, 1),
        cell(are_symmetric, 1),
        cell(ape, 1),
        100.0 * precision,
        100.0 * recall,
        cam_cm,
        cam_deg,
        cell(psnr, 2),
        cell(ssim, 3),
        cell(lpips, 3),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use neuroom_core::formats::{write_arrangement, write_rgb};
    use neuroom_testing::{TINY_ROOM_JSON, tiny_arrangement, write_tiny_models};

    /// A room folder whose only test panorama is the tiny models rendered at the truth, and the models.
    fn tiny_room(dir: &Path) -> (PathBuf, PathBuf) {
        let (room, models) = (dir.join("room"), dir.join("models"));
        std::fs::create_dir_all(room.join("panoramas")).unwrap();
        std::fs::write(room.join("room.json"), TINY_ROOM_JSON).unwrap();
        write_tiny_models(&models).unwrap();
        let truth = room.join("panoramas/tiny.json");
        write_arrangement(&truth, &tiny_arrangement()).unwrap();
        let view =
            crate::view::render_arrangement(&models, &truth, &ViewCamera::Panorama { width: 64 });
        write_rgb(room.join("panoramas/tiny.png"), &view.unwrap().rgb).unwrap();
        (room, models)
    }

    #[test]
    fn scores_a_solved_arrangement_against_the_truth_beside_its_panorama() {
        let dir = tempfile::tempdir().unwrap();
        let (room, models) = tiny_room(dir.path());
        let exact = dir.path().join("exact.json");
        write_arrangement(&exact, &tiny_arrangement()).unwrap();
        let mut moved = tiny_arrangement();
        moved.objects[0].object_to_world.translation += DVec3::new(0.05, 0.0, 0.0);
        moved.objects.pop();
        let off = dir.path().join("off.json");
        write_arrangement(&off, &moved).unwrap();
        let options = EvalOptions {
            models: Some(models),
            render_width: 64,
        };
        let mut seen = 0;
        let e = evaluate(&room, &[exact, off], &options, &mut |_| seen += 1).unwrap();
        assert_eq!(seen, 2);
        let (a, b) = (&e.rows[0], &e.rows[1]);
        assert_eq!(a.objects.recall, 1.0);
        assert!(a.objects.mean_iou_percent.unwrap() > 99.9);
        assert!(a.camera_position_error_cm < 1e-9);
        assert!((b.objects.recall - 2.0 / 3.0).abs() < 1e-12);
        assert_eq!(b.objects.precision, 1.0);
        let ape = b.objects.mean_position_error_cm.unwrap();
        assert!((ape - 2.5).abs() < 1e-6, "5 cm and 0 cm: {ape}");
        let (ia, ib) = (a.image.unwrap(), b.image.unwrap());
        assert_eq!(ia.width, 64);
        assert!(ia.psnr_db > ib.psnr_db + 3.0, "{ia:?} vs {ib:?}");
        assert!(ia.ssim > ib.ssim);
        // LPIPS where its weights are installed (`tools/setup_lpips.py`).
        if e.lpips_unavailable.is_none() {
            assert!(ia.lpips.unwrap() < ib.lpips.unwrap(), "{ia:?} vs {ib:?}");
        }
        assert_eq!(e.mean.arrangements, 2);
        assert!((e.mean.recall - (1.0 + 2.0 / 3.0) / 2.0).abs() < 1e-12);
        let text = table(&e);
        assert_eq!(text.lines().filter(|l| l.contains("tiny.png")).count(), 2);
        assert!(text.contains("tiny (mean of 2)"));
    }

    #[test]
    fn an_arrangement_without_ground_truth_is_named_in_the_error() {
        let dir = tempfile::tempdir().unwrap();
        let (room, _) = tiny_room(dir.path());
        let mut other = tiny_arrangement();
        other.image = "elsewhere.png".into();
        let path = dir.path().join("other.json");
        write_arrangement(&path, &other).unwrap();
        let err = evaluate(&room, &[path], &EvalOptions::default(), &mut |_| {}).unwrap_err();
        let msg = format!("{err:#}");
        assert!(
            msg.contains("other.json") && msg.contains("elsewhere.png"),
            "{msg}"
        );
    }
}

//! The metrics of docs/formats.md: box IoU, rotation (ARE) and position (APE) errors, identification precision
//! and recall for a whole arrangement, and PSNR / SSIM for images; beside ARE, the rotation error up to
//! the turns an object's shape does not show (a vase has no heading to find).

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

use crate::image::{Image, RgbImage};
use crate::obb::OrientedBox;
use crate::pose::Pose;

/// Volume IoU of two oriented boxes, in percent.
pub fn iou_percent(gt: &OrientedBox, predicted: &OrientedBox) -> f64 {
    100.0 * gt.iou(predicted)
}

/// Geodesic angle between two rotations, degrees: arccos((tr(Rgtᵀ R) − 1) / 2), the argument clamped to
/// [−1, 1] so that rounding never yields NaN.
pub fn rotation_error_deg(r_gt: DMat3, r: DMat3) -> f64 {
    let trace: f64 = (0..3).map(|i| r_gt.col(i).dot(r.col(i))).sum();
    ((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees()
}

/// Which turns about an object's up axis (+z of its canonical frame) leave its shape unchanged: headings
/// that differ by such a turn look alike, so no image can tell them apart.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Symmetry {
    /// Only the full turn: every heading shows.
    #[default]
    None,
    /// Every multiple of a full turn / n, n ≥ 2 (a four-legged table: 2; a square stool: 4).
    Turns(u32),
    /// Every turn (a body of revolution: a round lamp, a vase).
    Continuous,
}

/// The geodesic rotation error up to `symmetry`, degrees: the least [`rotation_error_deg`] between `r`
/// and `r_gt` composed with any turn of the symmetry about the object's up axis. For a continuous
/// symmetry that is the angle between the two up axes.
pub fn rotation_error_up_to_symmetry_deg(r_gt: DMat3, r: DMat3, symmetry: Symmetry) -> f64 {
    match symmetry {
        Symmetry::None => rotation_error_deg(r_gt, r),
        Symmetry::Turns(n) => (0..n.max(1))
            .map(|k| {
                let turn = std::f64::consts::TAU * f64::from(k) / f64::from(n);
                rotation_error_deg(r_gt * DMat3::from_rotation_z(turn), r)
            })
            .fold(f64::INFINITY, f64::min),
        Symmetry::Continuous => r_gt
            .z_axis
            .dot(r.z_axis)
            .clamp(-1.0, 1.0)
            .acos()
            .to_degrees(),
    }
}

/// Difference of the headings about +z (of each rotated +x axis, the object's front), degrees in [0, 180].
pub fn yaw_error_deg(r_gt: DMat3, r: DMat3) -> f64 {
    let heading = |m: DMat3| m.x_axis.y.atan2(m.x_axis.x);
    let d = (heading(r) - heading(r_gt)).rem_euclid(std::f64::consts::TAU);
    d.min(std::f64::consts::TAU - d).to_degrees()
}

/// Distance between two box centres, centimetres.
pub fn position_error_cm(gt: DVec3, predicted: DVec3) -> f64 {
    100.0 * gt.distance(predicted)
}

/// A ground-truth object of a panorama, for [`evaluate_arrangement`].
#[derive(Clone, Debug, PartialEq)]
pub struct GtObject {
    /// The object id of room.json.
    pub id: u16,
    /// What identifies the object's model: objects with equal keys (e.g. the same capture path) are
    /// interchangeable instances and are matched to predictions by position.
    pub model: String,
    /// Full extents of its bounding box, metres.
    pub size: DVec3,
    /// Its true pose.
    pub object_to_world: Pose,
    /// The turns its shape does not show (see [`rotation_error_up_to_symmetry_deg`]).
    pub symmetry: Symmetry,
}

/// A predicted object of a panorama, for [`evaluate_arrangement`].
#[derive(Clone, Debug, PartialEq)]
pub struct PredictedObject {
    /// The object id the prediction claims.
    pub id: u16,
    /// The predicted pose (placing the ground-truth size).
    pub object_to_world: Pose,
}

/// The scores of one ground-truth object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectScore {
    /// The ground-truth id.
    pub id: u16,
    /// The id of the prediction matched to it (another instance of the same model may take its place);
    /// `None` when the object was missed.
    pub predicted_id: Option<u16>,
    /// Box IoU in percent; 0 when missed.
    pub iou_percent: f64,
    /// Geodesic rotation error, degrees; `None` when missed.
    pub rotation_error_deg: Option<f64>,
    /// The rotation error up to the object's shape symmetry, degrees; `None` when missed.
    #[serde(default)]
    pub rotation_error_up_to_symmetry_deg: Option<f64>,
    /// Heading error about +z, degrees; `None` when missed.
    pub yaw_error_deg: Option<f64>,
    /// Centre distance, centimetres; `None` when missed.
    pub position_error_cm: Option<f64>,
}

/// The scores of a predicted arrangement against the ground truth.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ArrangementScore {
    /// One row per ground-truth object, in the order given.
    pub objects: Vec<ObjectScore>,
    /// Mean IoU over all ground-truth objects (missed ones count 0), percent; `None` without objects.
    pub mean_iou_percent: Option<f64>,
    /// Mean rotation error over the found objects (ARE), degrees; `None` when none was found.
    pub mean_rotation_error_deg: Option<f64>,
    /// Mean rotation error up to each object's shape symmetry over the found objects, degrees.
    #[serde(default)]
    pub mean_rotation_error_up_to_symmetry_deg: Option<f64>,
    /// Mean heading error over the found objects, degrees; `None` when none was found.
    pub mean_yaw_error_deg: Option<f64>,
    /// Mean centre distance over the found objects (APE), centimetres; `None` when none was found.
    pub mean_position_error_cm: Option<f64>,
    /// Share of the ground-truth objects found within [`PLACED_WITHIN_CM`] of where they stand (missed
    /// ones count as not placed), in [0, 1]; 1 without objects. Unlike precision, which counts
    /// identities, an object named right and placed across the room does not count.
    #[serde(default)]
    pub placed_share: f64,
    /// Number of ground-truth objects without a matching prediction.
    pub missed: usize,
    /// Matched predictions over all predictions (1 when nothing was predicted).
    pub precision: f64,
    /// Matched ground-truth objects over all of them (1 when there are none).
    pub recall: f64,
}

/// How close to its true centre an object must be found to count as placed ([`ArrangementScore::placed_share`]),
/// centimetres: a robot reaching for it or an editor moving it can still tell which object it is.
pub const PLACED_WITHIN_CM: f64 = 20.0;

/// Scores a predicted arrangement: predictions are matched to ground-truth objects of the same model
/// (the model of the ground-truth object carrying the predicted id), by an optimal assignment on centre
/// distance among interchangeable instances, so a swap of two identical chairs costs nothing. Predictions
/// with an id absent from the ground truth, or in excess of a model's instances, are false positives.
pub fn evaluate_arrangement(gt: &[GtObject], predicted: &[PredictedObject]) -> ArrangementScore {
    let mut matched: Vec<Option<usize>> = vec![None; gt.len()];
    let mut models: Vec<&str> = gt.iter().map(|g| g.model.as_str()).collect();
    models.sort_unstable();
    models.dedup();
    for model in models {
        let gts: Vec<usize> = (0..gt.len()).filter(|&i| gt[i].model == model).collect();
        let preds: Vec<usize> = (0..predicted.len())
            .filter(|&j| gts.iter().any(|&i| gt[i].id == predicted[j].id))
            .collect();
        let cost: Vec<Vec<f64>> = gts
            .iter()
            .map(|&i| {
                let c = gt[i].object_to_world.translation;
                preds
                    .iter()
                    .map(|&j| c.distance(predicted[j].object_to_world.translation))
                    .collect()
            })
            .collect();
        for (row, col) in min_cost_assignment(&cost).into_iter().enumerate() {
            matched[gts[row]] = col.map(|c| preds[c]);
        }
    }
    let objects: Vec<ObjectScore> = gt
        .iter()
        .zip(&matched)
        .map(|(g, m)| score_object(g, m.map(|j| &predicted[j])))
        .collect();
    summarize(objects, predicted.len())
}

/// The row of one ground-truth object and its matched prediction, if any.
fn score_object(gt: &GtObject, predicted: Option<&PredictedObject>) -> ObjectScore {
    let Some(p) = predicted else {
        return ObjectScore {
            id: gt.id,
            predicted_id: None,
            iou_percent: 0.0,
            rotation_error_deg: None,
            rotation_error_up_to_symmetry_deg: None,
            yaw_error_deg: None,
            position_error_cm: None,
        };
    };
    let (r_gt, r) = (gt.object_to_world.rotation, p.object_to_world.rotation);
    ObjectScore {
        id: gt.id,
        predicted_id: Some(p.id),
        iou_percent: iou_percent(
            &OrientedBox::new(gt.object_to_world, gt.size),
            &OrientedBox::new(p.object_to_world, gt.size),
        ),
        rotation_error_deg: Some(rotation_error_deg(r_gt, r)),
        rotation_error_up_to_symmetry_deg: Some(rotation_error_up_to_symmetry_deg(
            r_gt,
            r,
            gt.symmetry,
        )),
        yaw_error_deg: Some(yaw_error_deg(r_gt, r)),
        position_error_cm: Some(position_error_cm(
            gt.object_to_world.translation,
            p.object_to_world.translation,
        )),
    }
}

/// Means, miss count, precision and recall from the per-object rows.
fn summarize(objects: Vec<ObjectScore>, predicted_count: usize) -> ArrangementScore {
    let found = objects.iter().filter(|o| o.predicted_id.is_some()).count();
    let mean = |values: Vec<f64>| {
        (!values.is_empty()).then(|| values.iter().sum::<f64>() / values.len() as f64)
    };
    ArrangementScore {
        mean_iou_percent: mean(objects.iter().map(|o| o.iou_percent).collect()),
        mean_rotation_error_deg: mean(
            objects
                .iter()
                .filter_map(|o| o.rotation_error_deg)
                .collect(),
        ),
        mean_rotation_error_up_to_symmetry_deg: mean(
            objects
                .iter()
                .filter_map(|o| o.rotation_error_up_to_symmetry_deg)
                .collect(),
        ),
        mean_yaw_error_deg: mean(objects.iter().filter_map(|o| o.yaw_error_deg).collect()),
        mean_position_error_cm: mean(objects.iter().filter_map(|o| o.position_error_cm).collect()),
        placed_share: if objects.is_empty() {
            1.0
        } else {
            objects
                .iter()
                .filter(|o| o.position_error_cm.is_some_and(|d| d <= PLACED_WITHIN_CM))
                .count() as f64
                / objects.len() as f64
        },
        missed: objects.len() - found,
        precision: if predicted_count == 0 {
            1.0
        } else {
            found as f64 / predicted_count as f64
        },
        recall: if objects.is_empty() {
            1.0
        } else {
            found as f64 / objects.len() as f64
        },
        objects,
    }
}

/// Minimum-cost assignment of rows to columns of a rectangular cost matrix (Hungarian method with
/// potentials, O(n²m)). Returns, for each row, its column; as many rows as possible are assigned
/// (all of them when there are at least as many columns), each column at most once.
pub fn min_cost_assignment(cost: &[Vec<f64>]) -> Vec<Option<usize>> {
    let rows = cost.len();
    let cols = cost.first().map_or(0, Vec::len);
    if rows == 0 || cols == 0 {
        return vec![None; rows];
    }
    if rows > cols {
        let transposed: Vec<Vec<f64>> = (0..cols)
            .map(|c| (0..rows).map(|r| cost[r][c]).collect())
            .collect();
        let mut out = vec![None; rows];
        for (c, r) in min_cost_assignment(&transposed).into_iter().enumerate() {
            if let Some(r) = r {
                out[r] = Some(c);
            }
        }
        return out;
    }
    let row_of_col = hungarian(cost, rows, cols);
    let mut out = vec![None; rows];
    for (c, r) in row_of_col.iter().enumerate().skip(1) {
        if *r > 0 {
            out[r - 1] = Some(c - 1);
        }
    }
    out
}

/// The Hungarian method for `rows ≤ cols`: shortest augmenting paths over reduced costs, one row at a
/// time. Indices are 1-based with 0 as a sentinel; returns the row (0 = none) matched to each column.
fn hungarian(cost: &[Vec<f64>], rows: usize, cols: usize) -> Vec<usize> {
    let (mut row_pot, mut col_pot) = (vec![0.0; rows + 1], vec![0.0; cols + 1]);
    let mut row_of_col = vec![0usize; cols + 1];
    let mut came_from = vec![0usize; cols + 1];
    for row in 1..=rows {
        row_of_col[0] = row;
        let mut col = 0;
        let mut slack = vec![f64::INFINITY; cols + 1];
        let mut visited = vec![false; cols + 1];
        while row_of_col[col] != 0 {
            visited[col] = true;
            let r = row_of_col[col];
            let (mut delta, mut next) = (f64::INFINITY, 0);
            for c in 1..=cols {
                if visited[c] {
                    continue;
                }
                let reduced = cost[r - 1][c - 1] - row_pot[r] - col_pot[c];
                if reduced < slack[c] {
                    slack[c] = reduced;
                    came_from[c] = col;
                }
                if slack[c] < delta {
                    delta = slack[c];
                    next = c;
                }
            }
            for c in 0..=cols {
                if visited[c] {
                    row_pot[row_of_col[c]] += delta;
                    col_pot[c] -= delta;
                } else {
                    slack[c] -= delta;
                }
            }
            col = next;
        }
        while col != 0 {
            let prev = came_from[col];
            row_of_col[col] = row_of_col[prev];
            col = prev;
        }
    }
    row_of_col
}

/// Panics with a clear message when two images differ in size.
fn assert_same_size<A, B>(a: &Image<A>, b: &Image<B>) {
    assert!(
        a.width == b.width && a.height == b.height,
        "images differ in size: {}×{} and {}×{}",
        a.width,
        a.height,
        b.width,
        b.height
    );
}

/// Peak signal-to-noise ratio of two sRGB images in [0, 1], dB: 10·log10(1 / MSE) over all pixels and
/// channels; infinite for identical images. Panics if the sizes differ.
pub fn psnr(a: &RgbImage, b: &RgbImage) -> f64 {
    assert_same_size(a, b);
    psnr_of(a.data.iter().zip(&b.data))
}

/// PSNR over the pixels where `mask` is true only (e.g. an object's silhouette); `None` when the mask is
/// empty. Panics if the sizes differ.
pub fn psnr_masked(a: &RgbImage, b: &RgbImage, mask: &Image<bool>) -> Option<f64> {
    assert_same_size(a, b);
    assert_same_size(a, mask);
    let pairs = a
        .data
        .iter()
        .zip(&b.data)
        .zip(&mask.data)
        .filter(|(_, m)| **m)
        .map(|(p, _)| p);
    mask.data.iter().any(|m| *m).then(|| psnr_of(pairs))
}

/// PSNR of pixel pairs, peak 1.
fn psnr_of<'a>(pairs: impl Iterator<Item = (&'a [f32; 3], &'a [f32; 3])>) -> f64 {
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (p, q) in pairs {
        for c in 0..3 {
            let d = p[c] as f64 - q[c] as f64;
            sum += d * d;
        }
        count += 3;
    }
    -10.0 * (sum / count as f64).log10()
}

/// Side of the SSIM window; its Gaussian has σ = [`SSIM_SIGMA`].
const SSIM_WINDOW: usize = 11;
/// Standard deviation of the SSIM Gaussian window, pixels.
const SSIM_SIGMA: f64 = 1.5;
/// SSIM stabilisers for a data range of 1: C1 = (0.01)², C2 = (0.03)².
const SSIM_C1: f64 = 0.01 * 0.01;
/// See [`SSIM_C1`].
const SSIM_C2: f64 = 0.03 * 0.03;

/// Structural similarity of two sRGB images in [0, 1] (Wang et al. 2004), the standard definition of
/// `pytorch-msssim` and of skimage with `gaussian_weights=True, sigma=1.5, use_sample_covariance=False`:
/// local statistics under a normalised 11×11 Gaussian window (σ 1.5), evaluated only where the window
/// fits inside the image ("valid" convolution), averaged over those positions and then over the channels.
/// Panics if the sizes differ or the image is smaller than 11×11.
pub fn ssim(a: &RgbImage, b: &RgbImage) -> f64 {
    assert_same_size(a, b);
    assert!(
        a.width as usize >= SSIM_WINDOW && a.height as usize >= SSIM_WINDOW,
        "SSIM needs images of at least {SSIM_WINDOW}×{SSIM_WINDOW} pixels, found {}×{}",
        a.width,
        a.height
    );
    let kernel = gaussian_kernel();
    let (w, h) = (a.width as usize, a.height as usize);
    let channel_means: Vec<f64> = (0..3)
        .map(|c| {
            let x: Vec<f64> = a.data.iter().map(|p| p[c] as f64).collect();
            let y: Vec<f64> = b.data.iter().map(|p| p[c] as f64).collect();
            ssim_channel(&x, &y, w, h, &kernel)
        })
        .collect();
    channel_means.iter().sum::<f64>() / 3.0
}

/// The normalised 1D Gaussian window.
fn gaussian_kernel() -> [f64; SSIM_WINDOW] {
    let centre = (SSIM_WINDOW / 2) as f64;
    let raw: [f64; SSIM_WINDOW] = std::array::from_fn(|i| {
        (-(i as f64 - centre).powi(2) / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp()
    });
    let total: f64 = raw.iter().sum();
    raw.map(|k| k / total)
}

/// Mean SSIM of one channel (row-major `w × h` planes).
fn ssim_channel(x: &[f64], y: &[f64], w: usize, h: usize, kernel: &[f64; SSIM_WINDOW]) -> f64 {
    let product = |f: &dyn Fn(usize) -> f64| -> Vec<f64> { (0..x.len()).map(f).collect() };
    let mu_x = filter_valid(x, w, h, kernel);
    let mu_y = filter_valid(y, w, h, kernel);
    let xx = filter_valid(&product(&|i| x[i] * x[i]), w, h, kernel);
    let yy = filter_valid(&product(&|i| y[i] * y[i]), w, h, kernel);
    let xy = filter_valid(&product(&|i| x[i] * y[i]), w, h, kernel);
    let total: f64 = (0..mu_x.len())
        .map(|i| {
            let (mx, my) = (mu_x[i], mu_y[i]);
            let (vx, vy, cov) = (xx[i] - mx * mx, yy[i] - my * my, xy[i] - mx * my);
            ((2.0 * mx * my + SSIM_C1) * (2.0 * cov + SSIM_C2))
                / ((mx * mx + my * my + SSIM_C1) * (vx + vy + SSIM_C2))
        })
        .sum();
    total / mu_x.len() as f64
}

/// Separable Gaussian filtering keeping only the positions where the whole window fits:
/// a `(w − 10) × (h − 10)` row-major result.
fn filter_valid(plane: &[f64], w: usize, h: usize, kernel: &[f64; SSIM_WINDOW]) -> Vec<f64> {
    let (ow, oh) = (w + 1 - SSIM_WINDOW, h + 1 - SSIM_WINDOW);
    let mut rows = vec![0.0; ow * h];
    for r in 0..h {
        for c in 0..ow {
            rows[r * ow + c] = kernel
                .iter()
                .enumerate()
                .map(|(k, wk)| wk * plane[r * w + c + k])
                .sum();
        }
    }
    let mut out = vec![0.0; ow * oh];
    for r in 0..oh {
        for c in 0..ow {
            out[r * ow + c] = kernel
                .iter()
                .enumerate()
                .map(|(k, wk)| wk * rows[(r + k) * ow + c])
                .sum();
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn pose(yaw_deg: f64, x: f64, y: f64) -> Pose {
        Pose::from_yaw_translation(yaw_deg.to_radians(), DVec3::new(x, y, 0.5))
    }

    fn gt(id: u16, model: &str, p: Pose) -> GtObject {
        GtObject {
            id,
            model: model.into(),
            size: DVec3::new(1.0, 0.5, 1.0),
            object_to_world: p,
            symmetry: Symmetry::None,
        }
    }

    #[test]
    fn rotation_error_up_to_symmetry_leaves_out_the_turns_the_shape_does_not_show() {
        let turn = |deg: f64| DMat3::from_rotation_z(deg.to_radians());
        let tilt = DMat3::from_rotation_x(0.1);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-9;
        // No symmetry: the plain geodesic error.
        assert!(close(
            rotation_error_up_to_symmetry_deg(turn(30.0), turn(200.0), Symmetry::None),
            170.0
        ));
        // A half-turn symmetry folds 170° onto 10°, and leaves a 60° error at 60°.
        let half = Symmetry::Turns(2);
        assert!(close(
            rotation_error_up_to_symmetry_deg(turn(30.0), turn(200.0), half),
            10.0
        ));
        assert!(close(
            rotation_error_up_to_symmetry_deg(turn(0.0), turn(60.0), half),
            60.0
        ));
        // Four turns: 100° is 10° from the nearest quarter turn.
        assert!(close(
            rotation_error_up_to_symmetry_deg(turn(0.0), turn(100.0), Symmetry::Turns(4)),
            10.0
        ));
        // A body of revolution has no heading: any turn costs nothing, a tilt still does.
        assert!(close(
            rotation_error_up_to_symmetry_deg(turn(10.0), turn(137.0), Symmetry::Continuous),
            0.0
        ));
        assert!(close(
            rotation_error_up_to_symmetry_deg(turn(10.0), turn(137.0) * tilt, Symmetry::Continuous),
            0.1f64.to_degrees()
        ));
        // Never more than the plain error.
        let (a, b) = (turn(25.0) * tilt, turn(-80.0));
        for symmetry in [Symmetry::Turns(2), Symmetry::Turns(3), Symmetry::Continuous] {
            assert!(
                rotation_error_up_to_symmetry_deg(a, b, symmetry)
                    <= rotation_error_deg(a, b) + 1e-9
            );
        }
    }

    #[test]
    fn pose_errors() {
        let a = DMat3::from_rotation_z(0.3);
        assert!(
            (rotation_error_deg(a, a * DMat3::from_rotation_x(0.5)) - 0.5f64.to_degrees()).abs()
                < 1e-9
        );
        assert_eq!(rotation_error_deg(a, a), 0.0);
        assert!(
            (rotation_error_deg(
                DMat3::IDENTITY,
                DMat3::from_rotation_y(std::f64::consts::PI)
            ) - 180.0)
                .abs()
                < 1e-6
        );
        let (r1, r2) = (
            DMat3::from_rotation_z(170f64.to_radians()),
            DMat3::from_rotation_z(-170f64.to_radians()),
        );
        assert!((yaw_error_deg(r1, r2) - 20.0).abs() < 1e-9);
        assert!((yaw_error_deg(r2, r1) - 20.0).abs() < 1e-9);
        assert!((position_error_cm(DVec3::ZERO, DVec3::new(0.03, 0.04, 0.0)) - 5.0).abs() < 1e-12);
        let b = OrientedBox::new(Pose::IDENTITY, DVec3::ONE);
        let c = OrientedBox::new(
            Pose::new(DMat3::IDENTITY, DVec3::new(0.5, 0.0, 0.0)),
            DVec3::ONE,
        );
        assert!((iou_percent(&b, &c) - 100.0 / 3.0).abs() < 1e-9);
    }

    #[test]
    fn hungarian_matches_brute_force() {
        fn best(cost: &[Vec<f64>], row: usize, used: &mut Vec<bool>) -> f64 {
            if row == cost.len() {
                return 0.0;
            }
            let mut m = f64::INFINITY;
            for c in 0..used.len() {
                if !used[c] {
                    used[c] = true;
                    m = m.min(cost[row][c] + best(cost, row + 1, used));
                    used[c] = false;
                }
            }
            m
        }
        let mut rng = Pcg64::seed_from_u64(6);
        for trial in 0..40 {
            let (rows, cols) = (1 + trial % 5, 1 + (trial / 5) % 6);
            let cost: Vec<Vec<f64>> = (0..rows)
                .map(|_| (0..cols).map(|_| rng.random_range(0.0..10.0)).collect())
                .collect();
            let got = min_cost_assignment(&cost);
            assert_eq!(got.iter().flatten().count(), rows.min(cols));
            let mut cols_seen: Vec<usize> = got.iter().flatten().copied().collect();
            cols_seen.sort_unstable();
            cols_seen.dedup();
            assert_eq!(cols_seen.len(), rows.min(cols));
            let total: f64 = got
                .iter()
                .enumerate()
                .filter_map(|(r, c)| c.map(|c| cost[r][c]))
                .sum();
            let optimum = if rows <= cols {
                best(&cost, 0, &mut vec![false; cols])
            } else {
                let t: Vec<Vec<f64>> = (0..cols)
                    .map(|c| (0..rows).map(|r| cost[r][c]).collect())
                    .collect();
                best(&t, 0, &mut vec![false; rows])
            };
            assert!(
                (total - optimum).abs() < 1e-9,
                "{rows}×{cols}: {total} vs {optimum}"
            );
        }
    }

    #[test]
    fn arrangement_matches_instances_and_counts_misses() {
        let truth = vec![
            gt(1, "bed", pose(0.0, 0.0, 0.0)),
            gt(2, "chair", pose(90.0, 3.0, 0.0)),
            gt(3, "chair", pose(0.0, 5.0, 0.0)),
            gt(4, "lamp", pose(0.0, 8.0, 0.0)),
        ];
        let predicted = vec![
            PredictedObject {
                id: 1,
                object_to_world: pose(10.0, 0.1, 0.0),
            },
            // The chairs swapped ids: they are matched by position instead.
            PredictedObject {
                id: 3,
                object_to_world: pose(90.0, 3.0, 0.0),
            },
            PredictedObject {
                id: 2,
                object_to_world: pose(0.0, 5.0, 0.0),
            },
            // An id that is not in the room.
            PredictedObject {
                id: 9,
                object_to_world: pose(0.0, 9.0, 0.0),
            },
        ];
        let score = evaluate_arrangement(&truth, &predicted);
        let rows = &score.objects;
        assert_eq!(rows[1].predicted_id, Some(3));
        assert_eq!(rows[2].predicted_id, Some(2));
        assert!(
            (rows[1].iou_percent - 100.0).abs() < 1e-9
                && (rows[2].iou_percent - 100.0).abs() < 1e-9
        );
        assert_eq!(rows[3].predicted_id, None);
        assert_eq!(rows[3].iou_percent, 0.0);
        assert_eq!(score.missed, 1);
        assert!((rows[0].rotation_error_deg.unwrap() - 10.0).abs() < 1e-9);
        assert!((rows[0].position_error_cm.unwrap() - 10.0).abs() < 1e-9);
        assert!((score.mean_rotation_error_deg.unwrap() - 10.0 / 3.0).abs() < 1e-9);
        let mean_iou = (rows[0].iou_percent + 200.0) / 4.0;
        assert!((score.mean_iou_percent.unwrap() - mean_iou).abs() < 1e-9);
        assert_eq!((score.precision, score.recall), (0.75, 0.75));
        assert_eq!(score.placed_share, 0.75);
        let json = serde_json::to_string(&score).unwrap();
        assert!(json.contains("\"mean_position_error_cm\""));
    }

    #[test]
    fn an_object_named_right_but_found_far_from_where_it_stands_is_not_placed() {
        let truth = vec![
            gt(1, "bed", pose(0.0, 0.0, 0.0)),
            gt(2, "lamp", pose(0.0, 3.0, 0.0)),
        ];
        let predicted = |lamp_x: f64| {
            evaluate_arrangement(
                &truth,
                &[
                    PredictedObject {
                        id: 1,
                        object_to_world: pose(0.0, 0.19, 0.0),
                    },
                    PredictedObject {
                        id: 2,
                        object_to_world: pose(0.0, lamp_x, 0.0),
                    },
                ],
            )
        };
        let far = predicted(3.25);
        assert_eq!(
            (far.precision, far.recall, far.placed_share),
            (1.0, 1.0, 0.5)
        );
        assert_eq!(predicted(3.19).placed_share, 1.0);
    }

    #[test]
    fn empty_arrangements() {
        let none = evaluate_arrangement(&[gt(1, "bed", Pose::IDENTITY)], &[]);
        assert_eq!((none.missed, none.precision, none.recall), (1, 1.0, 0.0));
        assert_eq!(none.placed_share, 0.0);
        assert_eq!(evaluate_arrangement(&[], &[]).placed_share, 1.0);
        assert_eq!(
            (none.mean_iou_percent, none.mean_rotation_error_deg),
            (Some(0.0), None)
        );
    }

    fn image(w: u32, h: u32, f: impl Fn(u32, u32, usize) -> f64) -> RgbImage {
        let data = (0..h)
            .flat_map(|v| (0..w).map(move |u| (u, v)))
            .map(|(u, v)| std::array::from_fn(|c| f(u, v, c) as f32));
        Image {
            width: w,
            height: h,
            data: data.collect(),
        }
    }

    #[test]
    fn psnr_of_constant_offset() {
        let a = image(16, 12, |u, v, c| {
            0.2 + 0.01 * (u + v) as f64 + 0.1 * c as f64
        });
        let b = a.map(|p| p.map(|x| x + 0.1));
        // MSE = 0.01 up to f32 rounding, so 20 dB.
        assert!((psnr(&a, &b) - 20.0).abs() < 1e-4);
        assert_eq!(psnr(&a, &a), f64::INFINITY);
        let mut mask = Image::filled(16, 12, false);
        assert_eq!(psnr_masked(&a, &b, &mask), None);
        let mut c = a.clone();
        c.set(3, 4, [0.0, 0.0, 0.0]);
        mask.set(5, 5, true);
        assert_eq!(psnr_masked(&a, &c, &mask), Some(f64::INFINITY));
        mask.set(3, 4, true);
        assert!(psnr_masked(&a, &c, &mask).unwrap().is_finite());
    }

    #[test]
    fn ssim_is_one_for_identical_and_drops_with_noise() {
        let a = image(32, 24, |u, v, c| {
            0.5 + 0.3 * (0.4 * u as f64 + 0.2 * v as f64 + c as f64).sin()
        });
        assert!((ssim(&a, &a) - 1.0).abs() < 1e-12);
        let mut rng = Pcg64::seed_from_u64(7);
        let mut last = 1.0;
        for sigma in [0.02, 0.1, 0.3] {
            let mut noisy = a.clone();
            noisy
                .data
                .iter_mut()
                .flatten()
                .for_each(|x| *x += sigma * rng.random_range(-1.0f32..1.0));
            let s = ssim(&a, &noisy);
            assert!(s < last, "SSIM should fall with noise: {s} after {last}");
            last = s;
        }
    }

    #[test]
    fn ssim_and_psnr_match_skimage() {
        // Reference from Python (numpy 2.4.6, scikit-image 0.26.0):
        //   u = arange(20)[None,:,None]; v = arange(16)[:,None,None]; c = arange(3)[None,None,:]
        //   a = float32(sin(0.7u + 0.3v + c)·0.4 + 0.5)
        //   b = float32(cos(0.5u − 0.2v + 2c)·0.3 + 0.45 + 0.1 sin(1.3uv))
        //   structural_similarity(a, b, channel_axis=2, gaussian_weights=True, sigma=1.5,
        //                         use_sample_covariance=False, data_range=1.0)   (inputs as float64)
        //   peak_signal_noise_ratio(a, b, data_range=1.0)
        let a = image(20, 16, |u, v, c| {
            (0.7 * u as f64 + 0.3 * v as f64 + c as f64).sin() * 0.4 + 0.5
        });
        let b = image(20, 16, |u, v, c| {
            let (u, v, c) = (u as f64, v as f64, c as f64);
            (0.5 * u - 0.2 * v + 2.0 * c).cos() * 0.3 + 0.45 + 0.1 * (1.3 * u * v).sin()
        });
        assert!(
            (ssim(&a, &b) - -0.1256135376661652).abs() < 1e-6,
            "{}",
            ssim(&a, &b)
        );
        assert!(
            (psnr(&a, &b) - 9.102942079391411).abs() < 1e-6,
            "{}",
            psnr(&a, &b)
        );
    }
}

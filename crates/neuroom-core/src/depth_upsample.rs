//! Coarse depth (a phone's LiDAR: 256 × 192 against 1920-pixel colour) brought to the colour's size.
//!
//! Each pixel interpolates the inverse depth of the four coarse samples around it, bilinearly: the
//! inverse depth of a plane is affine in the image, so planes come back exact instead of as steps.
//! Where those samples disagree by more than an edge's jump they lie on different surfaces: the
//! pixel takes its nearest sample instead of a blend floating between them. Holes (0) take no part
//! in a blend, and a pixel that lies nearer to holes than to samples (their bilinear weights) stays
//! one, so holes neither grow nor shrink.

use crate::image::{DepthImage, Image};

/// Neighbouring samples of one surface differ by a few percent even at grazing angles; more than
/// this and they are two surfaces.
const EDGE_JUMP: f32 = 0.1;

/// `depth` resampled to `width` × `height` (metres, 0 = none), as the module says.
pub fn upsample_depth(depth: &DepthImage, width: u32, height: u32) -> DepthImage {
    let mut out = Image::filled(width, height, 0.0f32);
    let scale_x = depth.width as f64 / width as f64;
    let scale_y = depth.height as f64 / height as f64;
    for v in 0..height {
        // Continuous coordinates in the coarse image, sample centres at integers.
        let y = ((v as f64 + 0.5) * scale_y - 0.5).clamp(0.0, (depth.height - 1) as f64);
        for u in 0..width {
            let x = ((u as f64 + 0.5) * scale_x - 0.5).clamp(0.0, (depth.width - 1) as f64);
            out.set(u, v, interpolate(depth, x, y));
        }
    }
    out
}

/// The depth at continuous coarse coordinates (`x`, `y`) inside the image.
fn interpolate(depth: &DepthImage, x: f64, y: f64) -> f32 {
    let (x0, y0) = (x.floor() as u32, y.floor() as u32);
    let (x1, y1) = (
        (x0 + 1).min(depth.width - 1),
        (y0 + 1).min(depth.height - 1),
    );
    let (fx, fy) = ((x - x0 as f64) as f32, (y - y0 as f64) as f32);
    let corners = [
        (*depth.get(x0, y0), (1.0 - fx) * (1.0 - fy)),
        (*depth.get(x1, y0), fx * (1.0 - fy)),
        (*depth.get(x0, y1), (1.0 - fx) * fy),
        (*depth.get(x1, y1), fx * fy),
    ];
    let valid = || corners.iter().filter(|(d, _)| *d > 0.0);
    // Holes keep their extent: a pixel nearer to holes than to samples stays one.
    if valid().map(|(_, k)| k).sum::<f32>() < 0.5 {
        return 0.0;
    }
    let Some(nearest) = valid().max_by(|a, b| a.1.total_cmp(&b.1)) else {
        return 0.0;
    };
    let (lo, hi) = valid().fold((f32::INFINITY, 0.0f32), |(lo, hi), (d, _)| {
        (lo.min(*d), hi.max(*d))
    });
    if hi > lo * (1.0 + EDGE_JUMP) {
        return nearest.0;
    }
    let (inverse, weight) = valid().fold((0.0f32, 0.0f32), |(s, w), (d, k)| (s + k / d, w + k));
    if weight <= 0.0 {
        return nearest.0;
    }
    weight / inverse
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The z-depth of a slanted plane seen by a pinhole camera of focal 100 at pixel (u, v) of a
    /// `w` × `h` image: inverse depth affine in the image.
    fn plane(w: u32, h: u32) -> DepthImage {
        let mut depth = Image::filled(w, h, 0.0f32);
        for v in 0..h {
            for u in 0..w {
                let (x, y) = ((u as f32 + 0.5) / w as f32, (v as f32 + 0.5) / h as f32);
                depth.set(u, v, 1.0 / (0.4 + 0.2 * x + 0.1 * y));
            }
        }
        depth
    }

    #[test]
    fn planes_come_back_exact() {
        let coarse = plane(16, 12);
        let fine = upsample_depth(&coarse, 120, 90);
        let truth = plane(120, 90);
        // Inside the outer half-sample border, where every pixel has samples on both sides.
        for v in 4..86 {
            for u in 4..116 {
                let (a, b) = (*fine.get(u, v), *truth.get(u, v));
                assert!((a - b).abs() < 1e-4 * b, "({u}, {v}): {a} against {b}");
            }
        }
    }

    #[test]
    fn edges_take_a_side_and_holes_stay() {
        let mut coarse = Image::filled(4, 2, 1.0f32);
        for v in 0..2 {
            coarse.set(2, v, 3.0);
            coarse.set(3, v, 3.0);
        }
        let mut holed = coarse.clone();
        holed.set(0, 0, 0.0);
        holed.set(0, 1, 0.0);
        let fine = upsample_depth(&coarse, 16, 8);
        assert!(
            fine.data
                .iter()
                .all(|d| (d - 1.0).abs() < 1e-5 || (d - 3.0).abs() < 1e-5),
            "no depth between the two surfaces"
        );
        let fine = upsample_depth(&holed, 16, 8);
        assert_eq!(
            *fine.get(0, 0),
            0.0,
            "a pixel among holes only stays a hole"
        );
        assert_eq!(
            *fine.get(5, 3),
            1.0,
            "a hole's neighbour takes no part in the blend"
        );
    }
}

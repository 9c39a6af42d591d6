//! Illumination-robust features of a panorama: the gradient of its blurred log luminance. A change of
//! exposure or of a smooth shading factor adds a slowly varying offset to the log luminance, which the
//! gradient removes, while edges of the room's geometry and texture stay.

use neuroom_core::image::RgbImage;
use neuroom_panorama::plane::{Plane, log_luminance};

/// Feature channels of one panorama at one resolution (all planes share its size).
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureMap {
    /// `∂/∂u` and `∂/∂v` of the blurred log luminance, per pixel.
    pub channels: [Plane; 2],
}

impl FeatureMap {
    /// Features of `image` blurred by `sigma` pixels before differentiation.
    pub fn new(image: &RgbImage, sigma: f32) -> Self {
        Self::from_log(log_luminance(image).blur(sigma))
    }

    /// Features of a rendering of which only the `valid` pixels are trusted (others saw no surface, or
    /// a surface whose look depends on the lights): the log luminance is blurred by normalised
    /// convolution over the valid pixels, so the borders of the others make no edges.
    pub fn masked(image: &RgbImage, valid: &[bool], sigma: f32) -> Self {
        let log = log_luminance(image);
        let mask = Plane {
            data: valid.iter().map(|d| f32::from(*d)).collect(),
            ..log.clone()
        };
        let weighted = Plane {
            data: log
                .data
                .iter()
                .zip(&mask.data)
                .map(|(l, m)| l * m)
                .collect(),
            ..log.clone()
        };
        let (num, den) = (weighted.blur(sigma), mask.blur(sigma));
        let mean = weighted.data.iter().sum::<f32>() / mask.data.iter().sum::<f32>().max(1.0);
        Self::from_log(Plane {
            data: num
                .data
                .iter()
                .zip(&den.data)
                .map(|(n, d)| if *d > 1e-3 { n / d } else { mean })
                .collect(),
            ..log
        })
    }

    fn from_log(blurred: Plane) -> Self {
        let (gx, gy) = blurred.gradients();
        Self { channels: [gx, gy] }
    }

    /// Orientation features: the gradient `g` as the doubled-angle vector
    /// `(gx² − gy², 2 gx gy) / (|g|² + ε²)`, with `ε` = `softness` × the RMS gradient. A lighting change
    /// can reverse an edge's contrast (a ceiling darker than the walls under one light, brighter under
    /// another) and scale it; the edge's orientation stays, so these features match panoramas under
    /// different lights where signed gradients disagree.
    pub fn orientation(&self, softness: f32) -> FeatureMap {
        let [gx, gy] = &self.channels;
        let n = gx.data.len().max(1) as f32;
        let mean_square = gx
            .data
            .iter()
            .zip(&gy.data)
            .map(|(a, b)| a * a + b * b)
            .sum::<f32>()
            / n;
        let eps2 = (softness * softness * mean_square).max(1e-12);
        let channel = |f: &dyn Fn(f32, f32) -> f32| Plane {
            data: gx
                .data
                .iter()
                .zip(&gy.data)
                .map(|(x, y)| f(*x, *y) / (x * x + y * y + eps2))
                .collect(),
            ..gx.clone()
        };
        FeatureMap {
            channels: [channel(&|x, y| x * x - y * y), channel(&|x, y| 2.0 * x * y)],
        }
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.channels[0].width
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.channels[0].height
    }

    /// Every channel scaled to zero mean and unit variance over the cosine-of-latitude weighted sphere,
    /// so that correlation scores compare across panoramas.
    pub fn normalized(&self) -> FeatureMap {
        let weights = row_weights(self.height());
        let norm = |p: &Plane| {
            let w = p.width;
            let (mut s, mut s2, mut n) = (0.0f64, 0.0f64, 0.0f64);
            for (i, x) in p.data.iter().enumerate() {
                let wt = weights[i / w] as f64;
                s += wt * *x as f64;
                s2 += wt * (*x as f64).powi(2);
                n += wt;
            }
            let mean = s / n;
            let std = (s2 / n - mean * mean).max(1e-12).sqrt();
            Plane {
                data: p
                    .data
                    .iter()
                    .map(|x| ((*x as f64 - mean) / std) as f32)
                    .collect(),
                ..p.clone()
            }
        };
        FeatureMap {
            channels: [norm(&self.channels[0]), norm(&self.channels[1])],
        }
    }
}

/// Cosine of each row's latitude: the solid angle a pixel of that row covers, relative to the equator.
pub fn row_weights(height: usize) -> Vec<f32> {
    (0..height)
        .map(|v| {
            let lat = std::f32::consts::PI * (0.5 - (v as f32 + 0.5) / height as f32);
            lat.cos()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn stripes(w: u32, h: u32, gain: f32) -> RgbImage {
        RgbImage {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| {
                    let u = i % w;
                    let c = if (u / 4).is_multiple_of(2) { 0.3 } else { 0.7 };
                    [c * gain; 3]
                })
                .collect(),
        }
    }

    #[test]
    fn features_ignore_a_change_of_exposure() {
        let a = FeatureMap::new(&stripes(32, 16, 1.0), 1.0).normalized();
        let b = FeatureMap::new(&stripes(32, 16, 0.6), 1.0).normalized();
        for (x, y) in a.channels[0].data.iter().zip(&b.channels[0].data) {
            assert!((x - y).abs() < 0.15, "{x} vs {y}");
        }
    }

    #[test]
    fn orientation_features_ignore_a_reversed_contrast() {
        let a = FeatureMap::new(&stripes(32, 16, 1.0), 1.0).orientation(0.5);
        let reversed = stripes(32, 16, 1.0).map(|c| c.map(|x| 1.0 - x));
        let b = FeatureMap::new(&reversed, 1.0).orientation(0.5);
        let signed = FeatureMap::new(&reversed, 1.0);
        let mut differs = false;
        for i in 0..a.channels[0].data.len() {
            assert!((a.channels[0].data[i] - b.channels[0].data[i]).abs() < 0.1);
            assert!((a.channels[1].data[i] - b.channels[1].data[i]).abs() < 0.1);
            differs |= signed.channels[0].data[i]
                * FeatureMap::new(&stripes(32, 16, 1.0), 1.0).channels[0].data[i]
                < -1e-3;
        }
        assert!(differs, "the signed gradients should flip");
    }

    #[test]
    fn masked_features_make_no_edge_at_a_hole() {
        let mut image = stripes(32, 16, 1.0).map(|_| [0.5; 3]);
        let valid: Vec<bool> = (0..32 * 16).map(|i| i % 32 < 20).collect();
        for (p, ok) in image.data.iter_mut().zip(&valid) {
            if !ok {
                *p = [0.0; 3];
            }
        }
        let plain = FeatureMap::new(&image, 1.5);
        let masked = FeatureMap::masked(&image, &valid, 1.5);
        let peak = |f: &FeatureMap| {
            f.channels[0]
                .data
                .iter()
                .fold(0.0f32, |m, x| m.max(x.abs()))
        };
        assert!(peak(&plain) > 0.5, "{}", peak(&plain));
        assert!(peak(&masked) < 1e-3, "{}", peak(&masked));
    }

    #[test]
    fn row_weights_peak_at_the_equator() {
        let w = row_weights(8);
        assert!(w[3] > w[0] && w[4] > w[7]);
        assert!((w[3] - w[4]).abs() < 1e-6);
    }
}

//! Illumination-robust features of a panorama: the gradient of its blurred log luminance. A change of
//! exposure or of a smooth shading factor adds a slowly varying offset to the log luminance, which the
//! gradient removes, while edges of the room's geometry and texture stay.

use neuroom_core::image::RgbImage;

use crate::plane::{Plane, log_luminance};

/// Feature channels of one panorama at one resolution (all planes share its size).
#[derive(Clone, Debug, PartialEq)]
pub struct FeatureMap {
    /// `∂/∂u` and `∂/∂v` of the blurred log luminance, per pixel.
    pub channels: [Plane; 2],
}

impl FeatureMap {
    /// Features of `image` blurred by `sigma` pixels before differentiation.
    pub fn new(image: &RgbImage, sigma: f32) -> Self {
        let (gx, gy) = log_luminance(image).blur(sigma).gradients();
        Self { channels: [gx, gy] }
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
    fn row_weights_peak_at_the_equator() {
        let w = row_weights(8);
        assert!(w[3] > w[0] && w[4] > w[7]);
        assert!((w[3] - w[4]).abs() < 1e-6);
    }
}

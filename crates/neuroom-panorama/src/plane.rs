//! Single-channel float images over the equirectangular grid: area downsampling, Gaussian blur and
//! bilinear sampling, all wrapping around in longitude (columns) and clamping in latitude (rows).

use neuroom_core::image::{RgbImage, srgb_to_linear};

/// A `width × height` grid of `f32`, row-major, row 0 on top; columns wrap around (a panorama).
#[derive(Clone, Debug, PartialEq)]
pub struct Plane {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width · height` values.
    pub data: Vec<f32>,
}

impl Plane {
    /// A plane filled with `value`.
    pub fn filled(width: usize, height: usize, value: f32) -> Self {
        Self {
            width,
            height,
            data: vec![value; width * height],
        }
    }

    /// The value at column `u` (wrapped) and row `v` (clamped).
    #[inline]
    pub fn at(&self, u: isize, v: isize) -> f32 {
        let u = u.rem_euclid(self.width as isize) as usize;
        let v = v.clamp(0, self.height as isize - 1) as usize;
        self.data[v * self.width + u]
    }

    /// Bilinear value at continuous pixel coordinates (pixel centres at `+0.5`).
    #[inline]
    pub fn sample(&self, x: f64, y: f64) -> f32 {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (u0, v0) = (fx.floor(), fy.floor());
        let (a, b) = ((fx - u0) as f32, (fy - v0) as f32);
        let (u0, v0) = (u0 as isize, v0 as isize);
        let top = self.at(u0, v0) * (1.0 - a) + self.at(u0 + 1, v0) * a;
        let bottom = self.at(u0, v0 + 1) * (1.0 - a) + self.at(u0 + 1, v0 + 1) * a;
        top * (1.0 - b) + bottom * b
    }

    /// Bilinear value and its derivatives along x and y at continuous pixel coordinates.
    #[inline]
    pub fn sample_grad(&self, x: f64, y: f64) -> (f32, f32, f32) {
        let (fx, fy) = (x - 0.5, y - 0.5);
        let (u0, v0) = (fx.floor(), fy.floor());
        let (a, b) = ((fx - u0) as f32, (fy - v0) as f32);
        let (u0, v0) = (u0 as isize, v0 as isize);
        let (p00, p10) = (self.at(u0, v0), self.at(u0 + 1, v0));
        let (p01, p11) = (self.at(u0, v0 + 1), self.at(u0 + 1, v0 + 1));
        let top = p00 * (1.0 - a) + p10 * a;
        let bottom = p01 * (1.0 - a) + p11 * a;
        let value = top * (1.0 - b) + bottom * b;
        let dx = (p10 - p00) * (1.0 - b) + (p11 - p01) * b;
        let dy = bottom - top;
        (value, dx, dy)
    }

    /// Separable Gaussian blur of standard deviation `sigma` pixels (wrapping columns, clamping rows).
    pub fn blur(&self, sigma: f32) -> Plane {
        if sigma <= 0.0 {
            return self.clone();
        }
        let kernel = gaussian_taps(sigma);
        let radius = (kernel.len() / 2) as isize;
        let (w, h) = (self.width, self.height);
        let mut rows = Plane::filled(w, h, 0.0);
        for v in 0..h {
            for u in 0..w {
                rows.data[v * w + u] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, g)| g * self.at(u as isize + k as isize - radius, v as isize))
                    .sum();
            }
        }
        let mut out = Plane::filled(w, h, 0.0);
        for v in 0..h {
            for u in 0..w {
                out.data[v * w + u] = kernel
                    .iter()
                    .enumerate()
                    .map(|(k, g)| g * rows.at(u as isize, v as isize + k as isize - radius))
                    .sum();
            }
        }
        out
    }

    /// Central differences along columns and rows.
    pub fn gradients(&self) -> (Plane, Plane) {
        let (w, h) = (self.width, self.height);
        let mut gx = Plane::filled(w, h, 0.0);
        let mut gy = Plane::filled(w, h, 0.0);
        for v in 0..h as isize {
            for u in 0..w as isize {
                let i = v as usize * w + u as usize;
                gx.data[i] = 0.5 * (self.at(u + 1, v) - self.at(u - 1, v));
                gy.data[i] = 0.5 * (self.at(u, v + 1) - self.at(u, v - 1));
            }
        }
        (gx, gy)
    }
}

/// The normalised taps of a Gaussian of `sigma` pixels (> 0), offsets `-r..=r` for `r = ⌈3σ⌉`: the
/// kernel of [`Plane::blur`].
pub fn gaussian_taps(sigma: f32) -> Vec<f32> {
    let radius = (3.0 * sigma).ceil() as isize;
    let taps: Vec<f32> = (-radius..=radius)
        .map(|k| (-0.5 * (k as f32 / sigma).powi(2)).exp())
        .collect();
    let norm: f32 = taps.iter().sum();
    taps.iter().map(|t| t / norm).collect()
}

/// Calls `visit(target, source)` for every pixel `source` of a `sw × sh` image, with the pixel `target`
/// of a `width × height` image that holds its centre (both row-major indices): the binning of area
/// averaging.
pub fn for_each_target(
    sw: usize,
    sh: usize,
    width: usize,
    height: usize,
    mut visit: impl FnMut(usize, usize),
) {
    for v in 0..sh {
        let tv = (((v as f64 + 0.5) * height as f64 / sh as f64) as usize).min(height - 1);
        for u in 0..sw {
            let tu = (((u as f64 + 0.5) * width as f64 / sw as f64) as usize).min(width - 1);
            visit(tv * width + tu, v * sw + u);
        }
    }
}

/// The pixel of a `sw × sh` image (row-major index) nearest the centre of pixel `target` of a
/// `width × height` image: what a target pixel that [`for_each_target`] never visits (the image
/// enlarged) takes.
pub fn nearest_source(sw: usize, sh: usize, width: usize, height: usize, target: usize) -> usize {
    let (u, v) = (target % width, target / width);
    let su = ((u as f64 + 0.5) * sw as f64 / width as f64) as usize;
    let sv = ((v as f64 + 0.5) * sh as f64 / height as f64) as usize;
    sv.min(sh - 1) * sw + su.min(sw - 1)
}

/// Adds colour `c` to a running sum `[r, g, b, count]` (the first four slots of `sum`).
pub fn add_colour(sum: &mut [f32], c: [f32; 3]) {
    sum[0] += c[0];
    sum[1] += c[1];
    sum[2] += c[2];
    sum[3] += 1.0;
}

/// Area-averaged colour panorama of `width × height` (each source pixel goes to the target pixel that
/// holds its centre; targets no source pixel reaches take the nearest source pixel).
pub fn downsample_rgb(image: &RgbImage, width: usize, height: usize) -> RgbImage {
    let (sw, sh) = (image.width as usize, image.height as usize);
    let mut sum = vec![[0.0f32; 4]; width * height];
    for_each_target(sw, sh, width, height, |target, source| {
        add_colour(&mut sum[target], image.data[source]);
    });
    let data = sum
        .iter()
        .enumerate()
        .map(|(i, s)| {
            if s[3] > 0.0 {
                [s[0] / s[3], s[1] / s[3], s[2] / s[3]]
            } else {
                image.data[nearest_source(sw, sh, width, height, i)]
            }
        })
        .collect();
    RgbImage {
        width: width as u32,
        height: height as u32,
        data,
    }
}

/// Each channel of `image` blurred by `sigma` pixels ([`Plane::blur`]).
pub fn blur_rgb(image: &RgbImage, sigma: f32) -> RgbImage {
    let (w, h) = (image.width as usize, image.height as usize);
    let channels: Vec<Plane> = (0..3)
        .map(|c| {
            Plane {
                width: w,
                height: h,
                data: image.data.iter().map(|p| p[c]).collect(),
            }
            .blur(sigma)
        })
        .collect();
    RgbImage {
        width: image.width,
        height: image.height,
        data: (0..w * h)
            .map(|i| std::array::from_fn(|c| channels[c].data[i]))
            .collect(),
    }
}

/// Natural log of linear luminance (Rec. 709 weights) plus a small floor, per pixel: a global change of
/// exposure becomes a constant offset, which gradients remove.
pub fn log_luminance(image: &RgbImage) -> Plane {
    let data = image
        .data
        .iter()
        .map(|c| {
            let l = 0.2126 * srgb_to_linear(c[0])
                + 0.7152 * srgb_to_linear(c[1])
                + 0.0722 * srgb_to_linear(c[2]);
            (l + 0.01).ln()
        })
        .collect();
    Plane {
        width: image.width as usize,
        height: image.height as usize,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Plane {
        Plane {
            width: w,
            height: h,
            data: (0..w * h)
                .map(|i| ((i % w) as f32 * 0.3).sin() + (i / w) as f32 * 0.1)
                .collect(),
        }
    }

    #[test]
    fn bilinear_derivatives_match_finite_differences() {
        let p = ramp(16, 8);
        let (x, y) = (5.3, 3.7);
        let (_, dx, dy) = p.sample_grad(x, y);
        let h = 1e-3;
        let nx = (p.sample(x + h, y) - p.sample(x - h, y)) / (2.0 * h as f32);
        let ny = (p.sample(x, y + h) - p.sample(x, y - h)) / (2.0 * h as f32);
        assert!((nx - dx).abs() < 1e-2, "{nx} vs {dx}");
        assert!((ny - dy).abs() < 1e-2, "{ny} vs {dy}");
    }

    #[test]
    fn sampling_wraps_columns_and_hits_pixel_centres() {
        let p = ramp(16, 8);
        assert_eq!(p.sample(3.5, 2.5), p.at(3, 2));
        assert!((p.sample(16.5, 2.5) - p.at(0, 2)).abs() < 1e-6);
    }

    #[test]
    fn blur_keeps_the_mean_and_smooths() {
        let p = ramp(32, 16);
        let b = p.blur(1.5);
        let mean = |q: &Plane| q.data.iter().sum::<f32>() / q.data.len() as f32;
        assert!((mean(&p) - mean(&b)).abs() < 0.02);
        let var = |q: &Plane| q.gradients().0.data.iter().map(|g| g * g).sum::<f32>();
        assert!(var(&b) < var(&p));
    }

    #[test]
    fn downsampling_averages_blocks() {
        let img = RgbImage {
            width: 4,
            height: 2,
            data: vec![
                [0.0; 3], [1.0; 3], [0.5; 3], [0.5; 3], [1.0; 3], [0.0; 3], [0.2; 3], [0.4; 3],
            ],
        };
        let d = downsample_rgb(&img, 2, 1);
        assert!((d.data[0][0] - 0.5).abs() < 1e-6);
        assert!((d.data[1][0] - 0.4).abs() < 1e-6);
    }
}

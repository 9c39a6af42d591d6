//! A plain row-major image buffer, used for colour (sRGB in [0, 1]), depth (metres) and instance ids.

/// A `width × height` grid of pixels stored row by row, row 0 on top (docs/formats.md image convention).
#[derive(Clone, Debug, PartialEq)]
pub struct Image<T> {
    /// Number of columns.
    pub width: u32,
    /// Number of rows.
    pub height: u32,
    /// `width * height` pixels, row-major.
    pub data: Vec<T>,
}

/// Colour image, sRGB-encoded values in [0, 1].
pub type RgbImage = Image<[f32; 3]>;
/// Colour with alpha, sRGB-encoded values in [0, 1]; alpha 0 means "no surface here".
pub type RgbaImage = Image<[f32; 4]>;
/// Depth in metres, 0 = no depth (pinhole: z-depth; panorama: distance along the ray).
pub type DepthImage = Image<f32>;
/// Instance ids, 0 = no movable object.
pub type MaskImage = Image<u16>;

impl<T: Clone> Image<T> {
    /// An image filled with one value.
    pub fn filled(width: u32, height: u32, value: T) -> Self {
        Self {
            width,
            height,
            data: vec![value; width as usize * height as usize],
        }
    }

    /// The pixel at column `u`, row `v`.
    pub fn get(&self, u: u32, v: u32) -> &T {
        &self.data[self.index(u, v)]
    }

    /// Sets the pixel at column `u`, row `v`.
    pub fn set(&mut self, u: u32, v: u32, value: T) {
        let i = self.index(u, v);
        self.data[i] = value;
    }

    /// Linear index of pixel (u, v).
    pub fn index(&self, u: u32, v: u32) -> usize {
        debug_assert!(u < self.width && v < self.height);
        v as usize * self.width as usize + u as usize
    }

    /// Applies `f` to every pixel, keeping the size.
    pub fn map<U>(&self, f: impl Fn(&T) -> U) -> Image<U> {
        Image {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(f).collect(),
        }
    }
}

impl Image<[f32; 3]> {
    /// The image averaged down by an integer factor to `width × height`: how a render at a lower
    /// resolution is compared with a full-size photo. `None` unless the size is an exact multiple.
    pub fn box_downsample(&self, width: u32, height: u32) -> Option<Self> {
        let f = self.width.checked_div(width)?;
        if f == 0 || self.width != f * width || self.height != f * height {
            return None;
        }
        let inv = 1.0 / (f * f) as f32;
        let mut out = Image::filled(width, height, [0.0f32; 3]);
        for v in 0..height {
            for u in 0..width {
                let mut acc = [0.0f32; 3];
                for dv in 0..f {
                    for du in 0..f {
                        let c = self.get(u * f + du, v * f + dv);
                        (0..3).for_each(|k| acc[k] += c[k]);
                    }
                }
                out.set(u, v, acc.map(|a| a * inv));
            }
        }
        Some(out)
    }
}

/// sRGB transfer function: encoded value in [0, 1] to linear light.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Inverse sRGB transfer function: linear light to encoded value (clamped to [0, 1]).
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// An sRGB colour under per-channel gains of a light, applied in linear light (an empty room as a panorama's
/// light shows it; composed training panoramas).
pub fn relit(color: [f32; 3], gains: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|c| linear_to_srgb((srgb_to_linear(color[c]) * gains[c]).min(1.0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let c = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(c)) - c).abs() < 1e-5, "{c}");
        }
    }

    #[test]
    fn indexing_is_row_major() {
        let mut img = Image::filled(3, 2, 0u16);
        img.set(2, 1, 7);
        assert_eq!(img.data[5], 7);
        assert_eq!(*img.get(2, 1), 7);
    }

    #[test]
    fn box_downsample_averages_integer_blocks() {
        let mut img = Image::filled(4, 2, [0.0f32; 3]);
        img.set(0, 0, [1.0; 3]);
        let small = img.box_downsample(2, 1).unwrap();
        assert_eq!(*small.get(0, 0), [0.25; 3]);
        assert_eq!(*small.get(1, 0), [0.0; 3]);
        assert!(img.box_downsample(3, 1).is_none());
        assert!(img.box_downsample(0, 0).is_none());
    }
}

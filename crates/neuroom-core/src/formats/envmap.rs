//! Environment maps: equirectangular HDR images of the light arriving from every world direction.
//!
//! # Convention
//! An environment map is laid out exactly like a docs/formats.md panorama, read in the **world** frame (z up):
//! pixel (u, v) holds the light arriving from direction
//! ```text
//! lon = π · (1 − 2 (u + 0.5) / W)        lat = π · (1/2 − (v + 0.5) / H)
//! d   = (cos lat · cos lon, cos lat · sin lon, sin lat)
//! ```
//! so the centre column faces +x, the column a quarter from the left faces +y, row 0 is the zenith (+z) and
//! the last row the nadir. The mapping is [`Equirect`]'s, which is why maps must be twice as wide as high.
//! It is also Blender's world mapping of an equirectangular image, so maps lit in Blender (e.g. the captures
//! of `shared/data/blender-lite`) read the same way here.
//! To turn a map about z, rotate the direction before [`EnvMap::sample`].
//!
//! # Files
//! - `.exr` (OpenEXR, via the `exr` crate, every compression including DWAA/DWAB): channels R, G, B, any
//!   sample type, first valid layer, largest resolution level.
//! - `.hdr` (Radiance RGBE, via the `image` crate).
//! - `.exr.js` (the `@pmndrs/assets` modules): a JavaScript module whose string literal holds a
//!   `data:…;base64,` URL of an EXR file.
//!
//! Values are linear RGB radiance in the file's own units; NaN and infinite values are rejected, and small
//! negative values (ringing of lossy compression such as DWAB) are clamped to 0.

use super::base64;
use crate::camera::{CameraModel, Equirect};
use crate::error::{FormatError, FormatResult};
use exr::prelude::{ReadChannels, ReadLayers, ReadSpecificChannel};
use glam::{DVec2, Vec3};
use image::ImageDecoder;
use std::io::Cursor;
use std::path::Path;

/// An equirectangular environment map of linear RGB radiance (see the module docs for the convention).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// Columns (twice `height`).
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// `width * height` linear RGB values, row-major, row 0 = zenith.
    pub data: Vec<[f32; 3]>,
}

impl EnvMap {
    /// A map from its pixels; fails unless `width = 2 · height` and `data` has `width · height` values.
    pub fn new(width: u32, height: u32, data: Vec<[f32; 3]>) -> Result<Self, String> {
        Equirect::new(width, height)?;
        if data.len() != width as usize * height as usize {
            return Err(format!("{} values for a {width}×{height} map", data.len()));
        }
        Ok(Self {
            width,
            height,
            data,
        })
    }

    /// The panorama camera sharing this map's pixel grid.
    pub fn camera(&self) -> Equirect {
        Equirect {
            width: self.width,
            height: self.height,
        }
    }

    /// World direction (unit) of continuous pixel coordinates; pixel (u, v)'s centre is (u + 0.5, v + 0.5).
    pub fn direction(&self, pixel: DVec2) -> glam::DVec3 {
        self.camera().direction(pixel)
    }

    /// Radiance arriving from world direction `dir` (any length), bilinearly interpolated between the four
    /// nearest pixel centres, wrapping around in longitude and clamping at the poles. A zero or non-finite
    /// direction has no defined radiance and returns black.
    pub fn sample(&self, dir: Vec3) -> [f32; 3] {
        let Some((p, _)) = dir
            .is_finite()
            .then(|| self.camera().project(dir.as_dvec3()))
            .flatten()
        else {
            return [0.0; 3];
        };
        let (x, y) = (p.x - 0.5, p.y - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (tx, ty) = ((x - x0) as f32, (y - y0) as f32);
        let (w, h) = (self.width as i64, self.height as i64);
        let col = |i: i64| i.rem_euclid(w) as usize;
        let row = |j: i64| j.clamp(0, h - 1) as usize;
        let (c0, c1, r0, r1) = (
            col(x0 as i64),
            col(x0 as i64 + 1),
            row(y0 as i64),
            row(y0 as i64 + 1),
        );
        let at = |r: usize, c: usize| self.data[r * self.width as usize + c];
        let mut out = [0.0; 3];
        for (k, o) in out.iter_mut().enumerate() {
            let top = at(r0, c0)[k] * (1.0 - tx) + at(r0, c1)[k] * tx;
            let bottom = at(r1, c0)[k] * (1.0 - tx) + at(r1, c1)[k] * tx;
            *o = top * (1.0 - ty) + bottom * ty;
        }
        out
    }

    /// Mean value of each channel over the pixels (not weighted by solid angle).
    pub fn pixel_mean(&self) -> [f32; 3] {
        let n = self.data.len().max(1) as f64;
        let sum = self.data.iter().fold([0.0f64; 3], |a, p| {
            [a[0] + p[0] as f64, a[1] + p[1] as f64, a[2] + p[2] as f64]
        });
        sum.map(|s| (s / n) as f32)
    }
}

/// Reads an environment map from an `.exr`, `.hdr` or `.exr.js` file (recognised by content).
pub fn read_envmap(path: impl AsRef<Path>) -> FormatResult<EnvMap> {
    let path = path.as_ref();
    let bytes =
        std::fs::read(path).map_err(|e| FormatError::file(path, format!("cannot read: {e}")))?;
    decode_envmap(path, &bytes)
}

/// Decodes an environment map file held in memory (see [`read_envmap`]); `path` names it in errors.
pub fn decode_envmap(path: &Path, bytes: &[u8]) -> FormatResult<EnvMap> {
    if bytes.is_empty() {
        return Err(FormatError::file(path, "file is empty"));
    }
    if bytes.starts_with(&EXR_MAGIC) {
        decode_exr(path, bytes)
    } else if bytes.starts_with(b"#?") {
        decode_hdr(path, bytes)
    } else if bytes.windows(5).any(|w| w == b"data:") {
        decode_exr(path, &exr_from_js(path, bytes)?)
    } else {
        Err(FormatError::file(
            path,
            "not an OpenEXR, Radiance HDR or .exr.js (base64 data URL) file",
        ))
    }
}

/// The first four bytes of every OpenEXR file.
const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Extracts the EXR bytes from a JavaScript module holding a `data:…;base64,…` string literal.
pub fn exr_from_js(path: &Path, js: &[u8]) -> FormatResult<Vec<u8>> {
    let text = std::str::from_utf8(js)
        .map_err(|_| FormatError::file(path, "JavaScript module is not UTF-8"))?;
    let bad = |m: &str| FormatError::file(path, format!("not a base64 data-URL module: {m}"));
    let start = text.find("data:").ok_or_else(|| bad("no `data:` URL"))?;
    let quote = text[..start]
        .chars()
        .next_back()
        .filter(|c| matches!(c, '\'' | '"' | '`'))
        .ok_or_else(|| bad("the data URL is not a string literal"))?;
    let url = &text[start..];
    let end = url
        .find(quote)
        .ok_or_else(|| bad("unterminated string literal"))?;
    let (_, payload) = url[..end]
        .split_once(";base64,")
        .ok_or_else(|| bad("the data URL is not base64"))?;
    let bytes = base64::decode(payload).map_err(|e| bad(&e))?;
    if !bytes.starts_with(&EXR_MAGIC) {
        return Err(bad("the decoded data is not an OpenEXR file"));
    }
    Ok(bytes)
}

/// Decodes an OpenEXR file's R, G, B channels, checking its size from the header first. Pixel storage
/// grows with the rows actually decoded, so a file whose header claims more than its chunks hold costs
/// memory in proportion to its data, and is then rejected as truncated.
fn decode_exr(path: &Path, bytes: &[u8]) -> FormatResult<EnvMap> {
    let err = |e: exr::error::Error| FormatError::file(path, format!("cannot decode OpenEXR: {e}"));
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(err)?;
    let header = meta
        .headers
        .first()
        .ok_or_else(|| FormatError::file(path, "OpenEXR file has no layer"))?;
    check_size(path, header.layer_size.x(), header.layer_size.y())?;
    let names: Vec<String> = header
        .channels
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    if let Some(missing) = ["R", "G", "B"]
        .iter()
        .find(|n| !names.iter().any(|c| c == *n))
    {
        return Err(FormatError::file(
            path,
            format!(
                "OpenEXR file has no channel {missing} (it has {}); an environment map needs R, G and B",
                names.join(", ")
            ),
        ));
    }
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .specific_channels()
        .required("R")
        .required("G")
        .required("B")
        .collect_pixels(
            |size, _| (size.width(), Vec::<[f32; 3]>::new()),
            |(w, px): &mut (usize, Vec<[f32; 3]>), pos, (r, g, b): (f32, f32, f32)| {
                let i = pos.y() * *w + pos.x();
                if i >= px.len() {
                    px.resize((pos.y() + 1) * *w, [0.0; 3]);
                }
                px[i] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(err)?;
    let size = image.layer_data.size;
    let data = image.layer_data.channel_data.pixels.1;
    if data.len() != size.area() {
        return Err(FormatError::file(
            path,
            format!(
                "OpenEXR file holds {} of its {} rows: it is truncated",
                data.len() / size.width().max(1),
                size.height()
            ),
        ));
    }
    finish(path, size.width() as u32, size.height() as u32, data)
}

/// Decodes a Radiance RGBE file straight into the map's pixels. Every scanline takes at least 4 bytes
/// (its run-length header or its first pixel), so a header claiming more rows than that is rejected
/// before allocating for them.
fn decode_hdr(path: &Path, bytes: &[u8]) -> FormatResult<EnvMap> {
    let err =
        |e: image::ImageError| FormatError::file(path, format!("cannot decode Radiance HDR: {e}"));
    let decoder = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes)).map_err(err)?;
    let (w, h) = decoder.dimensions();
    check_size(path, w as usize, h as usize)?;
    if h as usize * 4 > bytes.len() {
        return Err(FormatError::file(
            path,
            format!(
                "a {}-byte file cannot hold a {w}×{h} Radiance HDR map: it is truncated or corrupt",
                bytes.len()
            ),
        ));
    }
    if decoder.color_type() != image::ColorType::Rgb32F {
        return Err(FormatError::file(path, "Radiance HDR map is not RGB"));
    }
    let mut data = vec![[0.0f32; 3]; w as usize * h as usize];
    decoder
        .read_image(bytemuck::cast_slice_mut(&mut data))
        .map_err(err)?;
    finish(path, w, h, data)
}

/// Rejects maps with a side beyond [`super::MAX_IMAGE_SIDE`] before decoding them.
fn check_size(path: &Path, w: usize, h: usize) -> FormatResult<()> {
    let max = super::MAX_IMAGE_SIDE as usize;
    if w == 0 || h == 0 || w > max || h > max {
        return Err(FormatError::file(
            path,
            format!("environment map is {w}×{h}; sides must be 1..={max} px"),
        ));
    }
    Ok(())
}

/// Validates decoded pixels (finite; negatives clamped to 0) and builds the map.
fn finish(path: &Path, w: u32, h: u32, mut data: Vec<[f32; 3]>) -> FormatResult<EnvMap> {
    if let Some(i) = data.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(FormatError::file(
            path,
            format!(
                "pixel ({}, {}) is not finite",
                i % w as usize,
                i / w as usize
            ),
        ));
    }
    data.iter_mut().flatten().for_each(|c| *c = c.max(0.0));
    EnvMap::new(w, h, data)
        .map_err(|m| FormatError::file(path, format!("not an equirectangular map: {m}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 8×4 map whose pixel (u, v) holds (u, v, 1).
    fn ramp() -> EnvMap {
        let data = (0..4)
            .flat_map(|v| (0..8).map(move |u| [u as f32, v as f32, 1.0]))
            .collect();
        EnvMap::new(8, 4, data).unwrap()
    }

    #[test]
    fn pixel_centres_sample_exactly() {
        let m = ramp();
        for v in 0..4 {
            for u in 0..8 {
                let d = m
                    .direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5))
                    .as_vec3();
                let s = m.sample(d);
                assert!(
                    (s[0] - u as f32).abs() < 1e-4 && (s[1] - v as f32).abs() < 1e-4,
                    "({u},{v}) → {s:?}"
                );
            }
        }
    }

    #[test]
    fn sampling_wraps_in_longitude_and_interpolates() {
        let m = ramp();
        // Halfway between the last and the first column: the mean of 7 and 0.
        let d = m.direction(DVec2::new(8.0, 1.5)).as_vec3();
        assert!((m.sample(d)[0] - 3.5).abs() < 1e-4);
        // +x is the centre of the map (between columns 3 and 4), +z the top rows.
        assert!((m.sample(Vec3::X)[0] - 3.5).abs() < 1e-4);
        assert!(m.sample(Vec3::Z)[1].abs() < 1e-6);
        assert_eq!(m.sample(Vec3::ZERO), [0.0; 3]);
        assert_eq!(m.sample(Vec3::NAN), [0.0; 3]);
    }

    #[test]
    fn js_wrapper_is_unwrapped() {
        let js = b"export default 'data:application/exr;base64,di8xAQ=='";
        assert_eq!(exr_from_js(Path::new("a.exr.js"), js).unwrap(), EXR_MAGIC);
        let err = exr_from_js(
            Path::new("a.exr.js"),
            b"export default 'data:image/png;base64,iVBO'",
        )
        .unwrap_err();
        assert!(err.to_string().contains("a.exr.js"), "{err}");
    }

    #[test]
    fn maps_must_be_two_to_one() {
        assert!(EnvMap::new(6, 4, vec![[0.0; 3]; 24]).is_err());
        assert!(EnvMap::new(8, 4, vec![[0.0; 3]; 3]).is_err());
    }
}

//! Image files: colour (PNG or JPEG), depth (16-bit PNG) and instance masks (8- or 16-bit PNG).
//!
//! Readers look at the header before decoding, so a file claiming more than [`MAX_IMAGE_SIDE`] pixels a
//! side is rejected without allocating for it. Colour readers accept 8- and 16-bit PNG, JPEG, grayscale and
//! palette images; every conversion they make is reported in [`Decoded::conversions`] so a caller can warn.
//! Depth and mask readers accept only single-channel PNGs and never convert, since a converted depth or id
//! would be a guess.
//!
//! Writers produce 8-bit sRGB PNG for colour (values in [0, 1] rounded to the nearest of 256 levels; NaN
//! writes 0), 16-bit PNG for depth, and instance masks as 8-bit PNG when every id is ≤ 255, else 16-bit.

use crate::error::{FormatError, FormatResult};
use crate::image::{DepthImage, Image, MaskImage, RgbImage, RgbaImage};
use image::ImageDecoder;
use png::{BitDepth, ColorType, Transformations};
use std::fmt;
use std::io::Cursor;
use std::path::Path;

/// Largest accepted width or height, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// A conversion a colour reader made to give the caller the pixel layout they asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Conversion {
    /// A grayscale image was expanded to RGB.
    GrayToRgb,
    /// A palette image was expanded to its colours.
    PaletteExpanded,
    /// The file's alpha channel was dropped (RGB was asked for).
    AlphaDropped,
    /// The file has no alpha channel; alpha was set to 1 everywhere.
    OpaqueAlphaAdded,
}

impl fmt::Display for Conversion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::GrayToRgb => "grayscale converted to RGB",
            Self::PaletteExpanded => "palette colours expanded",
            Self::AlphaDropped => "alpha channel dropped",
            Self::OpaqueAlphaAdded => "no alpha channel: alpha set to 1",
        })
    }
}

/// A decoded image and the conversions made on the way.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded<I> {
    /// The pixels.
    pub image: I,
    /// What was converted (empty when the file held exactly the layout asked for).
    pub conversions: Vec<Conversion>,
}

/// Decoded samples before conversion: `channels` interleaved samples per pixel, normalised to [0, 1].
struct Samples {
    width: u32,
    height: u32,
    channels: usize,
    values: Vec<f32>,
    conversions: Vec<Conversion>,
}

/// Reads a colour image as sRGB RGB in [0, 1].
pub fn read_rgb(path: impl AsRef<Path>) -> FormatResult<Decoded<RgbImage>> {
    read_converted(
        path.as_ref(),
        (&[2, 4], Conversion::AlphaDropped),
        |p| match p.len() {
            1 | 2 => [p[0]; 3],
            _ => [p[0], p[1], p[2]],
        },
    )
}

/// Reads a colour image as sRGB RGBA in [0, 1]; files without alpha get alpha 1.
pub fn read_rgba(path: impl AsRef<Path>) -> FormatResult<Decoded<RgbaImage>> {
    read_converted(
        path.as_ref(),
        (&[1, 3], Conversion::OpaqueAlphaAdded),
        |p| match p.len() {
            1 => [p[0], p[0], p[0], 1.0],
            2 => [p[0], p[0], p[0], p[1]],
            3 => [p[0], p[1], p[2], 1.0],
            _ => [p[0], p[1], p[2], p[3]],
        },
    )
}

/// Decodes a colour image and turns each pixel's samples into `P`; `note` names the channel counts for
/// which that turn is itself a conversion worth reporting.
fn read_converted<P>(
    path: &Path,
    note: (&[usize], Conversion),
    pixel: impl Fn(&[f32]) -> P,
) -> FormatResult<Decoded<Image<P>>> {
    let s = decode_colour(path)?;
    let mut conversions = s.conversions;
    if note.0.contains(&s.channels) {
        conversions.push(note.1);
    }
    let data = s.values.chunks_exact(s.channels).map(pixel).collect();
    Ok(Decoded {
        image: Image {
            width: s.width,
            height: s.height,
            data,
        },
        conversions,
    })
}

/// Reads a 16-bit single-channel depth PNG: metres = value × `unit` (0 stays 0 = no depth).
pub fn read_depth(path: impl AsRef<Path>, unit: f64) -> FormatResult<DepthImage> {
    let path = path.as_ref();
    if !super::json::is_positive(unit) {
        return Err(FormatError::file(
            path,
            format!("depth unit must be a positive number, found {unit}"),
        ));
    }
    let bytes = read_bytes(path)?;
    let mut reader = png_reader(path, &bytes, Transformations::IDENTITY)?;
    let (color, depth) = (reader.info().color_type, reader.info().bit_depth);
    if color != ColorType::Grayscale || depth != BitDepth::Sixteen {
        let hint = if depth == BitDepth::Eight {
            " (8-bit depth would hold at most 255 units)"
        } else {
            ""
        };
        return Err(FormatError::file(
            path,
            format!(
                "depth must be a 16-bit grayscale PNG, found {}{hint}",
                describe_png(color, depth)
            ),
        ));
    }
    let (w, h, raw) = read_png_frame(path, &mut reader)?;
    let data = raw
        .chunks_exact(2)
        .map(|b| (u16::from_be_bytes([b[0], b[1]]) as f64 * unit) as f32)
        .collect();
    Ok(Image {
        width: w,
        height: h,
        data,
    })
}

/// Reads an 8- or 16-bit single-channel instance mask PNG (value = object id, 0 = none).
pub fn read_mask(path: impl AsRef<Path>) -> FormatResult<MaskImage> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    let mut reader = png_reader(path, &bytes, Transformations::IDENTITY)?;
    let (color, depth) = (reader.info().color_type, reader.info().bit_depth);
    if color != ColorType::Grayscale || !matches!(depth, BitDepth::Eight | BitDepth::Sixteen) {
        return Err(FormatError::file(
            path,
            format!(
                "instance mask must be an 8- or 16-bit grayscale PNG, found {}",
                describe_png(color, depth)
            ),
        ));
    }
    let (w, h, raw) = read_png_frame(path, &mut reader)?;
    let data = if depth == BitDepth::Eight {
        raw.iter().map(|&b| b as u16).collect()
    } else {
        raw.chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect()
    };
    Ok(Image {
        width: w,
        height: h,
        data,
    })
}

/// Reads only the header of a PNG or JPEG and returns its (width, height), checking the size limit.
pub fn read_image_size(path: impl AsRef<Path>) -> FormatResult<(u32, u32)> {
    let path = path.as_ref();
    let bytes = read_bytes(path)?;
    if is_png(&bytes) {
        let r = png_reader(path, &bytes, Transformations::IDENTITY)?;
        Ok((r.info().width, r.info().height))
    } else {
        let d = jpeg_decoder(path, &bytes)?;
        Ok(d.dimensions())
    }
}

/// Fails, naming `path_b`, when the two images differ in size (e.g. a depth map and its colour image).
pub fn check_same_size(
    path_a: &Path,
    size_a: (u32, u32),
    path_b: &Path,
    size_b: (u32, u32),
) -> FormatResult<()> {
    if size_a == size_b {
        return Ok(());
    }
    Err(FormatError::file(
        path_b,
        format!(
            "image is {}×{} but {} is {}×{}; they must match",
            size_b.0,
            size_b.1,
            path_a.display(),
            size_a.0,
            size_a.1
        ),
    ))
}

/// Writes an 8-bit RGB PNG from sRGB values in [0, 1].
pub fn write_rgb(path: impl AsRef<Path>, image: &RgbImage) -> FormatResult<()> {
    let bytes: Vec<u8> = image.data.iter().flatten().map(|&c| to_u8(c)).collect();
    write_png(
        path.as_ref(),
        image.width,
        image.height,
        ColorType::Rgb,
        BitDepth::Eight,
        &bytes,
    )
}

/// Writes an 8-bit RGBA PNG from sRGB values (and alpha) in [0, 1].
pub fn write_rgba(path: impl AsRef<Path>, image: &RgbaImage) -> FormatResult<()> {
    let bytes: Vec<u8> = image.data.iter().flatten().map(|&c| to_u8(c)).collect();
    write_png(
        path.as_ref(),
        image.width,
        image.height,
        ColorType::Rgba,
        BitDepth::Eight,
        &bytes,
    )
}

/// Writes a 16-bit depth PNG: value = round(metres / `unit`). Zero and +∞ (no surface) write 0; a positive
/// depth too small to round to 1 writes 1 so it is not mistaken for "no depth". Negative or NaN depths, and
/// depths beyond 65535 units, are errors naming the pixel.
pub fn write_depth(path: impl AsRef<Path>, image: &DepthImage, unit: f64) -> FormatResult<()> {
    let path = path.as_ref();
    if !super::json::is_positive(unit) {
        return Err(FormatError::file(
            path,
            format!("depth unit must be a positive number, found {unit}"),
        ));
    }
    let mut bytes = Vec::with_capacity(image.data.len() * 2);
    for (i, &d) in image.data.iter().enumerate() {
        let value = depth_value(d as f64, unit).map_err(|m| {
            let w = image.width.max(1) as usize;
            FormatError::file(path, format!("pixel ({}, {}): {m}", i % w, i / w))
        })?;
        bytes.extend_from_slice(&value.to_be_bytes());
    }
    write_png(
        path,
        image.width,
        image.height,
        ColorType::Grayscale,
        BitDepth::Sixteen,
        &bytes,
    )
}

/// Writes an instance mask PNG: 8-bit when every id is ≤ 255, else 16-bit.
pub fn write_mask(path: impl AsRef<Path>, image: &MaskImage) -> FormatResult<()> {
    let path = path.as_ref();
    if image.data.iter().all(|&id| id <= 255) {
        let bytes: Vec<u8> = image.data.iter().map(|&id| id as u8).collect();
        write_png(
            path,
            image.width,
            image.height,
            ColorType::Grayscale,
            BitDepth::Eight,
            &bytes,
        )
    } else {
        let bytes: Vec<u8> = image.data.iter().flat_map(|id| id.to_be_bytes()).collect();
        write_png(
            path,
            image.width,
            image.height,
            ColorType::Grayscale,
            BitDepth::Sixteen,
            &bytes,
        )
    }
}

/// One depth in metres as a PNG value (see [`write_depth`]).
fn depth_value(d: f64, unit: f64) -> Result<u16, String> {
    if d == 0.0 || d == f64::INFINITY {
        return Ok(0);
    }
    if d.is_nan() || d < 0.0 {
        return Err(format!(
            "depth must be positive, zero or +infinity, found {d}"
        ));
    }
    let units = (d / unit).round().max(1.0);
    if units > u16::MAX as f64 {
        return Err(format!(
            "depth {d} m exceeds the largest storable depth {} m",
            u16::MAX as f64 * unit
        ));
    }
    Ok(units as u16)
}

/// An sRGB value in [0, 1] as a byte, rounded; out-of-range values are clamped and NaN writes 0.
fn to_u8(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Reads the whole file, rejecting an empty one.
fn read_bytes(path: &Path) -> FormatResult<Vec<u8>> {
    let bytes =
        std::fs::read(path).map_err(|e| FormatError::file(path, format!("cannot read: {e}")))?;
    if bytes.is_empty() {
        return Err(FormatError::file(path, "file is empty"));
    }
    Ok(bytes)
}

/// Whether `bytes` start with the PNG signature.
fn is_png(bytes: &[u8]) -> bool {
    bytes.starts_with(b"\x89PNG\r\n\x1a\n")
}

/// Decodes a PNG or JPEG colour image to normalised samples.
fn decode_colour(path: &Path) -> FormatResult<Samples> {
    let bytes = read_bytes(path)?;
    if is_png(&bytes) {
        decode_colour_png(path, &bytes)
    } else {
        decode_jpeg(path, &bytes)
    }
}

/// Decodes a colour PNG, expanding palettes, transparency chunks and sub-byte depths.
fn decode_colour_png(path: &Path, bytes: &[u8]) -> FormatResult<Samples> {
    let mut reader = png_reader(path, bytes, Transformations::EXPAND)?;
    let palette = reader.info().color_type == ColorType::Indexed;
    let (w, h, raw) = read_png_frame(path, &mut reader)?;
    let (color, depth) = reader.output_color_type();
    let values: Vec<f32> = match depth {
        BitDepth::Sixteen => raw
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]) as f32 / 65535.0)
            .collect(),
        _ => raw.iter().map(|&b| b as f32 / 255.0).collect(),
    };
    let mut conversions = Vec::new();
    if palette {
        conversions.push(Conversion::PaletteExpanded);
    }
    if matches!(color, ColorType::Grayscale | ColorType::GrayscaleAlpha) {
        conversions.push(Conversion::GrayToRgb);
    }
    Ok(Samples {
        width: w,
        height: h,
        channels: color.samples(),
        values,
        conversions,
    })
}

/// A JPEG decoder whose header has been read and whose size has been checked.
fn jpeg_decoder<'a>(
    path: &Path,
    bytes: &'a [u8],
) -> FormatResult<image::codecs::jpeg::JpegDecoder<Cursor<&'a [u8]>>> {
    if !bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return Err(FormatError::file(path, "not a PNG or JPEG file"));
    }
    let decoder = image::codecs::jpeg::JpegDecoder::new(Cursor::new(bytes))
        .map_err(|e| FormatError::file(path, format!("cannot decode JPEG: {e}")))?;
    let (w, h) = decoder.dimensions();
    check_size(path, w, h)?;
    Ok(decoder)
}

/// Decodes a JPEG (8-bit, grayscale or colour) to normalised samples.
fn decode_jpeg(path: &Path, bytes: &[u8]) -> FormatResult<Samples> {
    let decoder = jpeg_decoder(path, bytes)?;
    let (w, h) = decoder.dimensions();
    let img = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| FormatError::file(path, format!("cannot decode JPEG: {e}")))?;
    let gray = matches!(img.color(), image::ColorType::L8 | image::ColorType::L16);
    let (channels, raw) = if gray {
        (1, img.into_luma8().into_raw())
    } else {
        (3, img.into_rgb8().into_raw())
    };
    let conversions = if gray {
        vec![Conversion::GrayToRgb]
    } else {
        Vec::new()
    };
    Ok(Samples {
        width: w,
        height: h,
        channels,
        values: raw.iter().map(|&b| b as f32 / 255.0).collect(),
        conversions,
    })
}

/// A PNG reader positioned after the header, with the size limit checked.
fn png_reader<'a>(
    path: &Path,
    bytes: &'a [u8],
    t: Transformations,
) -> FormatResult<png::Reader<Cursor<&'a [u8]>>> {
    if !is_png(bytes) {
        return Err(FormatError::file(path, "not a PNG file"));
    }
    let mut decoder = png::Decoder::new(Cursor::new(bytes));
    decoder.set_transformations(t);
    let reader = decoder
        .read_info()
        .map_err(|e| FormatError::file(path, format!("cannot decode PNG: {e}")))?;
    check_size(path, reader.info().width, reader.info().height)?;
    Ok(reader)
}

/// Decodes the first frame of a PNG: (width, height, raw output bytes).
fn read_png_frame(
    path: &Path,
    reader: &mut png::Reader<Cursor<&[u8]>>,
) -> FormatResult<(u32, u32, Vec<u8>)> {
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| FormatError::file(path, "PNG is too large to decode"))?;
    let mut buf = vec![0; size];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| FormatError::file(path, format!("cannot decode PNG: {e}")))?;
    buf.truncate(info.buffer_size());
    Ok((info.width, info.height, buf))
}

/// Rejects images with a zero side or a side beyond [`MAX_IMAGE_SIDE`].
fn check_size(path: &Path, w: u32, h: u32) -> FormatResult<()> {
    if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
        return Err(FormatError::file(
            path,
            format!("image is {w}×{h}; sides must be 1..={MAX_IMAGE_SIDE} px"),
        ));
    }
    Ok(())
}

/// "8-bit RGB PNG" and the like, for error messages.
fn describe_png(color: ColorType, depth: BitDepth) -> String {
    let kind = match color {
        ColorType::Grayscale => "grayscale",
        ColorType::GrayscaleAlpha => "grayscale+alpha",
        ColorType::Rgb => "RGB",
        ColorType::Rgba => "RGBA",
        ColorType::Indexed => "palette",
    };
    format!("a {}-bit {kind} PNG", depth as u8)
}

/// Encodes and atomically writes a PNG, checking that the buffer matches the size.
fn write_png(
    path: &Path,
    w: u32,
    h: u32,
    color: ColorType,
    depth: BitDepth,
    bytes: &[u8],
) -> FormatResult<()> {
    check_size(path, w, h)?;
    let expected = w as usize * h as usize * color.samples() * (depth as usize / 8);
    if bytes.len() != expected {
        return Err(FormatError::file(
            path,
            format!(
                "image data holds {} bytes, expected {expected} for {w}×{h}",
                bytes.len()
            ),
        ));
    }
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, w, h);
    encoder.set_color(color);
    encoder.set_depth(depth);
    let encode = |e: png::EncodingError| FormatError::file(path, format!("cannot encode PNG: {e}"));
    let mut writer = encoder.write_header().map_err(encode)?;
    writer.write_image_data(bytes).map_err(encode)?;
    writer.finish().map_err(encode)?;
    super::atomic_write(path, &out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_values_round_and_keep_no_depth_distinct() {
        assert_eq!(depth_value(0.0, 0.001), Ok(0));
        assert_eq!(depth_value(f64::INFINITY, 0.001), Ok(0));
        assert_eq!(depth_value(1.2345, 0.001), Ok(1235));
        assert_eq!(depth_value(1e-5, 0.001), Ok(1));
        assert!(depth_value(-1.0, 0.001).is_err());
        assert!(depth_value(f64::NAN, 0.001).is_err());
        assert!(depth_value(70.0, 0.001).unwrap_err().contains("65.535"));
    }

    #[test]
    fn colour_bytes_round_to_nearest() {
        assert_eq!(to_u8(0.5), 128);
        assert_eq!(to_u8(1.0 / 255.0 * 0.49), 0);
        assert_eq!(to_u8(2.0), 255);
        assert_eq!(to_u8(f32::NAN), 0);
    }
}

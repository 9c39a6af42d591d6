//! Image files: colour (PNG or JPEG), depth (16-bit PNG) and instance masks (8- or 16-bit PNG).
//!
//! Readers look at the header before decoding, so a file claiming more than [`MAX_IMAGE_SIDE`] pixels a
//! side, or more pixels than its length can hold (a truncated or forged file), is rejected without
//! allocating for it; decoding then needs the raw samples plus the output, no further copy. Colour readers
//! accept 8- and 16-bit PNG, grayscale and palette PNG, and grayscale, colour and CMYK JPEG; every conversion
//! they make is reported in [`Decoded::conversions`] so a caller can warn. Each reader has a `decode_*`
//! twin that takes the file's bytes already in memory.
//! Depth and mask readers accept only single-channel PNGs and never convert, since a converted depth or id
//! would be a guess.
//!
//! Writers produce 8-bit sRGB PNG for colour (values in [0, 1] rounded to the nearest of 256 levels; NaN
//! writes 0), 16-bit PNG for depth, and instance masks as 8-bit PNG when every id is ≤ 255, else 16-bit.

use crate::camera::Equirect;
use crate::error::{FormatError, FormatResult};
use crate::image::{DepthImage, Image, MaskImage, RgbImage, RgbaImage};
use png::{BitDepth, ColorType, Transformations};
use std::fmt;
use std::io::Cursor;
use std::path::Path;
use zune_core::bytestream::ZCursor;
use zune_core::colorspace::ColorSpace;
use zune_core::options::DecoderOptions;

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
    /// 16-bit samples were scaled to [0, 1] (images are written back with 8 bits).
    SixteenBit,
    /// A CMYK (or YCCK) JPEG was converted to RGB.
    CmykToRgb,
}

impl fmt::Display for Conversion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::GrayToRgb => "grayscale converted to RGB",
            Self::PaletteExpanded => "palette colours expanded",
            Self::AlphaDropped => "alpha channel dropped",
            Self::OpaqueAlphaAdded => "no alpha channel: alpha set to 1",
            Self::SixteenBit => "16-bit samples scaled to [0, 1] (written back as 8-bit)",
            Self::CmykToRgb => "CMYK JPEG converted to RGB",
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

/// Reads a colour image as sRGB RGB in [0, 1].
pub fn read_rgb(path: impl AsRef<Path>) -> FormatResult<Decoded<RgbImage>> {
    let path = path.as_ref();
    decode_rgb(path, &read_bytes(path)?)
}

/// Decodes a colour image file held in memory as sRGB RGB in [0, 1]; `path` names it in errors.
pub fn decode_rgb(path: &Path, bytes: &[u8]) -> FormatResult<Decoded<RgbImage>> {
    decode_converted(
        path,
        bytes,
        (&[2, 4], Conversion::AlphaDropped),
        |p| match p.len() {
            1 | 2 => [p[0]; 3],
            _ => [p[0], p[1], p[2]],
        },
    )
}

/// Reads a photograph or panorama of a scene as [`read_rgb`] does, refusing a 16-bit single-channel
/// PNG: in this format that is a depth map or an instance mask, never a camera's picture, and read
/// as grey colours it would be located silently.
pub fn read_colour_photo(path: impl AsRef<Path>) -> FormatResult<Decoded<RgbImage>> {
    let path = path.as_ref();
    let decoded = read_rgb(path)?;
    let has = |c: Conversion| decoded.conversions.contains(&c);
    if has(Conversion::GrayToRgb) && has(Conversion::SixteenBit) {
        return Err(FormatError::file(
            path,
            "a 16-bit single-channel image is a depth map or an instance mask, not a colour \
             picture: give the colour file (.jpg or .png) beside it",
        ));
    }
    Ok(decoded)
}

/// Reads an equirectangular panorama as [`read_colour_photo`] does, refusing one that is not exactly
/// twice as wide as it is high ([`Equirect::new`]).
pub fn read_panorama(path: impl AsRef<Path>) -> FormatResult<RgbImage> {
    let path = path.as_ref();
    let image = read_colour_photo(path)?.image;
    Equirect::new(image.width, image.height).map_err(|e| FormatError::file(path, e))?;
    Ok(image)
}

/// Reads a colour image as sRGB RGBA in [0, 1]; files without alpha get alpha 1.
pub fn read_rgba(path: impl AsRef<Path>) -> FormatResult<Decoded<RgbaImage>> {
    let path = path.as_ref();
    decode_rgba(path, &read_bytes(path)?)
}

/// Decodes a colour image file held in memory as sRGB RGBA in [0, 1]; `path` names it in errors.
pub fn decode_rgba(path: &Path, bytes: &[u8]) -> FormatResult<Decoded<RgbaImage>> {
    decode_converted(
        path,
        bytes,
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
fn decode_converted<P>(
    path: &Path,
    bytes: &[u8],
    note: (&[usize], Conversion),
    pixel: impl Fn(&[f32]) -> P,
) -> FormatResult<Decoded<Image<P>>> {
    let s = if is_png(bytes) {
        decode_colour_png(path, bytes)?
    } else {
        decode_jpeg(path, bytes)?
    };
    let data = s.pixels(pixel);
    let mut conversions = s.conversions;
    if note.0.contains(&s.channels) {
        conversions.push(note.1);
    }
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
    check_unit(path, unit)?;
    decode_depth(path, &read_bytes(path)?, unit)
}

/// Decodes a depth PNG held in memory (see [`read_depth`]); `path` names it in errors.
pub fn decode_depth(path: &Path, bytes: &[u8], unit: f64) -> FormatResult<DepthImage> {
    check_unit(path, unit)?;
    let mut reader = png_reader(path, bytes, Transformations::IDENTITY)?;
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

/// Fails unless the depth unit is a positive finite number.
fn check_unit(path: &Path, unit: f64) -> FormatResult<()> {
    if super::json::is_positive(unit) {
        Ok(())
    } else {
        Err(FormatError::file(
            path,
            format!("depth unit must be a positive number, found {unit}"),
        ))
    }
}

/// Reads an 8- or 16-bit single-channel instance mask PNG (value = object id, 0 = none).
pub fn read_mask(path: impl AsRef<Path>) -> FormatResult<MaskImage> {
    let path = path.as_ref();
    decode_mask(path, &read_bytes(path)?)
}

/// Decodes an instance mask PNG held in memory (see [`read_mask`]); `path` names it in errors.
pub fn decode_mask(path: &Path, bytes: &[u8]) -> FormatResult<MaskImage> {
    let mut reader = png_reader(path, bytes, Transformations::IDENTITY)?;
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
    decode_image_size(path, &read_bytes(path)?)
}

/// The (width, height) of a PNG or JPEG file held in memory, from its header; `path` names it in errors.
pub fn decode_image_size(path: &Path, bytes: &[u8]) -> FormatResult<(u32, u32)> {
    if is_png(bytes) {
        let r = png_reader(path, bytes, Transformations::IDENTITY)?;
        Ok((r.info().width, r.info().height))
    } else {
        let (d, _) = jpeg_decoder(path, bytes)?;
        let info = d
            .info()
            .ok_or_else(|| jpeg_error(path, "no frame header"))?;
        Ok((info.width as u32, info.height as u32))
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
    check_unit(path, unit)?;
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

/// Decoded samples before conversion: `channels` interleaved samples per pixel, 8 or 16 bits each.
struct Samples {
    width: u32,
    height: u32,
    channels: usize,
    sixteen_bit: bool,
    raw: Vec<u8>,
    conversions: Vec<Conversion>,
}

impl Samples {
    /// Every pixel's samples, normalised to [0, 1], turned into `P` without an intermediate copy.
    fn pixels<P>(&self, pixel: impl Fn(&[f32]) -> P) -> Vec<P> {
        let c = self.channels;
        let bytes = if self.sixteen_bit { 2 } else { 1 };
        self.raw
            .chunks_exact(c * bytes)
            .map(|px| {
                let mut s = [0.0f32; 4];
                for (k, v) in s.iter_mut().take(c).enumerate() {
                    *v = if self.sixteen_bit {
                        u16::from_be_bytes([px[2 * k], px[2 * k + 1]]) as f32 / 65535.0
                    } else {
                        px[k] as f32 / 255.0
                    };
                }
                pixel(&s[..c])
            })
            .collect()
    }
}

/// Decodes a colour PNG, expanding palettes, transparency chunks and sub-byte depths.
fn decode_colour_png(path: &Path, bytes: &[u8]) -> FormatResult<Samples> {
    let mut reader = png_reader(path, bytes, Transformations::EXPAND)?;
    let palette = reader.info().color_type == ColorType::Indexed;
    let (w, h, raw) = read_png_frame(path, &mut reader)?;
    let (color, depth) = reader.output_color_type();
    let sixteen_bit = depth == BitDepth::Sixteen;
    let mut conversions = Vec::new();
    if palette {
        conversions.push(Conversion::PaletteExpanded);
    }
    if matches!(color, ColorType::Grayscale | ColorType::GrayscaleAlpha) {
        conversions.push(Conversion::GrayToRgb);
    }
    if sixteen_bit {
        conversions.push(Conversion::SixteenBit);
    }
    Ok(Samples {
        width: w,
        height: h,
        channels: color.samples(),
        sixteen_bit,
        raw,
        conversions,
    })
}

/// Most pixels one byte of a JPEG file can describe. Every 8×8 block of every component costs at least
/// one bit of Huffman code (the DC difference), so a file of `n` bytes holds at most 512·n pixels; a
/// header claiming more belongs to a truncated or forged file, rejected before allocating for it.
const JPEG_MAX_PIXELS_PER_BYTE: u64 = 512;

/// A JPEG decoder whose header has been read, with its size checked, and the source colour space.
fn jpeg_decoder<'a>(
    path: &Path,
    bytes: &'a [u8],
) -> FormatResult<(zune_jpeg::JpegDecoder<ZCursor<&'a [u8]>>, ColorSpace)> {
    if !bytes.starts_with(&[0xFF, 0xD8, 0xFF]) {
        return Err(FormatError::file(path, "not a PNG or JPEG file"));
    }
    let options = DecoderOptions::default()
        .set_strict_mode(false)
        .set_max_width(usize::MAX)
        .set_max_height(usize::MAX);
    let mut decoder = zune_jpeg::JpegDecoder::new_with_options(ZCursor::new(bytes), options);
    decoder
        .decode_headers()
        .map_err(|e| jpeg_error(path, &e.to_string()))?;
    let info = decoder
        .info()
        .ok_or_else(|| jpeg_error(path, "no frame header"))?;
    let (w, h) = (info.width as u32, info.height as u32);
    check_size(path, w, h)?;
    if w as u64 * h as u64 > JPEG_MAX_PIXELS_PER_BYTE * bytes.len() as u64 {
        return Err(FormatError::file(
            path,
            format!(
                "a {}-byte file cannot hold a {w}×{h} JPEG: it is truncated or corrupt",
                bytes.len()
            ),
        ));
    }
    let space = decoder
        .input_colorspace()
        .ok_or_else(|| jpeg_error(path, "no colour space"))?;
    Ok((decoder, space))
}

/// "cannot decode JPEG: …" naming `path`.
fn jpeg_error(path: &Path, message: &str) -> FormatError {
    FormatError::file(path, format!("cannot decode JPEG: {message}"))
}

/// Decodes a JPEG (8-bit grayscale, colour or CMYK) to samples: grayscale stays one channel, everything
/// else becomes RGB.
fn decode_jpeg(path: &Path, bytes: &[u8]) -> FormatResult<Samples> {
    let (mut decoder, space) = jpeg_decoder(path, bytes)?;
    let gray = matches!(space, ColorSpace::Luma | ColorSpace::LumaA);
    let out = if gray {
        ColorSpace::Luma
    } else {
        ColorSpace::RGB
    };
    decoder.set_options(decoder.options().jpeg_set_out_colorspace(out));
    let raw = decoder
        .decode()
        .map_err(|e| jpeg_error(path, &e.to_string()))?;
    let info = decoder
        .info()
        .ok_or_else(|| jpeg_error(path, "no frame header"))?;
    let (w, h) = (info.width as u32, info.height as u32);
    let channels = if gray { 1 } else { 3 };
    if raw.len() != w as usize * h as usize * channels {
        return Err(jpeg_error(
            path,
            "decoded data does not match the image size",
        ));
    }
    let conversions = match space {
        ColorSpace::Luma | ColorSpace::LumaA => vec![Conversion::GrayToRgb],
        ColorSpace::CMYK | ColorSpace::YCCK => vec![Conversion::CmykToRgb],
        _ => Vec::new(),
    };
    Ok(Samples {
        width: w,
        height: h,
        channels,
        sixteen_bit: false,
        raw,
        conversions,
    })
}

/// Most bytes one byte of deflate data can expand to (RFC 1951 codes at most 258 bytes in 2 bits).
const DEFLATE_MAX_RATIO: u64 = 1032;

/// A PNG reader positioned after the header, with the size limit checked, and the file's size checked
/// against what it claims to hold: a file too short to hold its pixels even at deflate's best ratio is
/// rejected before anything is allocated for them.
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
    let info = reader.info();
    check_size(path, info.width, info.height)?;
    let raw = info.raw_row_length() as u64 * info.height as u64;
    if raw > DEFLATE_MAX_RATIO * bytes.len() as u64 {
        return Err(FormatError::file(
            path,
            format!(
                "a {}-byte file cannot hold a {}×{} PNG: it is truncated or corrupt",
                bytes.len(),
                info.width,
                info.height
            ),
        ));
    }
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

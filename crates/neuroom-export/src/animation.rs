//! Animated GIFs of rendered frames (touring paths, relighting sequences): each frame quantised to its
//! own 256-colour palette, looping forever.

use std::path::Path;

use anyhow::{Context as _, ensure};
use neuroom_core::image::RgbImage;

/// Frames per second of written animations unless asked otherwise.
pub const DEFAULT_FPS: f64 = 12.0;

/// Encodes `frames` (all the same size) as a looping GIF at `fps` frames per second.
pub fn encode_gif(frames: &[RgbImage], fps: f64) -> anyhow::Result<Vec<u8>> {
    let first = frames
        .first()
        .context("an animation needs at least one frame")?;
    let (w, h) = (first.width, first.height);
    ensure!(
        w <= u16::MAX as u32 && h <= u16::MAX as u32,
        "frames of {w}×{h} are too large for a GIF"
    );
    ensure!(fps > 0.0 && fps.is_finite(), "frame rate must be positive");
    let delay = (100.0 / fps).round().clamp(1.0, u16::MAX as f64) as u16;
    let mut out = Vec::new();
    {
        let mut encoder = gif::Encoder::new(&mut out, w as u16, h as u16, &[])?;
        encoder.set_repeat(gif::Repeat::Infinite)?;
        for (k, frame) in frames.iter().enumerate() {
            ensure!(
                frame.width == w && frame.height == h,
                "frame {k} is {}×{}, the first is {w}×{h}",
                frame.width,
                frame.height
            );
            let rgb: Vec<u8> = frame.data.iter().flatten().map(|&c| to_u8(c)).collect();
            let mut f = gif::Frame::from_rgb_speed(w as u16, h as u16, &rgb, 10);
            f.delay = delay;
            encoder.write_frame(&f)?;
        }
    }
    Ok(out)
}

/// Writes `frames` as a looping GIF at `path` (through a temporary file).
pub fn write_gif(path: &Path, frames: &[RgbImage], fps: f64) -> anyhow::Result<()> {
    let bytes = encode_gif(frames, fps).with_context(|| format!("encoding {}", path.display()))?;
    neuroom_core::formats::atomic_write(path, &bytes)?;
    Ok(())
}

/// An sRGB value in [0, 1] as a byte.
pub(crate) fn to_u8(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::image::Image;

    #[test]
    fn frames_decode_back_with_their_colours_and_delay() {
        let red = Image::filled(8, 6, [1.0, 0.0, 0.0]);
        let blue = Image::filled(8, 6, [0.0, 0.0, 1.0]);
        let bytes = encode_gif(&[red, blue], 10.0).unwrap();
        let mut options = gif::DecodeOptions::new();
        options.set_color_output(gif::ColorOutput::RGBA);
        let mut decoder = options.read_info(&bytes[..]).unwrap();
        let mut frames = Vec::new();
        while let Some(f) = decoder.read_next_frame().unwrap() {
            assert_eq!(f.delay, 10);
            frames.push(f.buffer[..4].to_vec());
        }
        assert_eq!(frames.len(), 2);
        assert!(frames[0][0] > 240 && frames[0][2] < 15);
        assert!(frames[1][2] > 240 && frames[1][0] < 15);
    }

    #[test]
    fn mismatched_or_missing_frames_are_errors() {
        assert!(encode_gif(&[], 10.0).is_err());
        let a = Image::filled(8, 6, [0.5; 3]);
        let b = Image::filled(6, 8, [0.5; 3]);
        let e = encode_gif(&[a, b], 10.0).unwrap_err().to_string();
        assert!(e.contains("frame 1"), "{e}");
    }
}

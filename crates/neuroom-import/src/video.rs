//! Video frames decoded by Debian's `ffmpeg`, called as a process: the frames a recording keeps,
//! scaled by ffmpeg and read as raw RGB from its output. HEVC and H.264 (what phones record) are
//! both in Debian's build.

use std::io::Read as _;
use std::path::Path;
use std::process::{Command, Stdio};

use anyhow::Context as _;
use neuroom_core::image::{Image, RgbImage};

/// The pixel size of a video's frames as stored (before any rotation its metadata asks for, which
/// the recording's intrinsics do not know of).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VideoSize {
    /// Pixels per row.
    pub width: u32,
    /// Rows.
    pub height: u32,
}

/// What to do when a program is missing.
fn missing(program: &str, video: &Path, e: std::io::Error) -> anyhow::Error {
    anyhow::anyhow!(
        "{}: reading the video needs `{program}` ({e}); install it (Debian: apt-get install ffmpeg)",
        video.display()
    )
}

/// The size of `video`'s first video stream, by `ffprobe`.
pub fn probe(video: &Path) -> anyhow::Result<VideoSize> {
    anyhow::ensure!(video.is_file(), "{}: no such file", video.display());
    let out = Command::new("ffprobe")
        .args(["-v", "error", "-select_streams", "v:0"])
        .args(["-show_entries", "stream=width,height", "-of", "csv=p=0"])
        .arg(video)
        .output()
        .map_err(|e| missing("ffprobe", video, e))?;
    let text = String::from_utf8_lossy(&out.stdout);
    let parsed = text
        .trim()
        .split_once(',')
        .and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match (out.status.success(), parsed) {
        (true, Some((width, height))) if width > 0 && height > 0 => Ok(VideoSize { width, height }),
        _ => anyhow::bail!(
            "{}: not a video ffprobe can read: {}",
            video.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        ),
    }
}

/// Decodes the frames at `indices` (ascending frame numbers from 0) of `video`, scaled to `size`,
/// handing each to `each` in order.
pub fn decode_frames(
    video: &Path,
    indices: &[usize],
    size: VideoSize,
    each: &mut dyn FnMut(usize, RgbImage) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    if indices.is_empty() {
        return Ok(());
    }
    let picked: Vec<String> = indices.iter().map(|k| format!("eq(n\\,{k})")).collect();
    let filter = format!(
        "select='{}',scale={}:{}:flags=area",
        picked.join("+"),
        size.width,
        size.height
    );
    let mut child = Command::new("ffmpeg")
        .args(["-v", "error", "-nostdin", "-noautorotate", "-i"])
        .arg(video)
        .args(["-map", "0:v:0", "-vf", &filter, "-fps_mode", "passthrough"])
        .args(["-f", "rawvideo", "-pix_fmt", "rgb24", "pipe:1"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| missing("ffmpeg", video, e))?;
    let mut stdout = child.stdout.take().context("ffmpeg's output")?;
    let bytes = size.width as usize * size.height as usize * 3;
    let mut buffer = vec![0u8; bytes];
    let mut result = Ok(());
    for &k in indices {
        if stdout.read_exact(&mut buffer).is_err() {
            result = Err(anyhow::anyhow!(
                "{}: the video ends before frame {k} (the recording lists more frames than it holds)",
                video.display()
            ));
            break;
        }
        let rgb = Image {
            width: size.width,
            height: size.height,
            data: buffer
                .chunks_exact(3)
                .map(|p| [p[0], p[1], p[2]].map(|c| c as f32 / 255.0))
                .collect(),
        };
        if let Err(e) = each(k, rgb) {
            result = Err(e);
            break;
        }
    }
    drop(stdout);
    let out = child.wait_with_output()?;
    result?;
    anyhow::ensure!(
        out.status.success(),
        "{}: ffmpeg failed: {}",
        video.display(),
        String::from_utf8_lossy(&out.stderr).trim()
    );
    Ok(())
}

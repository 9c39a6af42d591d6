//! Captures from phone RGB-D apps turned into neuroom's capture format (docs/formats.md,
//! "transforms.json"; docs/capture.md says how to record with each app):
//!
//! - [`nerfstudio`]: data processed by nerfstudio's `ns-process-data` (Polycam, Record3D,
//!   Metashape, COLMAP), with depth where it has some;
//! - [`stray`]: a Stray Scanner recording (`rgb.mp4`, LiDAR depth and confidence, `odometry.csv`,
//!   `camera_matrix.csv`), its video decoded by Debian's `ffmpeg` ([`video`]);
//! - [`scanner_app`]: a 3D Scanner App raw export (`frame_XXXXX.jpg` + `.json`, depth and
//!   confidence maps).
//!
//! Each reader is a [`Recording`]; [`import_recording`] converts its poses once ([`convention`]),
//! picks evenly spread frames and writes them ([`capture_out`]).

pub mod capture_out;
pub mod convention;
pub mod masks;
pub mod nerfstudio;
pub mod scanner_app;
pub mod stray;
pub mod video;

use std::path::Path;

use neuroom_core::formats::Capture;
use neuroom_core::pose::Pose;

pub use capture_out::{CaptureWriter, FrameSize, SourceFrame};
pub use convention::{CameraAxes, WorldFrame, WorldUp};

/// A capture app's recording, read frame by frame.
pub trait Recording {
    /// Every frame's camera (OpenGL frame) to the recording's world, in the recording's units.
    fn poses(&self) -> &[Pose];

    /// Which way is up in the recording's world, as the app defines it.
    fn up(&self) -> WorldUp;

    /// Reads the frames at `indices` (ascending), handing each to `each` with its index; their
    /// poses as [`Recording::poses`] gives them, depth in the recording's units.
    fn read_frames(
        &mut self,
        indices: &[usize],
        each: &mut dyn FnMut(usize, SourceFrame) -> anyhow::Result<()>,
    ) -> anyhow::Result<()>;
}

/// How an import converts and thins out a recording.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// The size of the written frames.
    pub size: FrameSize,
    /// At most this many frames, evenly spread over the recording.
    pub max_frames: usize,
    /// The world's up; `None`: as the format defines it ([`Recording::up`]).
    pub up: Option<WorldUp>,
    /// Metres per unit of the recording (poses and depth): 1 for phone apps, which track in
    /// metres; a structure-from-motion reconstruction (COLMAP) needs its own.
    pub scale: f64,
    /// LiDAR depth below this confidence (ARKit: 0 low, 1 medium, 2 high) is left out.
    pub min_confidence: u8,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            size: FrameSize { max_width: 640 },
            max_frames: 300,
            up: None,
            scale: 1.0,
            min_confidence: 2,
        }
    }
}

/// Converts `recording` into a capture folder `out`: its poses into neuroom's world once (up to +z,
/// scaled to metres), at most [`ImportOptions::max_frames`] evenly spread frames written at
/// [`ImportOptions::size`]. `progress` is told `(frames written, frames to write)`.
pub fn import_recording(
    recording: &mut dyn Recording,
    out: &Path,
    options: &ImportOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<Capture> {
    let up = options.up.unwrap_or(recording.up());
    anyhow::ensure!(
        options.scale.is_finite() && options.scale > 0.0,
        "the scale must be a positive number of metres per unit, found {}",
        options.scale
    );
    let world = WorldFrame::for_source(up, recording.poses(), options.scale).ok_or_else(|| {
        anyhow::anyhow!(
            "{}: the cameras do not show which way is up; give the up axis",
            out.display()
        )
    })?;
    let indices = capture_out::spread(recording.poses().len(), options.max_frames);
    let mut writer = CaptureWriter::new(out, options.size)?;
    recording.read_frames(&indices, &mut |_, mut frame| {
        frame.camera_to_world = world.pose(&frame.camera_to_world);
        if let Some(depth) = &mut frame.depth {
            let scale = world.scale as f32;
            depth.data.iter_mut().for_each(|d| *d *= scale);
        }
        writer.push(frame)?;
        progress(writer.len(), indices.len());
        Ok(())
    })?;
    writer.finish()
}

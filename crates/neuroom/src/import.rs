//! `neuroom import`: a capture app's recording into a room folder (`captures/<name>/`), the empty
//! room's capture also registered as the room's background in `room.json` (docs/capture.md).

use std::path::{Path, PathBuf};

use neuroom_core::formats::{self, BackgroundSpec, Room};
use neuroom_import::nerfstudio::NerfstudioRecording;
use neuroom_import::scanner_app::ScannerAppRecording;
use neuroom_import::stray::StrayRecording;
use neuroom_import::{Recording, import_recording};

use crate::staging::StagedFolder;

pub use neuroom_import::{FrameSize, ImportOptions, WorldUp};

/// The name of the empty room's capture: importing it also makes it the room's background.
pub const BACKGROUND_CAPTURE: &str = "background";

/// The recordings `neuroom import` reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaptureFormat {
    /// A folder processed by nerfstudio's `ns-process-data` (`transforms.json`).
    Nerfstudio,
    /// A Stray Scanner recording folder.
    Stray,
    /// A 3D Scanner App raw export folder.
    ScannerApp,
}

/// What [`import_capture`] wrote.
#[derive(Clone, Debug)]
pub struct ImportedCapture {
    /// The capture folder.
    pub dir: PathBuf,
    /// Frames written.
    pub frames: usize,
    /// Frames of them with depth.
    pub with_depth: usize,
    /// Whether `room.json` now names it as the room's background.
    pub background: bool,
}

/// Imports the recording `src` (in `format`) into `room/captures/<name>/`; a capture named
/// [`BACKGROUND_CAPTURE`] becomes the room's background (room.json is made when missing). An
/// existing capture of that name is never overwritten; the capture appears only once complete.
/// `progress` is told `(frames written, frames to write)`.
pub fn import_capture(
    format: CaptureFormat,
    src: &Path,
    room: &Path,
    name: &str,
    options: &ImportOptions,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<ImportedCapture> {
    anyhow::ensure!(
        !name.is_empty() && !name.contains(['/', '\\']) && !name.starts_with('.'),
        "--name {name:?}: a capture name is one folder name"
    );
    let dir = room.join("captures").join(name);
    anyhow::ensure!(
        !dir.exists(),
        "{}: already exists; remove it or import under another name",
        dir.display()
    );
    let mut recording: Box<dyn Recording> = match format {
        CaptureFormat::Nerfstudio => Box::new(NerfstudioRecording::open(src)?),
        CaptureFormat::Stray => Box::new(StrayRecording::open(src, options)?),
        CaptureFormat::ScannerApp => {
            Box::new(ScannerAppRecording::open(src, options.min_confidence)?)
        }
    };
    let staged = StagedFolder::new(&dir)?;
    let capture = import_recording(recording.as_mut(), staged.path(), options, progress)?;
    staged.finish()?;
    let background = name == BACKGROUND_CAPTURE;
    if background {
        register_background(room, &Path::new("captures").join(name))?;
    }
    Ok(ImportedCapture {
        dir,
        frames: capture.frames.len(),
        with_depth: capture.frames.iter().filter(|f| f.depth.is_some()).count(),
        background,
    })
}

/// Names `capture` (relative to `room`) as the room's background, making room.json when missing
/// (named after the folder, no objects yet).
fn register_background(room: &Path, capture: &Path) -> anyhow::Result<()> {
    let file = room.join("room.json");
    let mut spec = if file.exists() {
        formats::read_room(&file)?
    } else {
        let name = room
            .canonicalize()
            .ok()
            .and_then(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
            .unwrap_or_else(|| "room".into());
        Room {
            root: room.to_path_buf(),
            name,
            background: BackgroundSpec {
                capture: capture.to_path_buf(),
            },
            objects: Vec::new(),
            extra: Default::default(),
        }
    };
    spec.background.capture = capture.to_path_buf();
    formats::write_room(room, &spec)?;
    Ok(())
}

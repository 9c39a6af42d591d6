//! A 3D Scanner App raw export ("All Data"): per frame `frame_NNNNN.json` (`cameraPoseARFrame`:
//! ARKit's camera-to-world matrix, 16 numbers row by row, camera in OpenGL axes, world y up;
//! `intrinsics`: 9 numbers row by row, for the frame's image), `frame_NNNNN.jpg` (only some frames
//! carry an image), `depth_NNNNN.png` (LiDAR, 16-bit millimetres) and `conf_NNNNN.png` (0–2).

use std::path::{Path, PathBuf};

use neuroom_core::camera::Pinhole;
use neuroom_core::formats;
use neuroom_core::formats::json::{JsonObject, POSE_TOLERANCE, as_numbers, parse_json};
use neuroom_core::image::DepthImage;
use neuroom_core::pose::Pose;

use crate::capture_out::read_lidar_depth;
use crate::stray::intrinsics_from_matrix;
use crate::{Recording, SourceFrame, WorldUp};

/// One frame of the export that has an image.
#[derive(Clone, Debug)]
struct ScannedFrame {
    /// `frame_NNNNN`.
    stem: String,
    camera: Pinhole,
}

/// A 3D Scanner App export folder.
pub struct ScannerAppRecording {
    dir: PathBuf,
    frames: Vec<ScannedFrame>,
    poses: Vec<Pose>,
    min_confidence: u8,
}

impl ScannerAppRecording {
    /// Reads the frames of `dir` that have both their JSON and their JPEG, in frame order.
    pub fn open(dir: &Path, min_confidence: u8) -> anyhow::Result<Self> {
        let listing = std::fs::read_dir(dir)
            .map_err(|e| anyhow::anyhow!("{}: cannot list: {e}", dir.display()))?;
        let mut stems: Vec<String> = listing
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter_map(|n| Some(n.strip_suffix(".json")?.to_string()))
            .filter(|s| s.starts_with("frame_") && dir.join(format!("{s}.jpg")).is_file())
            .collect();
        stems.sort();
        anyhow::ensure!(
            !stems.is_empty(),
            "{}: no frame_NNNNN.json with its frame_NNNNN.jpg: not a 3D Scanner App raw export",
            dir.display()
        );
        let (mut frames, mut poses) = (Vec::new(), Vec::new());
        for stem in stems {
            let (frame, pose) = read_frame(dir, stem)?;
            frames.push(frame);
            poses.push(pose);
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            frames,
            poses,
            min_confidence,
        })
    }

    /// The depth beside frame `stem` ([`read_lidar_depth`]); `None` when it has none.
    fn depth(&self, stem: &str) -> anyhow::Result<Option<DepthImage>> {
        let number = stem.trim_start_matches("frame_");
        let path = self.dir.join(format!("depth_{number}.png"));
        if !path.is_file() {
            return Ok(None);
        }
        let confidence = self.dir.join(format!("conf_{number}.png"));
        read_lidar_depth(&path, &confidence, self.min_confidence).map(Some)
    }
}

/// Reads `dir/<stem>.json` with its image's size.
fn read_frame(dir: &Path, stem: String) -> anyhow::Result<(ScannedFrame, Pose)> {
    let file = dir.join(format!("{stem}.json"));
    let bytes = std::fs::read(&file)
        .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", file.display()))?;
    let value = parse_json(&file, &bytes)?;
    let top = JsonObject::root(&file, &value)?;
    let m = top.required("cameraPoseARFrame", as_numbers::<16>)?;
    let rows = [0, 1, 2, 3].map(|r| [m[4 * r], m[4 * r + 1], m[4 * r + 2], m[4 * r + 3]]);
    let pose = Pose::check_rows(&rows, POSE_TOLERANCE)
        .map_err(|e| top.error("cameraPoseARFrame", e))?
        .orthonormalized();
    let k = top.required("intrinsics", as_numbers::<9>)?;
    let (width, height) = formats::read_image_size(dir.join(format!("{stem}.jpg")))?;
    let camera = intrinsics_from_matrix(&file, &k, width, height)?;
    Ok((ScannedFrame { stem, camera }, pose))
}

impl Recording for ScannerAppRecording {
    fn poses(&self) -> &[Pose] {
        &self.poses
    }

    fn up(&self) -> WorldUp {
        WorldUp::Y
    }

    fn read_frames(
        &mut self,
        indices: &[usize],
        each: &mut dyn FnMut(usize, SourceFrame) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        for &k in indices {
            let frame = &self.frames[k];
            let rgb = formats::read_rgb(self.dir.join(format!("{}.jpg", frame.stem)))?.image;
            let source = SourceFrame {
                rgb,
                camera: frame.camera,
                camera_to_world: self.poses[k],
                depth: self.depth(&frame.stem)?,
            };
            each(k, source)?;
        }
        Ok(())
    }
}

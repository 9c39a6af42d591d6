//! Data processed by nerfstudio's `ns-process-data`: `transforms.json` with OpenGL camera poses,
//! images and (Polycam, Record3D with depth) 16-bit depth maps, possibly smaller than the images.
//! The world's up depends on the source: Polycam's is z, Record3D's ARKit y, COLMAP's and
//! Metashape's any; so it is found from the cameras unless given.

use std::path::Path;

use neuroom_core::formats::{self, Capture};
use neuroom_core::pose::Pose;

use crate::{Recording, SourceFrame, WorldUp};

/// A nerfstudio dataset folder (or its `transforms.json`).
pub struct NerfstudioRecording {
    capture: Capture,
    poses: Vec<Pose>,
}

impl NerfstudioRecording {
    /// Reads `src`'s `transforms.json` (nerfstudio's `OPENCV` or `PINHOLE` cameras; fisheye and
    /// equirectangular ones are refused by name).
    pub fn open(src: &Path) -> anyhow::Result<Self> {
        let capture = formats::read_capture(src)?;
        let poses = capture.frames.iter().map(|f| f.camera_to_world).collect();
        Ok(Self { capture, poses })
    }
}

impl Recording for NerfstudioRecording {
    fn poses(&self) -> &[Pose] {
        &self.poses
    }

    fn up(&self) -> WorldUp {
        WorldUp::Auto
    }

    fn read_frames(
        &mut self,
        indices: &[usize],
        each: &mut dyn FnMut(usize, SourceFrame) -> anyhow::Result<()>,
    ) -> anyhow::Result<()> {
        let unit = self.capture.depth_unit_scale_factor;
        for &k in indices {
            let frame = &self.capture.frames[k];
            let image = self.capture.resolve(&frame.image);
            let rgb = formats::read_rgb(&image)?.image;
            anyhow::ensure!(
                (rgb.width, rgb.height) == (frame.camera.width, frame.camera.height),
                "{}: {}×{} pixels where transforms.json says {}×{}",
                image.display(),
                rgb.width,
                rgb.height,
                frame.camera.width,
                frame.camera.height
            );
            let depth = match &frame.depth {
                Some(d) => Some(formats::read_depth(self.capture.resolve(d), unit)?),
                None => None,
            };
            let source = SourceFrame {
                rgb,
                camera: frame.camera,
                camera_to_world: frame.camera_to_world,
                depth,
            };
            each(k, source)?;
        }
        Ok(())
    }
}

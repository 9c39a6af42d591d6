//! What every importer writes: a capture folder of neuroom's format (docs/formats.md,
//! "transforms.json"): colour frames at the chosen width, depth resampled onto them, poses in the
//! OpenGL camera frame of a z-up world.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use image::imageops::FilterType;
use neuroom_core::camera::Pinhole;
use neuroom_core::depth_upsample::upsample_depth;
use neuroom_core::formats::{
    self, Capture, CaptureDevice, DepthNoise, Frame, transforms::DEFAULT_DEPTH_UNIT,
};
use neuroom_core::image::{DepthImage, Image, RgbImage};
use neuroom_core::pose::Pose;
use serde_json::Map;

/// One frame as a source gives it, already in neuroom's conventions.
#[derive(Clone, Debug)]
pub struct SourceFrame {
    /// The colour image.
    pub rgb: RgbImage,
    /// The colour image's intrinsics.
    pub camera: Pinhole,
    /// Camera (OpenGL frame) to world (z up, metres).
    pub camera_to_world: Pose,
    /// Depth in metres along the optical axis of the colour camera, at any resolution (a phone's
    /// LiDAR gives 256×192); 0 where there is none.
    pub depth: Option<DepthImage>,
}

/// The pixel sizes an import writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FrameSize {
    /// Width of the written frames; frames narrower than it keep their size.
    pub max_width: u32,
}

impl FrameSize {
    /// The written size of a `width × height` frame: at most `max_width` wide, same aspect.
    pub fn of(self, width: u32, height: u32) -> (u32, u32) {
        if width <= self.max_width {
            return (width, height);
        }
        let h = (height as f64 * self.max_width as f64 / width as f64).round() as u32;
        (self.max_width, h.max(1))
    }
}

/// Writes frames into a capture folder as they come: `images/NNNNN.png`, `depths/NNNNN.png`, then
/// `transforms.json` by [`CaptureWriter::finish`].
pub struct CaptureWriter {
    dir: PathBuf,
    size: FrameSize,
    frames: Vec<Frame>,
}

impl CaptureWriter {
    /// A writer into `dir` (created with its `images/` and `depths/`).
    pub fn new(dir: &Path, size: FrameSize) -> anyhow::Result<Self> {
        for sub in ["images", "depths"] {
            let folder = dir.join(sub);
            std::fs::create_dir_all(&folder)
                .with_context(|| format!("{}: cannot create", folder.display()))?;
        }
        Ok(Self {
            dir: dir.to_path_buf(),
            size,
            frames: Vec::new(),
        })
    }

    /// Frames written so far.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Whether no frame was written yet.
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Writes `frame` at the writer's size: colour resized (area-weighted), intrinsics scaled with
    /// it, depth upsampled onto its pixels (inverse depth interpolated on one surface, the nearest
    /// sample across an edge: `neuroom_core::depth_upsample`).
    pub fn push(&mut self, frame: SourceFrame) -> anyhow::Result<()> {
        let (w, h) = self.size.of(frame.rgb.width, frame.rgb.height);
        let rgb = resize_rgb(&frame.rgb, w, h);
        let camera = scaled_camera(&frame.camera, w, h);
        let stem = format!("{:05}", self.frames.len());
        let image = PathBuf::from(format!("images/{stem}.png"));
        formats::write_rgb(self.dir.join(&image), &rgb)?;
        let depth = match &frame.depth {
            Some(d) => {
                let path = PathBuf::from(format!("depths/{stem}.png"));
                formats::write_depth(
                    self.dir.join(&path),
                    &upsample_depth(d, w, h),
                    DEFAULT_DEPTH_UNIT,
                )?;
                Some(path)
            }
            None => None,
        };
        self.frames.push(Frame {
            image,
            depth,
            instance: None,
            camera,
            camera_to_world: frame.camera_to_world.orthonormalized(),
            light: None,
            extra: Map::new(),
        });
        Ok(())
    }

    /// Writes `transforms.json` and returns the capture.
    pub fn finish(self) -> anyhow::Result<Capture> {
        anyhow::ensure!(
            !self.frames.is_empty(),
            "{}: no frame to write",
            self.dir.display()
        );
        let capture = Capture {
            dir: self.dir.clone(),
            frames: self.frames,
            depth_unit_scale_factor: DEFAULT_DEPTH_UNIT,
            // Every app this crate reads tracks its poses and takes its depth from the phone's LiDAR;
            // phones expose every frame themselves.
            device: CaptureDevice {
                auto_exposure: true,
                tracked_poses: true,
                depth_noise: Some(DepthNoise::PHONE_LIDAR),
            },
            extra: Map::new(),
        };
        formats::write_capture(&self.dir, &capture)?;
        Ok(capture)
    }
}

/// `camera` for its image resized to `width × height`: focal lengths and principal point scale with
/// the pixels (continuous coordinates, pixel centres at +0.5), distortion does not.
pub fn scaled_camera(camera: &Pinhole, width: u32, height: u32) -> Pinhole {
    let (sx, sy) = (
        width as f64 / camera.width as f64,
        height as f64 / camera.height as f64,
    );
    Pinhole {
        width,
        height,
        fx: camera.fx * sx,
        fy: camera.fy * sy,
        cx: camera.cx * sx,
        cy: camera.cy * sy,
        ..*camera
    }
}

/// `rgb` at `width × height` (unchanged when it has that size).
fn resize_rgb(rgb: &RgbImage, width: u32, height: u32) -> RgbImage {
    if (rgb.width, rgb.height) == (width, height) {
        return rgb.clone();
    }
    let flat: Vec<f32> = rgb.data.iter().flatten().copied().collect();
    let buffer = image::Rgb32FImage::from_raw(rgb.width, rgb.height, flat)
        .expect("an image's data has width × height pixels");
    let resized = image::imageops::resize(&buffer, width, height, FilterType::Triangle);
    Image {
        width,
        height,
        data: resized
            .pixels()
            .map(|p| p.0.map(|c| c.clamp(0.0, 1.0)))
            .collect(),
    }
}

/// A phone LiDAR depth map (16-bit millimetres) in metres, without the pixels its confidence map
/// (ARKit: 0 low, 1 medium, 2 high; when the file exists) rates below `min_confidence`.
pub fn read_lidar_depth(
    depth: &Path,
    confidence: &Path,
    min_confidence: u8,
) -> anyhow::Result<DepthImage> {
    let mut metres = formats::read_depth(depth, 0.001)?;
    if confidence.is_file() {
        let rating = formats::read_mask(confidence)?;
        formats::check_same_size(
            confidence,
            (rating.width, rating.height),
            depth,
            (metres.width, metres.height),
        )?;
        for (d, c) in metres.data.iter_mut().zip(&rating.data) {
            if *c < min_confidence as u16 {
                *d = 0.0;
            }
        }
    }
    Ok(metres)
}

/// Evenly spread indices of at most `max` of `count` items, the first and the last among them.
pub fn spread(count: usize, max: usize) -> Vec<usize> {
    if count <= max || max == 0 {
        return (0..count).collect();
    }
    if max == 1 {
        return vec![0];
    }
    (0..max)
        .map(|k| (k as f64 * (count - 1) as f64 / (max - 1) as f64).round() as usize)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_scaled_camera_projects_a_point_to_the_same_place_in_the_image() {
        let camera = Pinhole {
            width: 1920,
            height: 1440,
            fx: 1350.0,
            fy: 1351.0,
            cx: 961.0,
            cy: 719.0,
            k1: 0.0,
            k2: 0.0,
            p1: 0.0,
            p2: 0.0,
        };
        let small = scaled_camera(&camera, 640, 480);
        let (x, y) = (0.31, -0.22);
        let full = (camera.fx * x + camera.cx, camera.fy * y + camera.cy);
        let scaled = (small.fx * x + small.cx, small.fy * y + small.cy);
        assert!((full.0 / 3.0 - scaled.0).abs() < 1e-9 && (full.1 / 3.0 - scaled.1).abs() < 1e-9);
    }

    #[test]
    fn spread_takes_the_ends_and_never_repeats() {
        assert_eq!(spread(5, 10), vec![0, 1, 2, 3, 4]);
        assert_eq!(spread(10, 4), vec![0, 3, 6, 9]);
        let many = spread(1001, 300);
        assert_eq!((many[0], *many.last().unwrap(), many.len()), (0, 1000, 300));
        assert!(many.windows(2).all(|w| w[0] < w[1]));
    }

    #[test]
    fn frames_keep_their_aspect() {
        let size = FrameSize { max_width: 640 };
        assert_eq!(size.of(1920, 1440), (640, 480));
        assert_eq!(size.of(320, 240), (320, 240));
        assert_eq!(size.of(1000, 563), (640, 360));
    }
}

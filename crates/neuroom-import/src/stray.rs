//! A Stray Scanner recording: `rgb.mp4` (the colour camera, HEVC), `depth/NNNNNN.png` (LiDAR,
//! 256×192, 16-bit millimetres), `confidence/NNNNNN.png` (0 low, 1 medium, 2 high),
//! `odometry.csv` (per frame: `timestamp, frame, x, y, z, qx, qy, qz, qw`; the camera in OpenCV
//! axes, as the app turns ARKit's camera by 180° about x, in ARKit's gravity-aligned y-up world;
//! recordings of older versions have no header and only the last seven columns) and
//! `camera_matrix.csv` (the colour camera's 3×3 intrinsics, row by row, for the video's frames).

use std::path::{Path, PathBuf};

use glam::{DQuat, DVec3};
use neuroom_core::camera::Pinhole;
use neuroom_core::pose::Pose;

use crate::capture_out::read_lidar_depth;
use crate::video::{self, VideoSize};
use crate::{CameraAxes, ImportOptions, Recording, SourceFrame, WorldUp};

/// A Stray Scanner recording folder.
pub struct StrayRecording {
    dir: PathBuf,
    poses: Vec<Pose>,
    /// Each frame's number, naming its depth and confidence files.
    numbers: Vec<u64>,
    /// The intrinsics of the frames as decoded.
    camera: Pinhole,
    decoded: VideoSize,
    min_confidence: u8,
}

impl StrayRecording {
    /// Reads the recording in `dir`; its frames will be decoded at `options.size`.
    pub fn open(dir: &Path, options: &ImportOptions) -> anyhow::Result<Self> {
        let rows = read_odometry(&dir.join("odometry.csv"))?;
        let stored = video::probe(&dir.join("rgb.mp4"))?;
        let matrix = dir.join("camera_matrix.csv");
        let camera = read_camera_matrix(&matrix, stored)?;
        let (width, height) = options.size.of(stored.width, stored.height);
        Ok(Self {
            dir: dir.to_path_buf(),
            poses: rows.iter().map(|r| r.camera_to_world).collect(),
            numbers: rows.iter().map(|r| r.frame).collect(),
            camera: crate::capture_out::scaled_camera(&camera, width, height),
            decoded: VideoSize { width, height },
            min_confidence: options.min_confidence,
        })
    }

    /// The depth of frame `number` ([`read_lidar_depth`]); `None` when the recording has none.
    fn depth(&self, number: u64) -> anyhow::Result<Option<neuroom_core::image::DepthImage>> {
        let path = self.dir.join(format!("depth/{number:06}.png"));
        if !path.is_file() {
            let npy = path.with_extension("npy");
            anyhow::ensure!(
                !npy.is_file(),
                "{}: depth saved as .npy (Stray Scanner before its PNG depth) is not read; \
                 export the recording again with a current version",
                npy.display()
            );
            return Ok(None);
        }
        let confidence = self.dir.join(format!("confidence/{number:06}.png"));
        read_lidar_depth(&path, &confidence, self.min_confidence).map(Some)
    }
}

impl Recording for StrayRecording {
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
        let video = self.dir.join("rgb.mp4");
        let this = &*self;
        video::decode_frames(&video, indices, this.decoded, &mut |k, rgb| {
            let frame = SourceFrame {
                rgb,
                camera: this.camera,
                camera_to_world: this.poses[k],
                depth: this.depth(this.numbers[k])?,
            };
            each(k, frame)
        })
    }
}

/// One row of `odometry.csv`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OdometryRow {
    /// The frame's number.
    pub frame: u64,
    /// Its camera (OpenGL axes) to ARKit's world.
    pub camera_to_world: Pose,
}

/// Reads `odometry.csv`: with its header (any column order) or, from older versions, seven
/// columns `x, y, z, qx, qy, qz, qw` whose row number is the frame's.
pub fn read_odometry(path: &Path) -> anyhow::Result<Vec<OdometryRow>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let first = lines.clone().next().map(|(_, l)| l).unwrap_or_default();
    let has_header = first.chars().any(|c| c.is_ascii_alphabetic());
    let names: Vec<String> = if has_header {
        lines.next();
        first.split(',').map(|s| s.trim().to_lowercase()).collect()
    } else {
        ["x", "y", "z", "qx", "qy", "qz", "qw"]
            .map(String::from)
            .to_vec()
    };
    let column = |name: &str| {
        names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| anyhow::anyhow!("{}: no `{name}` column in {names:?}", path.display()))
    };
    let cols = ["x", "y", "z", "qx", "qy", "qz", "qw"]
        .into_iter()
        .map(column)
        .collect::<anyhow::Result<Vec<usize>>>()?;
    let frame_col = names.iter().position(|n| n == "frame");
    let mut rows = Vec::new();
    for (row, (line_no, line)) in lines.enumerate() {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let number = |c: usize| -> anyhow::Result<f64> {
            fields
                .get(c)
                .and_then(|f| f.parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    anyhow::anyhow!(
                        "{}: line {}: column `{}` is not a number",
                        path.display(),
                        line_no + 1,
                        names[c]
                    )
                })
        };
        let v: Vec<f64> = cols
            .iter()
            .map(|&c| number(c))
            .collect::<anyhow::Result<_>>()?;
        let q = DQuat::from_xyzw(v[3], v[4], v[5], v[6]);
        anyhow::ensure!(
            (q.length() - 1.0).abs() < 1e-2,
            "{}: line {}: the quaternion has length {:.4}, not 1",
            path.display(),
            line_no + 1,
            q.length()
        );
        let opencv = Pose::new(
            glam::DMat3::from_quat(q.normalize()),
            DVec3::new(v[0], v[1], v[2]),
        );
        let frame = match frame_col {
            Some(c) => number(c)? as u64,
            None => row as u64,
        };
        rows.push(OdometryRow {
            frame,
            camera_to_world: CameraAxes::OpenCv.to_opengl(&opencv),
        });
    }
    anyhow::ensure!(!rows.is_empty(), "{}: no poses", path.display());
    Ok(rows)
}

/// Reads `camera_matrix.csv` (three rows of three numbers) as the intrinsics of `size` frames.
pub fn read_camera_matrix(path: &Path, size: VideoSize) -> anyhow::Result<Pinhole> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
    let values: Vec<f64> = text
        .split([',', '\n', '\r', ' ', '\t'])
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|e| anyhow::anyhow!("{}: not a 3×3 matrix of numbers: {e}", path.display()))?;
    anyhow::ensure!(
        values.len() == 9,
        "{}: expected a 3×3 matrix, found {} numbers",
        path.display(),
        values.len()
    );
    intrinsics_from_matrix(path, &values, size.width, size.height)
}

/// The pinhole camera of a row-major 3×3 intrinsic matrix for `width × height` frames, checked:
/// positive focal lengths, the principal point in the middle half of the frame (where every phone
/// camera has it: a matrix for frames of another size fails here rather than silently).
pub fn intrinsics_from_matrix(
    file: &Path,
    m: &[f64],
    width: u32,
    height: u32,
) -> anyhow::Result<Pinhole> {
    let (fx, fy, cx, cy) = (m[0], m[4], m[2], m[5]);
    anyhow::ensure!(
        fx > 0.0 && fy > 0.0 && fx.is_finite() && fy.is_finite(),
        "{}: focal lengths must be positive, found {fx}, {fy}",
        file.display()
    );
    let middle = |c: f64, n: u32| c > 0.25 * n as f64 && c < 0.75 * n as f64;
    anyhow::ensure!(
        middle(cx, width) && middle(cy, height),
        "{}: principal point ({cx}, {cy}) is not near the middle of the {width}×{height} frames: \
         the matrix is for frames of another size",
        file.display()
    );
    Ok(Pinhole::new(width, height, fx, fy, cx, cy))
}

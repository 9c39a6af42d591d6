//! Touring a solved room: a camera path — read from a JSON list of poses, or generated inside the room
//! box as an orbit or a walk — rendered frame by frame under the solved lighting, written as numbered
//! PNG frames and an animated GIF.
//!
//! A path file is a JSON list whose entries are either `{"eye": [x, y, z], "look_at": [x, y, z]}` or
//! `{"camera_to_world": [[4 rows of 4]]}` (the pinhole OpenGL frame for pinhole frames, the panorama
//! frame of docs/formats.md for panorama frames).

use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail, ensure};
use glam::DVec3;
use neuroom_core::Pose;
use neuroom_core::camera::{Camera, Equirect, Pinhole, look_at};
use neuroom_core::formats::write_rgb;
use neuroom_core::image::RgbImage;
use neuroom_export::animation::write_gif;
use serde::Deserialize;

use crate::view::{SolvedScene, render_camera, solved_scene};

/// One camera of a path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CameraPose {
    /// Standing at `eye`, looking at `target` (world z up).
    LookAt {
        /// Camera centre.
        eye: DVec3,
        /// Point looked at.
        target: DVec3,
    },
    /// A full camera-to-world pose.
    Pose(Pose),
}

impl CameraPose {
    /// The pinhole (OpenGL frame) camera-to-world pose.
    pub fn pinhole(&self) -> Pose {
        match *self {
            CameraPose::LookAt { eye, target } => look_at(eye, target),
            CameraPose::Pose(p) => p,
        }
    }

    /// The panorama camera-to-world pose: upright, its forward axis (+x) turned towards the target.
    pub fn panorama(&self) -> Pose {
        match *self {
            CameraPose::LookAt { eye, target } => {
                let d = target - eye;
                Pose::from_yaw_translation(d.y.atan2(d.x), eye)
            }
            CameraPose::Pose(p) => p,
        }
    }
}

#[derive(Deserialize)]
#[serde(untagged)]
enum PathEntry {
    LookAt { eye: [f64; 3], look_at: [f64; 3] },
    Matrix { camera_to_world: [[f64; 4]; 4] },
}

/// Reads a path file (see the module documentation); errors name the file and the entry.
pub fn read_path(path: &Path) -> anyhow::Result<Vec<CameraPose>> {
    let text = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    let entries: Vec<serde_json::Value> = serde_json::from_slice(&text)
        .with_context(|| format!("{}: expected a JSON list of camera poses", path.display()))?;
    ensure!(!entries.is_empty(), "{}: the path is empty", path.display());
    entries
        .into_iter()
        .enumerate()
        .map(|(k, v)| camera_pose(v).with_context(|| format!("{}: entry {k}", path.display())))
        .collect()
}

fn camera_pose(v: serde_json::Value) -> anyhow::Result<CameraPose> {
    let entry: PathEntry = serde_json::from_value(v).context(
        "expected {\"eye\": [x, y, z], \"look_at\": [x, y, z]} or {\"camera_to_world\": 4×4 rows}",
    )?;
    match entry {
        PathEntry::LookAt { eye, look_at } => {
            let (eye, target) = (DVec3::from(eye), DVec3::from(look_at));
            ensure!(
                eye.is_finite() && target.is_finite(),
                "coordinates must be finite"
            );
            ensure!(
                (target - eye).length() > 1e-6,
                "eye and look_at must differ"
            );
            Ok(CameraPose::LookAt { eye, target })
        }
        PathEntry::Matrix { camera_to_world } => Pose::check_rows(&camera_to_world, 1e-4)
            .map(CameraPose::Pose)
            .map_err(|e| anyhow::anyhow!("camera_to_world: {e}")),
    }
}

/// A generated path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Generated {
    /// Circling the room's centre at eye height, looking across it.
    Orbit(usize),
    /// Walking a closed loop around the room, looking ahead.
    Walk(usize),
}

/// The path `kind` inside the room box `[min, max]`: eye height at 55 % of the room's height; orbits
/// circle the centre at 35 % of the smaller half-width looking across the centre at the far side (down
/// to 30 % of the height), walks follow an ellipse of 55 % of the half-widths looking ahead.
pub fn generate(kind: Generated, min: DVec3, max: DVec3) -> anyhow::Result<Vec<CameraPose>> {
    let (centre, half) = (0.5 * (min + max), 0.5 * (max - min));
    ensure!(
        half.min_element() > 0.0,
        "the room box is empty: {min} .. {max}"
    );
    let eye_z = min.z + 0.55 * (max.z - min.z);
    let angle = |k: usize, n: usize| std::f64::consts::TAU * k as f64 / n as f64;
    match kind {
        Generated::Orbit(n) | Generated::Walk(n) if n == 0 => {
            bail!("a path needs at least one frame")
        }
        Generated::Orbit(n) => {
            let r = 0.35 * half.x.min(half.y);
            let target_z = min.z + 0.3 * (max.z - min.z);
            Ok((0..n)
                .map(|k| {
                    let a = angle(k, n);
                    let out = DVec3::new(a.cos(), a.sin(), 0.0);
                    let eye = centre + r * out;
                    let across = centre - 2.0 * r * out;
                    CameraPose::LookAt {
                        eye: DVec3::new(eye.x, eye.y, eye_z),
                        target: DVec3::new(across.x, across.y, target_z),
                    }
                })
                .collect())
        }
        Generated::Walk(n) => {
            let at = |a: f64| {
                DVec3::new(
                    centre.x + 0.55 * half.x * a.cos(),
                    centre.y + 0.55 * half.y * a.sin(),
                    eye_z,
                )
            };
            Ok((0..n)
                .map(|k| {
                    let a = angle(k, n);
                    let ahead = at(a + 0.6) - DVec3::new(0.0, 0.0, 0.25);
                    CameraPose::LookAt {
                        eye: at(a),
                        target: ahead,
                    }
                })
                .collect())
        }
    }
}

/// The frames' camera model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lens {
    /// Pinhole frames.
    Pinhole {
        /// Width.
        width: u32,
        /// Height.
        height: u32,
        /// Horizontal field of view, degrees.
        fov_deg: f64,
    },
    /// Equirectangular frames `width × width/2`.
    Panorama {
        /// Width (even).
        width: u32,
    },
}

impl Lens {
    /// The camera model and its pose at `pose`.
    pub fn camera(&self, pose: &CameraPose) -> anyhow::Result<(Camera, Pose)> {
        match *self {
            Lens::Pinhole {
                width,
                height,
                fov_deg,
            } => {
                ensure!(width > 0 && height > 0, "image size must be positive");
                ensure!(
                    fov_deg > 1.0 && fov_deg < 179.0,
                    "field of view must lie in (1°, 179°)"
                );
                let f = 0.5 * width as f64 / (0.5 * fov_deg.to_radians()).tan();
                let c = Pinhole::new(width, height, f, f, 0.5 * width as f64, 0.5 * height as f64);
                Ok((Camera::Pinhole(c), pose.pinhole()))
            }
            Lens::Panorama { width } => {
                let c = Equirect::new(width, width / 2).map_err(anyhow::Error::msg)?;
                Ok((Camera::Equirect(c), pose.panorama()))
            }
        }
    }
}

/// Where a sequence goes.
#[derive(Clone, Debug)]
pub struct SequenceOutputs {
    /// Folder of numbered PNG frames (`frame_0000.png`, …).
    pub frames: PathBuf,
    /// The animated GIF.
    pub gif: PathBuf,
    /// Frames per second of the GIF.
    pub fps: f64,
}

impl SequenceOutputs {
    /// Frames in `<gif stem>_frames/` beside the GIF, unless `frames` says otherwise.
    pub fn beside(gif: &Path, frames: Option<&Path>, fps: f64) -> Self {
        let stem = gif
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "sequence".into());
        Self {
            frames: frames
                .map(Path::to_path_buf)
                .unwrap_or_else(|| gif.with_file_name(format!("{stem}_frames"))),
            gif: gif.to_path_buf(),
            fps,
        }
    }

    /// Writes frame `k`.
    pub fn write_frame(&self, k: usize, frame: &RgbImage) -> anyhow::Result<()> {
        std::fs::create_dir_all(&self.frames)
            .with_context(|| format!("creating {}", self.frames.display()))?;
        write_rgb(self.frames.join(format!("frame_{k:04}.png")), frame)?;
        Ok(())
    }

    /// Writes the GIF of all frames.
    pub fn write_gif(&self, frames: &[RgbImage]) -> anyhow::Result<()> {
        write_gif(&self.gif, frames, self.fps)
    }
}

/// The room box of a solved scene (the manifest's, or the room model's bounds).
pub fn room_box(scene: &SolvedScene) -> (DVec3, DVec3) {
    match scene.placed.room_box {
        Some((lo, hi)) => (lo.as_dvec3(), hi.as_dvec3()),
        None => {
            let bg = &scene.lit.scene.background;
            (bg.bounds_min.as_dvec3(), bg.bounds_max.as_dvec3())
        }
    }
}

/// Renders `poses` of the solved scene through `lens`; `progress(done, total)` after each frame.
pub fn render_frames(
    scene: &SolvedScene,
    poses: &[CameraPose],
    lens: &Lens,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<Vec<RgbImage>> {
    let mut frames = Vec::with_capacity(poses.len());
    for (k, pose) in poses.iter().enumerate() {
        let (camera, camera_to_world) = lens.camera(pose)?;
        frames.push(render_camera(scene, &camera, &camera_to_world, &|_| {}).rgb);
        progress(k + 1, poses.len());
    }
    Ok(frames)
}

/// Which path to tour.
#[derive(Clone, Debug)]
pub enum TourPath {
    /// A path file.
    File(PathBuf),
    /// A generated path.
    Generated(Generated),
}

/// Renders a tour of the models in `models` placed by `arrangement` under its solved lighting, and
/// writes the frames and the GIF. Returns the number of frames.
pub fn tour(
    models: &Path,
    arrangement: &Path,
    path: &TourPath,
    lens: &Lens,
    outputs: &SequenceOutputs,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<usize> {
    let scene = solved_scene(models, arrangement)?;
    let poses = match path {
        TourPath::File(p) => read_path(p)?,
        TourPath::Generated(g) => {
            let (lo, hi) = room_box(&scene);
            generate(*g, lo, hi)?
        }
    };
    let frames = render_frames(&scene, &poses, lens, progress)?;
    for (k, f) in frames.iter().enumerate() {
        outputs.write_frame(k, f)?;
    }
    outputs.write_gif(&frames)?;
    Ok(frames.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_core::formats::write_arrangement;
    use neuroom_testing::{ROOM_MAX, ROOM_MIN, tiny_arrangement, write_tiny_models};

    fn room() -> (DVec3, DVec3) {
        (
            glam::Vec3::from(ROOM_MIN).as_dvec3(),
            glam::Vec3::from(ROOM_MAX).as_dvec3(),
        )
    }

    #[test]
    fn generated_paths_stay_inside_the_room_and_close_their_loop() {
        let (lo, hi) = room();
        for kind in [Generated::Orbit(12), Generated::Walk(12)] {
            let poses = generate(kind, lo, hi).unwrap();
            assert_eq!(poses.len(), 12);
            for p in &poses {
                let CameraPose::LookAt { eye, target } = *p else {
                    panic!("generated paths look at points")
                };
                assert!(eye.cmpgt(lo).all() && eye.cmplt(hi).all(), "{eye} outside");
                assert!(target.cmpgt(lo).all() && target.cmplt(hi).all());
                let forward = p.pinhole().transform_vector(-DVec3::Z);
                assert!((forward - (target - eye).normalize()).length() < 1e-9);
            }
        }
        assert!(generate(Generated::Orbit(0), lo, hi).is_err());
    }

    #[test]
    fn panorama_poses_turn_towards_the_target_and_stay_upright() {
        let p = CameraPose::LookAt {
            eye: DVec3::new(1.0, 1.0, 1.5),
            target: DVec3::new(1.0, 3.0, 0.5),
        };
        let pano = p.panorama();
        assert!((pano.yaw() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!((pano.transform_vector(DVec3::Z) - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn path_files_are_read_and_bad_entries_named() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("path.json");
        let pose = Pose::from_yaw_translation(0.2, DVec3::new(1.0, 1.0, 1.2)).to_rows();
        let text = serde_json::json!([
            { "eye": [1.0, 1.0, 1.5], "look_at": [2.0, 1.0, 1.0] },
            { "camera_to_world": pose },
        ]);
        std::fs::write(&good, text.to_string()).unwrap();
        let poses = read_path(&good).unwrap();
        assert_eq!(poses.len(), 2);
        assert!(matches!(poses[1], CameraPose::Pose(_)));
        let bad = dir.path().join("bad.json");
        std::fs::write(
            &bad,
            r#"[{"eye": [1, 1, 1], "look_at": [2, 2, 2]}, {"eye": [1, 1]}]"#,
        )
        .unwrap();
        let e = format!("{:#}", read_path(&bad).unwrap_err());
        assert!(e.contains("bad.json") && e.contains("entry 1"), "{e}");
        let skewed = dir.path().join("skewed.json");
        std::fs::write(
            &skewed,
            r#"[{"camera_to_world": [[2,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}]"#,
        )
        .unwrap();
        assert!(read_path(&skewed).is_err());
    }

    #[test]
    fn a_tour_writes_every_frame_and_a_gif() {
        let dir = tempfile::tempdir().unwrap();
        let models = dir.path().join("models");
        write_tiny_models(&models).unwrap();
        let arrangement = dir.path().join("arr.json");
        write_arrangement(&arrangement, &tiny_arrangement()).unwrap();
        let outputs = SequenceOutputs::beside(&dir.path().join("tour.gif"), None, 8.0);
        let lens = Lens::Pinhole {
            width: 24,
            height: 16,
            fov_deg: 70.0,
        };
        let mut calls = Vec::new();
        let n = tour(
            &models,
            &arrangement,
            &TourPath::Generated(Generated::Orbit(3)),
            &lens,
            &outputs,
            &mut |d, t| calls.push((d, t)),
        )
        .unwrap();
        assert_eq!(n, 3);
        assert_eq!(calls, vec![(1, 3), (2, 3), (3, 3)]);
        for k in 0..3 {
            assert!(outputs.frames.join(format!("frame_{k:04}.png")).exists());
        }
        let gif = std::fs::read(&outputs.gif).unwrap();
        assert_eq!(&gif[..6], b"GIF89a");
    }
}

//! Refined camera poses (docs/formats.md, "Refined poses"): the poses of a tracked capture's frames as
//! training corrected them, written beside the model trained on it. A phone's tracker drifts by a
//! centimetre or two; the corrected poses agree with the model's geometry, so whatever looks at the
//! capture through the model (carving its surface clouds, exporting the cameras) reads these instead.

use super::json::{
    JsonObject, as_integer_in, as_nonempty_str, as_pose, parse_json, pose_value, write_json,
};
use crate::error::{FormatError, FormatResult};
use crate::pose::Pose;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// The format tag this module reads and writes.
pub const REFINED_POSES_FORMAT: &str = "neuroom.refined_poses/1";

/// The file name of refined poses inside a model folder.
pub const REFINED_POSES_FILE: &str = "refined_poses.json";

/// The corrected poses of the frames a model was trained on.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinedPoses {
    /// One entry per training frame, in the capture's order (held-out frames have none).
    pub frames: Vec<RefinedFrame>,
}

/// One frame's corrected pose.
#[derive(Clone, Debug, PartialEq)]
pub struct RefinedFrame {
    /// The frame's position in its capture's `transforms.json` (from 0).
    pub index: usize,
    /// The frame's colour image as the capture names it, to tell a capture recorded anew.
    pub image: PathBuf,
    /// Camera-to-capture-frame pose, in `transforms.json`'s convention (OpenGL camera).
    pub camera_to_world: Pose,
}

/// Reads a refined poses file, rejecting a wrong format tag, bad poses and indices out of order.
pub fn read_refined_poses(path: impl AsRef<Path>) -> FormatResult<RefinedPoses> {
    let file = path.as_ref();
    let bytes =
        std::fs::read(file).map_err(|e| FormatError::file(file, format!("cannot read: {e}")))?;
    let value = parse_json(file, &bytes)?;
    let top = JsonObject::root(file, &value)?;
    top.check_format(REFINED_POSES_FORMAT)?;
    let frames = top
        .objects("frames")?
        .iter()
        .map(|f| {
            Ok(RefinedFrame {
                index: f.required("index", as_integer_in(0, u32::MAX as u64))? as usize,
                image: PathBuf::from(f.required("image", as_nonempty_str)?),
                camera_to_world: f.required("transform_matrix", as_pose)?,
            })
        })
        .collect::<FormatResult<Vec<_>>>()?;
    check_increasing(file, &frames)?;
    Ok(RefinedPoses { frames })
}

/// Writes `poses` to `path` atomically, checking what the reader checks.
pub fn write_refined_poses(path: impl AsRef<Path>, poses: &RefinedPoses) -> FormatResult<()> {
    let file = path.as_ref();
    check_increasing(file, &poses.frames)?;
    let frames = poses
        .frames
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let mut m = Map::new();
            m.insert("index".into(), f.index.into());
            m.insert(
                "image".into(),
                f.image.to_string_lossy().into_owned().into(),
            );
            m.insert(
                "transform_matrix".into(),
                pose_value(
                    file,
                    &format!("frames[{i}].transform_matrix"),
                    &f.camera_to_world,
                )?,
            );
            Ok(Value::Object(m))
        })
        .collect::<FormatResult<Vec<_>>>()?;
    let mut top = Map::new();
    top.insert("format".into(), REFINED_POSES_FORMAT.into());
    top.insert("frames".into(), frames.into());
    write_json(file, &Value::Object(top))
}

/// Frame indices must rise strictly: each frame is refined once.
fn check_increasing(file: &Path, frames: &[RefinedFrame]) -> FormatResult<()> {
    match frames.windows(2).position(|w| w[1].index <= w[0].index) {
        Some(i) => Err(FormatError::field(
            file,
            format!("frames[{}].index", i + 1),
            format!(
                "{} follows {}: indices must rise, each frame once",
                frames[i + 1].index,
                frames[i].index
            ),
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DVec3};

    fn frame(index: usize) -> RefinedFrame {
        RefinedFrame {
            index,
            image: PathBuf::from(format!("images/{index:04}.jpg")),
            camera_to_world: Pose::new(
                DMat3::from_rotation_z(0.1 * index as f64),
                DVec3::new(index as f64, 0.5, 1.5),
            ),
        }
    }

    #[test]
    fn round_trips() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REFINED_POSES_FILE);
        let poses = RefinedPoses {
            frames: vec![frame(1), frame(2), frame(5)],
        };
        write_refined_poses(&path, &poses).unwrap();
        let back = read_refined_poses(&path).unwrap();
        assert_eq!(back.frames.len(), 3);
        for (a, b) in back.frames.iter().zip(&poses.frames) {
            assert_eq!((a.index, &a.image), (b.index, &b.image));
            let d = a.camera_to_world.to_mat4() - b.camera_to_world.to_mat4();
            assert!(d.to_cols_array().iter().all(|x| x.abs() < 1e-12));
        }
    }

    #[test]
    fn indices_out_of_order_name_the_frame() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REFINED_POSES_FILE);
        let poses = RefinedPoses {
            frames: vec![frame(3), frame(3)],
        };
        let err = write_refined_poses(&path, &poses).unwrap_err().to_string();
        assert!(err.contains("frames[1].index"), "{err}");
        std::fs::write(
            &path,
            r#"{"format": "neuroom.refined_poses/1", "frames": [{"index": 0, "image": "a.jpg"}]}"#,
        )
        .unwrap();
        let err = read_refined_poses(&path).unwrap_err().to_string();
        assert!(err.contains("transform_matrix"), "{err}");
    }
}

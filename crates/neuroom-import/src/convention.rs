//! The one place where the coordinate conventions of capture apps become neuroom's: cameras in the
//! OpenGL frame (looking along −z, +y up), worlds with z up, in metres (docs/formats.md, "Frames and
//! conventions").

use glam::{DMat3, DVec3};
use neuroom_core::pose::Pose;

/// How a source's camera frame is laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraAxes {
    /// x right, y up, looking along −z: OpenGL, nerfstudio, ARKit's `camera.transform`.
    OpenGl,
    /// x right, y down, looking along +z: OpenCV, COLMAP, Stray Scanner's odometry.
    OpenCv,
}

impl CameraAxes {
    /// The camera-to-world pose `pose` (this layout) as an OpenGL camera's: the y and z axes of the
    /// camera flip, the world stays.
    pub fn to_opengl(self, pose: &Pose) -> Pose {
        match self {
            CameraAxes::OpenGl => *pose,
            CameraAxes::OpenCv => Pose::new(
                pose.rotation * DMat3::from_diagonal(DVec3::new(1.0, -1.0, -1.0)),
                pose.translation,
            ),
        }
    }
}

/// Which way is up in a source's world.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WorldUp {
    /// +z, as neuroom has it (nerfstudio's Polycam data).
    Z,
    /// +y: ARKit's gravity-aligned world (Stray Scanner, 3D Scanner App, Record3D).
    Y,
    /// Found from the cameras ([`up_from_cameras`]).
    Auto,
}

/// A mean camera up within this angle of a world axis (degrees) is taken to be that axis: worlds
/// that capture apps align with gravity have an axis for up, and the cameras' mean up leans off it
/// only by how the phone was held on average.
pub const AXIS_SNAP_DEG: f64 = 25.0;

/// The world's up from OpenGL camera poses: the mean of the cameras' up axes (people hold a camera
/// upright, leaning it about as much one way as the other), or the world axis it lies within
/// [`AXIS_SNAP_DEG`] of. `None` without cameras or when their ups cancel out.
pub fn up_from_cameras(poses: &[Pose]) -> Option<DVec3> {
    let sum: DVec3 = poses.iter().map(|p| p.rotation.col(1)).sum();
    let mean = sum.try_normalize()?;
    if sum.length() < 0.5 * poses.len() as f64 {
        return None;
    }
    let axes = [DVec3::X, DVec3::Y, DVec3::Z];
    let snapped = axes
        .iter()
        .flat_map(|&a| [a, -a])
        .find(|a| a.dot(mean) >= AXIS_SNAP_DEG.to_radians().cos());
    Some(snapped.unwrap_or(mean))
}

/// How source coordinates become neuroom's world: `p ↦ scale · rotation · p`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorldFrame {
    /// Turns the source's up onto +z.
    pub rotation: DMat3,
    /// Metres per source unit.
    pub scale: f64,
}

impl WorldFrame {
    /// The frame that turns `up` (a unit vector of the source world) onto +z by the smallest
    /// rotation, with `scale` metres per source unit.
    pub fn with_up(up: DVec3, scale: f64) -> Self {
        Self {
            rotation: DMat3::from_quat(glam::DQuat::from_rotation_arc(up.normalize(), DVec3::Z)),
            scale,
        }
    }

    /// The frame for a source whose up is `up`, given the source's OpenGL camera poses (for
    /// [`WorldUp::Auto`]); `None` when `Auto` finds no up.
    pub fn for_source(up: WorldUp, poses: &[Pose], scale: f64) -> Option<Self> {
        let up = match up {
            WorldUp::Z => DVec3::Z,
            WorldUp::Y => DVec3::Y,
            WorldUp::Auto => up_from_cameras(poses)?,
        };
        Some(Self::with_up(up, scale))
    }

    /// A camera-to-world pose of the source world in neuroom's.
    pub fn pose(&self, pose: &Pose) -> Pose {
        Pose::new(
            self.rotation * pose.rotation,
            self.scale * (self.rotation * pose.translation),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_pose(rng: &mut rand_pcg::Pcg64) -> Pose {
        let axis = DVec3::new(rng.random(), rng.random(), rng.random()) - 0.5;
        let rotation = DMat3::from_axis_angle(axis.normalize(), rng.random_range(-3.0..3.0));
        Pose::new(
            rotation,
            DVec3::new(rng.random(), rng.random(), rng.random()),
        )
    }

    #[test]
    fn an_opencv_camera_sees_along_the_opengl_cameras_minus_z() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
        for _ in 0..100 {
            let cv = random_pose(&mut rng);
            let gl = CameraAxes::OpenCv.to_opengl(&cv);
            // OpenCV looks along +z and has y down; OpenGL looks along −z and has y up.
            assert!((gl.rotation * -DVec3::Z - cv.rotation * DVec3::Z).length() < 1e-12);
            assert!((gl.rotation * DVec3::Y + cv.rotation * DVec3::Y).length() < 1e-12);
            assert!((gl.rotation * DVec3::X - cv.rotation * DVec3::X).length() < 1e-12);
            assert_eq!(gl.translation, cv.translation);
            assert!((gl.rotation.determinant() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn arkit_y_up_becomes_z_up_keeping_the_world_right_handed() {
        let frame = WorldFrame::for_source(WorldUp::Y, &[], 1.0).unwrap();
        assert!((frame.rotation * DVec3::Y - DVec3::Z).length() < 1e-12);
        assert!((frame.rotation.determinant() - 1.0).abs() < 1e-12);
        // A camera 1.5 m up in ARKit (y) stands 1.5 m up here (z).
        let camera = Pose::new(DMat3::IDENTITY, DVec3::new(0.2, 1.5, -3.0));
        let moved = frame.pose(&camera);
        assert!((moved.translation.z - 1.5).abs() < 1e-12);
        // Its up (+y of an upright OpenGL camera) is the world's up.
        assert!((moved.rotation.col(1) - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn the_cameras_up_snaps_to_an_axis_or_stays_their_mean() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(2);
        // Upright cameras in a y-up world, leaning up to 20° and turned any way about y.
        let leaning = |max_deg: f64, rng: &mut rand_pcg::Pcg64| {
            let lean = DMat3::from_rotation_x(rng.random_range(-max_deg..max_deg).to_radians());
            Pose::new(
                DMat3::from_rotation_y(rng.random_range(-3.1..3.1)) * lean,
                DVec3::ZERO,
            )
        };
        let poses: Vec<Pose> = (0..50).map(|_| leaning(20.0, &mut rng)).collect();
        assert_eq!(up_from_cameras(&poses), Some(DVec3::Y));
        // Tilted 40° off every axis (a COLMAP world): the mean stays.
        let tilt =
            DMat3::from_axis_angle(DVec3::new(1.0, 0.0, 1.0).normalize(), 40f64.to_radians());
        let tilted: Vec<Pose> = poses
            .iter()
            .map(|p| Pose::new(tilt * p.rotation, DVec3::ZERO))
            .collect();
        let up = up_from_cameras(&tilted).unwrap();
        assert!(up.angle_between(tilt * DVec3::Y).to_degrees() < 5.0);
        let frame = WorldFrame::with_up(up, 1.0);
        assert!((frame.rotation * up - DVec3::Z).length() < 1e-12);
        assert_eq!(up_from_cameras(&[]), None);
    }
}

//! The poses the object search's descent visits, on a fine lattice of positions and headings.
//!
//! A descent moves an object by whole steps (centimetres, degrees); on the lattice a pose reached along
//! two paths (two starts that meet, a step forth and back) is the same pose to the bit, so its score is
//! looked up rather than computed again ([`crate::memo`]). The lattice is far finer than anything a
//! panorama resolves (a 512-pixel-wide pixel spans 3.7 cm at 3 m), so snapping a start onto it moves the
//! object by a negligible amount.

use glam::DVec3;
use neuroom_core::pose::Pose;

/// Metres per lattice unit of position.
const POSITION_UNIT: f64 = 1e-4;

/// Degrees per lattice unit of heading.
const YAW_UNIT_DEG: f64 = 0.01;

/// Lattice units of heading in a whole turn.
const TURN: i64 = 36_000;

/// A pose standing upright at a lattice position, turned by a lattice heading about the vertical.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub(crate) struct LatticePose {
    /// Position in [`POSITION_UNIT`]s.
    position: [i64; 3],
    /// Heading in [`YAW_UNIT_DEG`]s, in `[0, TURN)`.
    yaw: i64,
}

impl LatticePose {
    /// The lattice pose nearest to an upright `pose` (its heading and position; a tilt is dropped).
    pub(crate) fn nearest(pose: &Pose) -> Self {
        let t = pose.translation / POSITION_UNIT;
        Self {
            position: [t.x, t.y, t.z].map(|v| v.round() as i64),
            yaw: ((pose.yaw().to_degrees() / YAW_UNIT_DEG).round() as i64).rem_euclid(TURN),
        }
    }

    /// The pose itself: equal lattice poses give bitwise equal poses.
    pub(crate) fn pose(&self) -> Pose {
        let [x, y, z] = self.position.map(|v| v as f64 * POSITION_UNIT);
        Pose::from_yaw_translation(self.yaw_rad(), DVec3::new(x, y, z))
    }

    /// This pose moved by `offset` (metres, world frame), to the nearest lattice position.
    pub(crate) fn moved(&self, offset: DVec3) -> Self {
        let d = offset / POSITION_UNIT;
        let [x, y, z] = self.position;
        Self {
            position: [
                x + d.x.round() as i64,
                y + d.y.round() as i64,
                z + d.z.round() as i64,
            ],
            ..*self
        }
    }

    /// This pose turned by `degrees` about the vertical, to the nearest lattice heading.
    pub(crate) fn turned(&self, degrees: f64) -> Self {
        let d = (degrees / YAW_UNIT_DEG).round() as i64;
        Self {
            yaw: (self.yaw + d).rem_euclid(TURN),
            ..*self
        }
    }

    /// The heading in radians.
    pub(crate) fn yaw_rad(&self) -> f64 {
        (self.yaw as f64 * YAW_UNIT_DEG).to_radians()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_reached_along_two_paths_is_the_same_pose() {
        let start = LatticePose::nearest(&Pose::from_yaw_translation(
            2.0,
            DVec3::new(1.234_567, -0.5, 0.45),
        ));
        let a = start
            .moved(DVec3::new(0.1, 0.0, 0.0))
            .turned(15.0)
            .moved(DVec3::new(0.0, 0.05, 0.0));
        let b = start
            .turned(8.0)
            .moved(DVec3::new(0.07, 0.07, 0.0) * 0.5)
            .turned(7.0)
            .moved(DVec3::new(0.1 - 0.035, 0.05 - 0.035, 0.0));
        assert_eq!(a, b);
        assert_eq!(a.pose(), b.pose());
    }

    #[test]
    fn headings_wrap_around_a_whole_turn() {
        let p = LatticePose::nearest(&Pose::from_yaw_translation(3.0, DVec3::ZERO));
        assert_eq!(p.turned(360.0), p);
        assert_eq!(p.turned(180.0).turned(180.0), p);
        assert_eq!(p.turned(-10.0).turned(10.0), p);
    }

    #[test]
    fn the_nearest_lattice_pose_is_within_half_a_unit() {
        let pose = Pose::from_yaw_translation(-2.5, DVec3::new(3.123_456_7, 2.765_432_1, 0.577_21));
        let snapped = LatticePose::nearest(&pose).pose();
        let dt = (snapped.translation - pose.translation).abs().max_element();
        assert!(dt <= 0.5 * POSITION_UNIT + 1e-12, "{dt}");
        let dyaw = (snapped.yaw() - pose.yaw()).abs().to_degrees();
        assert!(dyaw <= 0.5 * YAW_UNIT_DEG + 1e-9, "{dyaw}");
    }
}

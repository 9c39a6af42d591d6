//! Rigid poses: a proper rotation and a translation in metres, no scale (docs/formats.md).

use glam::{DMat3, DMat4, DVec3, DVec4, Mat3, Vec3};

/// A rigid transform `x ↦ R x + t`, e.g. `object_to_world` or `camera_to_world`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pose {
    /// Proper rotation (orthonormal, det +1).
    pub rotation: DMat3,
    /// Translation in metres.
    pub translation: DVec3,
}

impl Default for Pose {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Pose {
    /// The identity transform.
    pub const IDENTITY: Self = Self {
        rotation: DMat3::IDENTITY,
        translation: DVec3::ZERO,
    };

    /// A pose from its parts.
    pub fn new(rotation: DMat3, translation: DVec3) -> Self {
        Self {
            rotation,
            translation,
        }
    }

    /// A pose rotating by `yaw` radians about +z, then translating.
    pub fn from_yaw_translation(yaw: f64, translation: DVec3) -> Self {
        Self {
            rotation: DMat3::from_rotation_z(yaw),
            translation,
        }
    }

    /// Maps a point.
    pub fn transform_point(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// Maps a direction (no translation).
    pub fn transform_vector(&self, v: DVec3) -> DVec3 {
        self.rotation * v
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Self {
        let rt = self.rotation.transpose();
        Self {
            rotation: rt,
            translation: -(rt * self.translation),
        }
    }

    /// `self ∘ other`: first `other`, then `self`.
    pub fn compose(&self, other: &Pose) -> Self {
        Self {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// The 4×4 homogeneous matrix.
    pub fn to_mat4(&self) -> DMat4 {
        DMat4::from_cols(
            self.rotation.x_axis.extend(0.0),
            self.rotation.y_axis.extend(0.0),
            self.rotation.z_axis.extend(0.0),
            self.translation.extend(1.0),
        )
    }

    /// Rows of the 4×4 matrix, as written in the JSON formats.
    pub fn to_rows(&self) -> [[f64; 4]; 4] {
        let m = self.to_mat4().transpose();
        [
            m.x_axis.to_array(),
            m.y_axis.to_array(),
            m.z_axis.to_array(),
            m.w_axis.to_array(),
        ]
    }

    /// Builds a pose from 4 rows of a homogeneous matrix without checking it (see [`Pose::check_rows`]).
    pub fn from_rows_unchecked(rows: &[[f64; 4]; 4]) -> Self {
        let m = DMat4::from_cols(
            DVec4::from(rows[0]),
            DVec4::from(rows[1]),
            DVec4::from(rows[2]),
            DVec4::from(rows[3]),
        )
        .transpose();
        Self {
            rotation: DMat3::from_cols(
                m.x_axis.truncate(),
                m.y_axis.truncate(),
                m.z_axis.truncate(),
            ),
            translation: m.w_axis.truncate(),
        }
    }

    /// Checks that rows form a rigid transform: finite, last row (0 0 0 1), rotation orthonormal with
    /// det +1 within `tol`. Returns a message saying what is wrong.
    pub fn check_rows(rows: &[[f64; 4]; 4], tol: f64) -> Result<Self, String> {
        if rows.iter().flatten().any(|x| !x.is_finite()) {
            return Err("matrix holds a non-finite number".into());
        }
        let last = rows[3];
        if (last[0].abs() + last[1].abs() + last[2].abs() + (last[3] - 1.0).abs()) > 1e-6 {
            return Err(format!("last row must be [0, 0, 0, 1], found {last:?}"));
        }
        let pose = Self::from_rows_unchecked(rows);
        let r = pose.rotation;
        let err = (r.transpose() * r - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |a, x| a.max(x.abs()));
        if err > tol {
            return Err(format!(
                "rotation is not orthonormal (max |RᵀR − I| = {err:.2e}; scale is not allowed)"
            ));
        }
        if r.determinant() < 0.0 {
            return Err("rotation is a reflection (det −1)".into());
        }
        Ok(pose)
    }

    /// Re-orthonormalises the rotation (nearest proper rotation by Gram–Schmidt on the columns),
    /// used after reading matrices written with limited precision.
    pub fn orthonormalized(&self) -> Self {
        let x = self.rotation.x_axis.normalize();
        let y = (self.rotation.y_axis - x * x.dot(self.rotation.y_axis)).normalize();
        let z = x.cross(y);
        Self {
            rotation: DMat3::from_cols(x, y, z),
            translation: self.translation,
        }
    }

    /// Rotation in single precision, for the renderer.
    pub fn rotation_f32(&self) -> Mat3 {
        self.rotation.as_mat3()
    }

    /// Translation in single precision, for the renderer.
    pub fn translation_f32(&self) -> Vec3 {
        self.translation.as_vec3()
    }

    /// Heading angle of the rotated +x axis about +z, in radians (−π, π].
    pub fn yaw(&self) -> f64 {
        let x = self.rotation.x_axis;
        x.y.atan2(x.x)
    }

    /// The rigid transform that best maps the points `from` onto their partners `to` in the least
    /// squares sense (Kabsch's solution, no scale), as trajectories are aligned before their error is
    /// measured. `None` for fewer than three pairs, lists of different lengths, or points that
    /// all lie on one line.
    pub fn aligning(from: &[DVec3], to: &[DVec3]) -> Option<Self> {
        if from.len() != to.len() || from.len() < 3 {
            return None;
        }
        let n = from.len() as f64;
        let (cf, ct) = (from.iter().sum::<DVec3>() / n, to.iter().sum::<DVec3>() / n);
        let mut cov = nalgebra::Matrix3::<f64>::zeros();
        for (f, t) in from.iter().zip(to) {
            let (a, b) = (*f - cf, *t - ct);
            cov += nalgebra::Vector3::new(b.x, b.y, b.z) * nalgebra::RowVector3::new(a.x, a.y, a.z);
        }
        let svd = cov.svd(true, true);
        let (u, v_t) = (svd.u?, svd.v_t?);
        let mut sorted = svd.singular_values.as_slice().to_vec();
        sorted.sort_by(f64::total_cmp);
        if sorted[1] <= 1e-12 * sorted[2].max(1e-300) {
            return None;
        }
        let flip = (u * v_t).determinant().signum();
        let r = u * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, flip)) * v_t;
        // nalgebra stores its matrices by columns, as glam reads them.
        let rotation = DMat3::from_cols_slice(r.as_slice());
        Some(Self::new(rotation, ct - rotation * cf))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rows_round_trip_and_inverse() {
        let p = Pose::new(
            DMat3::from_euler(glam::EulerRot::ZYX, 0.3, -0.2, 0.1),
            DVec3::new(1.0, -2.0, 0.5),
        );
        let rows = p.to_rows();
        assert_eq!(rows[0][3], 1.0);
        let q = Pose::check_rows(&rows, 1e-9).unwrap();
        let x = DVec3::new(0.2, 0.7, -1.1);
        assert!((q.transform_point(x) - p.transform_point(x)).length() < 1e-12);
        assert!((p.inverse().transform_point(p.transform_point(x)) - x).length() < 1e-12);
        assert!((p.compose(&p.inverse()).translation).length() < 1e-12);
    }

    #[test]
    fn aligning_recovers_a_rigid_motion_and_refuses_a_line() {
        let motion = Pose::new(
            DMat3::from_euler(glam::EulerRot::ZYX, 0.4, 0.1, -0.3),
            DVec3::new(0.5, -1.0, 2.0),
        );
        let from: Vec<DVec3> = (0..7)
            .map(|k| {
                let k = k as f64;
                DVec3::new(k.cos(), (1.3 * k).sin(), 0.1 * k * k)
            })
            .collect();
        let to: Vec<DVec3> = from.iter().map(|&p| motion.transform_point(p)).collect();
        let found = Pose::aligning(&from, &to).unwrap();
        for (f, t) in from.iter().zip(&to) {
            assert!((found.transform_point(*f) - *t).length() < 1e-9);
        }
        assert!((found.rotation.determinant() - 1.0).abs() < 1e-9);
        let line: Vec<DVec3> = (0..5).map(|k| DVec3::X * k as f64).collect();
        assert!(Pose::aligning(&line, &line).is_none());
        assert!(Pose::aligning(&from[..2], &to[..2]).is_none());
    }

    #[test]
    fn rejects_scale_reflection_and_nan() {
        let mut rows = Pose::IDENTITY.to_rows();
        rows[0][0] = 2.0;
        assert!(
            Pose::check_rows(&rows, 1e-4)
                .unwrap_err()
                .contains("orthonormal")
        );
        rows[0][0] = -1.0;
        assert!(
            Pose::check_rows(&rows, 1e-4)
                .unwrap_err()
                .contains("reflection")
        );
        rows[0][0] = f64::NAN;
        assert!(
            Pose::check_rows(&rows, 1e-4)
                .unwrap_err()
                .contains("non-finite")
        );
    }
}

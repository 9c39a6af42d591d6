//! The continuous 6D rotation representation of Zhou et al. (CVPR 2019), with its gradient.
//!
//! Six numbers `[a1, a2]` are the first two columns of a matrix before Gram–Schmidt:
//! `b1 = a1/|a1|`, `b2 = normalise(a2 − (b1·a2) b1)`, `b3 = b1 × b2`, `R = [b1 b2 b3]` (columns).
//! Unlike Euler angles or quaternions, this map has no discontinuity, which is why pose optimisation
//! uses it. The f64 functions serve geometry and tests; the `_f32` twins serve the renderer. Both are
//! generated from one macro so they cannot drift apart.

use glam::{DMat3, DVec3, Mat3, Vec3};

/// Generates the forward map, its inverse and its backward pass for one float precision.
macro_rules! rotation6d_impl {
    ($t:ty, $vec:ty, $mat:ty, $from:ident, $to:ident, $backward:ident) => {
        /// The proper rotation `[b1 b2 b3]` obtained from `[a1, a2]` by Gram–Schmidt (see the module docs).
        ///
        /// `a1` must be non-zero and `a2` not parallel to it, or the result is not finite.
        pub fn $from(a: [$t; 6]) -> $mat {
            let (a1, a2) = (<$vec>::new(a[0], a[1], a[2]), <$vec>::new(a[3], a[4], a[5]));
            let b1 = a1 / a1.length();
            let u = a2 - b1 * b1.dot(a2);
            let b2 = u / u.length();
            <$mat>::from_cols(b1, b2, b1.cross(b2))
        }

        /// The 6D representation of a rotation: its first two columns (so `from(to(R)) = R`).
        pub fn $to(r: $mat) -> [$t; 6] {
            let (c1, c2) = (r.x_axis, r.y_axis);
            [c1.x, c1.y, c1.z, c2.x, c2.y, c2.z]
        }

        /// Gradient of a scalar loss with respect to the six numbers `a`, given its gradient `d_r`
        /// with respect to the rotation matrix returned by the forward map (same column layout).
        pub fn $backward(a: [$t; 6], d_r: $mat) -> [$t; 6] {
            let (a1, a2) = (<$vec>::new(a[0], a[1], a[2]), <$vec>::new(a[3], a[4], a[5]));
            let n1 = a1.length();
            let b1 = a1 / n1;
            let s = b1.dot(a2);
            let u = a2 - b1 * s;
            let n2 = u.length();
            let b2 = u / n2;
            let (g1, g2, g3) = (d_r.x_axis, d_r.y_axis, d_r.z_axis);
            // b3 = b1 × b2, so L = g3 · (b1 × b2) = b1 · (b2 × g3) = b2 · (g3 × b1).
            let g_b2 = g2 + g3.cross(b1);
            // b2 = u / |u|: project out the radial part.
            let g_u = (g_b2 - b2 * b2.dot(g_b2)) / n2;
            // u = a2 − (b1·a2) b1.
            let g_a2 = g_u - b1 * b1.dot(g_u);
            let g_b1 = g1 + b2.cross(g3) - g_u * s - a2 * g_u.dot(b1);
            // b1 = a1 / |a1|.
            let g_a1 = (g_b1 - b1 * b1.dot(g_b1)) / n1;
            [g_a1.x, g_a1.y, g_a1.z, g_a2.x, g_a2.y, g_a2.z]
        }
    };
}

rotation6d_impl!(
    f64,
    DVec3,
    DMat3,
    rotation_from_6d,
    rotation_to_6d,
    rotation_from_6d_backward
);
rotation6d_impl!(
    f32,
    Vec3,
    Mat3,
    rotation_from_6d_f32,
    rotation_to_6d_f32,
    rotation_from_6d_backward_f32
);

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn random_6d(rng: &mut Pcg64) -> [f64; 6] {
        std::array::from_fn(|_| rng.random_range(-2.0..2.0))
    }

    fn random_mat(rng: &mut Pcg64) -> DMat3 {
        DMat3::from_cols_array(&std::array::from_fn(|_| rng.random_range(-1.0..1.0)))
    }

    /// A scalar loss `Σ W ∘ R` whose gradient with respect to R is exactly W.
    fn loss(a: [f64; 6], w: DMat3) -> f64 {
        let r = rotation_from_6d(a);
        (0..3).map(|i| r.col(i).dot(w.col(i))).sum()
    }

    #[test]
    fn forward_is_a_proper_rotation_and_inverts_to_6d() {
        let mut rng = Pcg64::seed_from_u64(1);
        for _ in 0..50 {
            let r = rotation_from_6d(random_6d(&mut rng));
            let err = (r.transpose() * r - DMat3::IDENTITY)
                .to_cols_array()
                .iter()
                .fold(0.0f64, |m, x| m.max(x.abs()));
            assert!(err < 1e-12);
            assert!((r.determinant() - 1.0).abs() < 1e-12);
            assert!(rotation_from_6d(rotation_to_6d(r)).abs_diff_eq(r, 1e-14));
        }
        let r = DMat3::from_rotation_z(0.7) * DMat3::from_rotation_x(-0.3);
        let back = rotation_from_6d(rotation_to_6d(r));
        assert!(back.abs_diff_eq(r, 1e-15));
    }

    #[test]
    fn backward_matches_finite_differences() {
        let mut rng = Pcg64::seed_from_u64(2);
        let h = 1e-6;
        for _ in 0..30 {
            let a = random_6d(&mut rng);
            let w = random_mat(&mut rng);
            let grad = rotation_from_6d_backward(a, w);
            for k in 0..6 {
                let (mut plus, mut minus) = (a, a);
                plus[k] += h;
                minus[k] -= h;
                let numeric = (loss(plus, w) - loss(minus, w)) / (2.0 * h);
                assert!(
                    (numeric - grad[k]).abs() < 1e-7 * (1.0 + numeric.abs()),
                    "k={k}: {numeric} vs {}",
                    grad[k]
                );
            }
        }
    }

    #[test]
    fn f32_twin_agrees_with_f64() {
        let mut rng = Pcg64::seed_from_u64(3);
        let a = random_6d(&mut rng);
        let w = random_mat(&mut rng);
        let a32 = a.map(|x| x as f32);
        let r = rotation_from_6d_f32(a32).as_dmat3();
        assert!(r.abs_diff_eq(rotation_from_6d(a), 1e-5));
        let g = rotation_from_6d_backward_f32(a32, w.as_mat3());
        let g64 = rotation_from_6d_backward(a, w);
        for k in 0..6 {
            assert!((g[k] as f64 - g64[k]).abs() < 1e-4 * (1.0 + g64[k].abs()));
        }
        assert_eq!(
            rotation_to_6d_f32(Mat3::IDENTITY),
            [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        );
    }
}

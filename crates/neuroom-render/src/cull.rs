//! Ray–box culling: the slab test of a ray against an axis-aligned box in the box's own frame. Objects whose
//! padded box a ray misses are never queried for that ray.

use glam::Vec3;

/// The distances `[t0, t1]` along `origin + t · dir` inside the box `[lo, hi]`, with `t0` raised to `near`;
/// `None` when the ray misses the box or the part inside lies before `near`. `dir` need not be unit length
/// (a rotated unit direction is), and zero components are handled (a parallel ray inside the slab never
/// leaves it).
pub fn slab(origin: Vec3, dir: Vec3, lo: Vec3, hi: Vec3, near: f32) -> Option<[f32; 2]> {
    let (mut t0, mut t1) = (near, f32::INFINITY);
    for a in 0..3 {
        if dir[a] == 0.0 {
            if origin[a] < lo[a] || origin[a] > hi[a] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / dir[a];
        let (ta, tb) = ((lo[a] - origin[a]) * inv, (hi[a] - origin[a]) * inv);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t1 > t0).then_some([t0, t1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_misses_and_inside() {
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        let r = slab(Vec3::new(-3.0, 0.0, 0.0), Vec3::X, lo, hi, 0.0).unwrap();
        assert!((r[0] - 2.0).abs() < 1e-6 && (r[1] - 4.0).abs() < 1e-6);
        assert!(slab(Vec3::new(-3.0, 2.0, 0.0), Vec3::X, lo, hi, 0.0).is_none());
        let inside = slab(Vec3::ZERO, Vec3::new(0.6, 0.8, 0.0), lo, hi, 0.05).unwrap();
        assert!((inside[0] - 0.05).abs() < 1e-6 && (inside[1] - 1.25).abs() < 1e-5);
        assert!(slab(Vec3::new(-3.0, 0.0, 0.0), -Vec3::X, lo, hi, 0.0).is_none());
    }
}

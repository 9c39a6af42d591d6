//! Oriented boxes and their exact volume IoU (docs/formats.md's IoU metric).
//!
//! The intersection of two boxes is a convex polyhedron. It is built by clipping the first box, kept as a
//! closed set of outward-oriented faces, by the six half-spaces of the second (Sutherland–Hodgman on every
//! face, plus the cap polygon each cut leaves on the clipping plane); its volume then follows from the
//! divergence theorem as a sum of tetrahedra from a central point. This is exact up to rounding for any
//! rotations, unlike the yaw-only formulas used by many 3D detection codes.

use glam::DVec3;

use crate::pose::Pose;

/// A box with full extents `size`, centred at `pose.translation`, its axes the columns of `pose.rotation`
/// (an object's bounding box placed by `object_to_world`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OrientedBox {
    /// Box frame to world: the box is axis-aligned and centred at the origin of its own frame.
    pub pose: Pose,
    /// Full extents along the box's x, y and z axes, metres.
    pub size: DVec3,
}

impl OrientedBox {
    /// A box of full extents `size` placed by `pose`.
    pub fn new(pose: Pose, size: DVec3) -> Self {
        Self { pose, size }
    }

    /// The centre in the world frame.
    pub fn center(&self) -> DVec3 {
        self.pose.translation
    }

    /// The eight corners in the world frame; corner `i` takes the + side of axis k where bit k of `i` is set.
    pub fn corners(&self) -> [DVec3; 8] {
        let h = 0.5 * self.size;
        std::array::from_fn(|i| {
            let sign = |bit: usize| if i >> bit & 1 == 1 { 1.0 } else { -1.0 };
            self.pose
                .transform_point(DVec3::new(sign(0) * h.x, sign(1) * h.y, sign(2) * h.z))
        })
    }

    /// Whether a world point lies in the box grown by `margin` on every side (a negative margin shrinks it).
    pub fn contains(&self, point: DVec3, margin: f64) -> bool {
        let local = self.pose.rotation.transpose() * (point - self.pose.translation);
        let h = 0.5 * self.size + DVec3::splat(margin);
        local.abs().cmple(h).all()
    }

    /// The volume, cubic metres.
    pub fn volume(&self) -> f64 {
        self.size.x * self.size.y * self.size.z
    }

    /// Exact volume of the intersection with another box, cubic metres.
    pub fn intersection_volume(&self, other: &OrientedBox) -> f64 {
        let reach = 0.5 * (self.size.length() + other.size.length());
        if self.center().distance(other.center()) > reach {
            return 0.0;
        }
        let eps = 1e-12
            * (1.0
                + reach
                + self.center().abs().max_element()
                + other.center().abs().max_element());
        let mut solid = Polyhedron::of_box(self);
        for (normal, offset) in other.half_spaces() {
            solid = solid.clip(normal, offset, eps);
            if solid.faces.is_empty() {
                return 0.0;
            }
        }
        solid.volume().max(0.0)
    }

    /// Volume intersection over union, in [0, 1]; 0 when both boxes are empty.
    pub fn iou(&self, other: &OrientedBox) -> f64 {
        let inter = self.intersection_volume(other);
        let union = self.volume() + other.volume() - inter;
        if union <= 0.0 {
            0.0
        } else {
            (inter / union).clamp(0.0, 1.0)
        }
    }

    /// The six half-spaces `n · x ≤ d` whose intersection is the box, as (outward unit normal n, offset d).
    fn half_spaces(&self) -> [(DVec3, f64); 6] {
        std::array::from_fn(|i| {
            let (axis, sign) = (i / 2, if i % 2 == 0 { 1.0 } else { -1.0 });
            let normal = sign * self.pose.rotation.col(axis);
            (normal, normal.dot(self.center()) + 0.5 * self.size[axis])
        })
    }
}

/// A closed convex polyhedron as its faces, each a planar polygon listed counter-clockwise seen from outside.
struct Polyhedron {
    faces: Vec<Vec<DVec3>>,
}

impl Polyhedron {
    /// The six faces of a box.
    fn of_box(b: &OrientedBox) -> Self {
        let h = 0.5 * b.size;
        let faces = (0..6)
            .map(|i| {
                let (a, sign) = (i / 2, if i % 2 == 0 { 1.0 } else { -1.0 });
                let (ea, eb, ec) = (
                    DVec3::AXES[a],
                    DVec3::AXES[(a + 1) % 3],
                    DVec3::AXES[(a + 2) % 3],
                );
                let (hb, hc) = (h[(a + 1) % 3], h[(a + 2) % 3]);
                // Counter-clockwise about +ea because eb × ec = ea; reversed for the −ea face.
                let mut quad: Vec<DVec3> = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
                    .iter()
                    .map(|&(sb, sc)| {
                        b.pose
                            .transform_point(sign * h[a] * ea + sb * hb * eb + sc * hc * ec)
                    })
                    .collect();
                if sign < 0.0 {
                    quad.reverse();
                }
                quad
            })
            .collect();
        Self { faces }
    }

    /// The part of the polyhedron in the half-space `n · x ≤ d`, closed by a cap on the plane.
    fn clip(&self, normal: DVec3, offset: f64, eps: f64) -> Self {
        let mut on_plane = Vec::new();
        let mut faces = Vec::with_capacity(self.faces.len() + 1);
        let mut face_on_plane = false;
        for face in &self.faces {
            let kept = clip_polygon(face, normal, offset, eps, &mut on_plane);
            if kept.len() >= 3 {
                face_on_plane |= kept.iter().all(|p| (normal.dot(*p) - offset).abs() <= eps);
                faces.push(kept);
            }
        }
        // A face already lying on the plane closes the solid there; a cap would count it twice.
        if !face_on_plane && let Some(cap) = cap_polygon(on_plane, normal, eps) {
            faces.push(cap);
        }
        Self { faces }
    }

    /// Volume by the divergence theorem: signed tetrahedra from the mean vertex to every face triangle.
    fn volume(&self) -> f64 {
        let count: usize = self.faces.iter().map(Vec::len).sum();
        let origin = self.faces.iter().flatten().sum::<DVec3>() / count as f64;
        let six_volume: f64 = self
            .faces
            .iter()
            .flat_map(|f| {
                f.windows(2)
                    .skip(1)
                    .map(move |w| (f[0] - origin, w[0] - origin, w[1] - origin))
            })
            .map(|(a, b, c)| a.dot(b.cross(c)))
            .sum();
        six_volume / 6.0
    }
}

/// Sutherland–Hodgman against one half-space: the part of `polygon` with `n · x ≤ d + eps`. Every kept
/// point on the plane (an old vertex within `eps`, or a new edge crossing) is also pushed to `on_plane`.
fn clip_polygon(
    polygon: &[DVec3],
    normal: DVec3,
    offset: f64,
    eps: f64,
    on_plane: &mut Vec<DVec3>,
) -> Vec<DVec3> {
    let dist: Vec<f64> = polygon.iter().map(|p| normal.dot(*p) - offset).collect();
    let mut out = Vec::with_capacity(polygon.len() + 1);
    for i in 0..polygon.len() {
        let j = (i + 1) % polygon.len();
        let (p, dp, dq) = (polygon[i], dist[i], dist[j]);
        if dp <= eps {
            out.push(p);
            if dp >= -eps {
                on_plane.push(p);
            }
        }
        if (dp < -eps && dq > eps) || (dp > eps && dq < -eps) {
            let x = p + (polygon[j] - p) * (dp / (dp - dq));
            out.push(x);
            on_plane.push(x);
        }
    }
    out
}

/// The convex polygon through the points left on a clipping plane, ordered counter-clockwise about the
/// plane's normal (the outward normal of the cap); `None` when fewer than three distinct points remain.
fn cap_polygon(points: Vec<DVec3>, normal: DVec3, eps: f64) -> Option<Vec<DVec3>> {
    let mut distinct: Vec<DVec3> = Vec::with_capacity(points.len());
    for p in points {
        if distinct
            .iter()
            .all(|q| q.distance_squared(p) > (1e3 * eps).powi(2))
        {
            distinct.push(p);
        }
    }
    if distinct.len() < 3 {
        return None;
    }
    let centre = distinct.iter().sum::<DVec3>() / distinct.len() as f64;
    let e1 = normal.any_orthonormal_vector();
    let e2 = normal.cross(e1);
    let angle = |p: &DVec3| (*p - centre).dot(e2).atan2((*p - centre).dot(e1));
    distinct.sort_by(|a, b| angle(a).total_cmp(&angle(b)));
    Some(distinct)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DMat3;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn aabb(centre: [f64; 3], size: [f64; 3]) -> OrientedBox {
        OrientedBox::new(
            Pose::new(DMat3::IDENTITY, DVec3::from(centre)),
            DVec3::from(size),
        )
    }

    fn random_rotation(rng: &mut Pcg64) -> DMat3 {
        let axis = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        DMat3::from_axis_angle(
            axis.normalize(),
            rng.random_range(0.0..std::f64::consts::PI),
        )
    }

    fn random_box(rng: &mut Pcg64) -> OrientedBox {
        let centre = DVec3::new(
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
            rng.random_range(-0.3..0.3),
        );
        let size = DVec3::new(
            rng.random_range(0.3..1.2),
            rng.random_range(0.3..1.2),
            rng.random_range(0.3..1.2),
        );
        OrientedBox::new(
            Pose::new(random_rotation(rng), centre + DVec3::splat(2.0)),
            size,
        )
    }

    /// Monte-Carlo estimate of the intersection volume and its standard deviation, sampling inside `a`.
    fn monte_carlo(
        a: &OrientedBox,
        b: &OrientedBox,
        samples: usize,
        rng: &mut Pcg64,
    ) -> (f64, f64) {
        let hits = (0..samples)
            .filter(|_| {
                let local = DVec3::new(
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-0.5..0.5),
                );
                b.contains(a.pose.transform_point(local * a.size), 0.0)
            })
            .count();
        let p = hits as f64 / samples as f64;
        (
            a.volume() * p,
            a.volume() * (p * (1.0 - p) / samples as f64).sqrt(),
        )
    }

    #[test]
    fn corners_and_contains() {
        let b = OrientedBox::new(
            Pose::from_yaw_translation(0.5, DVec3::new(1.0, 2.0, 3.0)),
            DVec3::new(2.0, 1.0, 0.5),
        );
        for c in b.corners() {
            assert!(b.contains(c, 1e-12) && !b.contains(c, -1e-6));
        }
        assert!((b.corners()[7] - b.corners()[0]).length() - b.size.length() < 1e-12);
        assert!(b.contains(b.center(), 0.0) && !b.contains(b.center() + DVec3::Z * 0.3, 0.0));
        assert!(b.contains(b.center() + DVec3::Z * 0.3, 0.1));
    }

    #[test]
    fn identical_boxes_have_iou_one() {
        let mut rng = Pcg64::seed_from_u64(4);
        for _ in 0..20 {
            let b = random_box(&mut rng);
            assert!((b.intersection_volume(&b) - b.volume()).abs() < 1e-12);
            assert!((b.iou(&b) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn disjoint_and_touching_boxes_have_iou_zero() {
        let a = aabb([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        assert_eq!(a.iou(&aabb([5.0, 0.0, 0.0], [1.0, 1.0, 1.0])), 0.0);
        // Sharing a face, an edge, a corner: no volume in common.
        for centre in [
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, -1.0, 1.0],
            [0.0, 0.0, -1.0],
        ] {
            assert!(
                a.intersection_volume(&aabb(centre, [1.0, 1.0, 1.0])).abs() < 1e-12,
                "{centre:?}"
            );
        }
        // Close but separated along a rotated axis (bounding spheres overlap).
        let b = OrientedBox::new(
            Pose::from_yaw_translation(0.25 * std::f64::consts::PI, DVec3::new(1.22, 0.0, 0.0)),
            DVec3::ONE,
        );
        assert_eq!(a.intersection_volume(&b), 0.0);
    }

    #[test]
    fn axis_aligned_overlaps_match_closed_form() {
        let a = aabb([0.0, 0.0, 0.0], [2.0, 1.0, 1.0]);
        let b = aabb([0.5, 0.25, -0.1], [2.0, 1.0, 0.6]);
        // Overlap: x ∈ [−0.5, 1], y ∈ [−0.25, 0.5], z ∈ [−0.4, 0.2].
        let inter = 1.5 * 0.75 * 0.6;
        assert!((a.intersection_volume(&b) - inter).abs() < 1e-12);
        assert!((a.iou(&b) - inter / (2.0 + 1.2 - inter)).abs() < 1e-12);
        // Coplanar faces on two axes.
        let c = aabb([0.5, 0.0, 0.0], [2.0, 1.0, 1.0]);
        assert!((a.intersection_volume(&c) - 1.5).abs() < 1e-12);
        // One box inside the other.
        let d = aabb([0.1, 0.1, 0.1], [0.2, 0.3, 0.4]);
        assert!((a.intersection_volume(&d) - d.volume()).abs() < 1e-12);
        assert!((a.iou(&d) - d.volume() / a.volume()).abs() < 1e-12);
    }

    #[test]
    fn yaw_rotated_square_matches_closed_form() {
        // A unit cube and the same cube turned 45° about z: the overlap is a regular octagon prism,
        // area 2(√2 − 1) for a unit square.
        let a = aabb([0.0, 0.0, 0.0], [1.0, 1.0, 1.0]);
        let b = OrientedBox::new(
            Pose::from_yaw_translation(0.25 * std::f64::consts::PI, DVec3::ZERO),
            DVec3::ONE,
        );
        let octagon = 2.0 * (2f64.sqrt() - 1.0);
        assert!((a.intersection_volume(&b) - octagon).abs() < 1e-12);
        assert!((b.intersection_volume(&a) - octagon).abs() < 1e-12);
    }

    #[test]
    fn nearly_coincident_boxes_are_stable() {
        let mut rng = Pcg64::seed_from_u64(8);
        for angle in [1e-5, 1e-8, 1e-11, 0.0] {
            let a = random_box(&mut rng);
            let axis = random_rotation(&mut rng).x_axis;
            let turn = Pose::new(DMat3::from_axis_angle(axis, angle), DVec3::splat(angle));
            let b = OrientedBox::new(a.pose.compose(&turn), a.size);
            let iou = a.iou(&b);
            assert!(
                (0.0..=1.0).contains(&iou) && 1.0 - iou < 1e-4,
                "angle {angle}: IoU {iou}"
            );
            assert!((iou - b.iou(&a)).abs() < 1e-9);
        }
        // A box standing on another, turned about z: they touch along a face only.
        let lower = aabb([0.0, 0.0, 0.5], [1.0, 1.0, 1.0]);
        for yaw in [0.0, 0.3, 1e-9] {
            let upper = OrientedBox::new(
                Pose::from_yaw_translation(yaw, DVec3::new(0.1, 0.0, 1.2)),
                DVec3::new(0.4, 0.3, 0.4),
            );
            assert!(lower.intersection_volume(&upper).abs() < 1e-12, "yaw {yaw}");
            assert!(upper.intersection_volume(&lower).abs() < 1e-12, "yaw {yaw}");
        }
    }

    #[test]
    fn random_rotated_pairs_match_monte_carlo() {
        let mut rng = Pcg64::seed_from_u64(5);
        let mut checked = 0;
        for _ in 0..12 {
            let (a, b) = (random_box(&mut rng), random_box(&mut rng));
            let exact = a.intersection_volume(&b);
            assert!(
                (exact - b.intersection_volume(&a)).abs() < 1e-12,
                "not symmetric"
            );
            let (estimate, sigma) = monte_carlo(&a, &b, 1_000_000, &mut rng);
            assert!(
                (exact - estimate).abs() <= 4.0 * sigma + 1e-9,
                "exact {exact}, estimate {estimate} ± {sigma}"
            );
            checked += usize::from(exact > 0.05 * a.volume());
        }
        assert!(
            checked >= 6,
            "too few substantial overlaps to test ({checked})"
        );
    }
}

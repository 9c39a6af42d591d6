//! The arrangement sampler: places objects in a box room the way people furnish rooms. Wall pieces
//! stand on the floor with their back (−x) a small gap from a wall; free pieces stand anywhere with
//! any yaw; pictures hang on walls; small objects stand on the top of their support. No two boxes
//! interpenetrate (exact separating-axis test on the yaw-rotated footprints plus the height
//! intervals, which is exact for boxes that only turn about z), everything stays inside the room
//! and off the keep-out areas, and the panorama camera stands in free floor space.

use std::f64::consts::{FRAC_PI_2, PI, TAU};

use glam::{DMat3, DVec2, DVec3};
use neuroom_core::Pose;
use rand::Rng;
use rand_pcg::Pcg64;

use crate::furniture::{Furniture, Stand};
use crate::shell::KeepOut;

/// One object to place.
#[derive(Clone, Copy, Debug)]
pub struct Item<'a> {
    /// Its model and room logic.
    pub furniture: &'a Furniture,
    /// Index (in the item list) of the object it stands on, for [`Stand::OnSupport`].
    pub support: Option<usize>,
}

/// A box turned about z only: centre, half extents and yaw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct YawBox {
    /// Centre (world).
    pub centre: DVec3,
    /// Half extents in the box frame.
    pub half: DVec3,
    /// Rotation about +z (radians).
    pub yaw: f64,
}

impl YawBox {
    /// The box of an object of full size `size` placed at `pose` (yaw-only).
    pub fn of(pose: &Pose, size: DVec3) -> Self {
        Self {
            centre: pose.translation,
            half: size * 0.5,
            yaw: pose.yaw(),
        }
    }

    fn axes(&self) -> [DVec2; 2] {
        let (s, c) = self.yaw.sin_cos();
        [DVec2::new(c, s), DVec2::new(-s, c)]
    }

    /// Footprint corners (x, y).
    pub fn footprint(&self) -> [DVec2; 4] {
        let [a, b] = self.axes();
        let c = self.centre.truncate();
        let (ha, hb) = (a * self.half.x, b * self.half.y);
        [c + ha + hb, c - ha + hb, c - ha - hb, c + ha - hb]
    }

    /// Whether the two boxes share interior volume, with `gap` of clearance required between
    /// footprints (heights must overlap by more than 1 µm to count).
    pub fn overlaps(&self, other: &YawBox, gap: f64) -> bool {
        let z_overlap = (self.centre.z - other.centre.z).abs() < self.half.z + other.half.z - 1e-6;
        z_overlap && footprints_overlap(self, other, gap)
    }
}

/// Separating-axis test of two rectangles in the plane, each inflated by `gap / 2`.
fn footprints_overlap(a: &YawBox, b: &YawBox, gap: f64) -> bool {
    let d = (b.centre - a.centre).truncate();
    let axes = a.axes().into_iter().chain(b.axes());
    for axis in axes {
        let radius = |x: &YawBox| {
            let [u, v] = x.axes();
            x.half.x * u.dot(axis).abs() + x.half.y * v.dot(axis).abs() + gap * 0.5
        };
        if d.dot(axis).abs() >= radius(a) + radius(b) {
            return false;
        }
    }
    true
}

/// A placed object: its index in the item list and its object-to-world pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placed {
    /// Index in the item list.
    pub index: usize,
    /// Object-to-world pose (yaw only).
    pub pose: Pose,
}

/// Clearance between floor objects (m).
const FLOOR_GAP: f64 = 0.04;
/// Attempts per object before the whole arrangement is restarted.
const TRIES: usize = 200;

/// The room the sampler fills.
#[derive(Clone, Debug)]
pub struct RoomSpace<'a> {
    /// Inner size [W, D, H]: x ∈ [0, W], y ∈ [0, D], floor at z = 0.
    pub size: DVec3,
    /// Floor areas to keep free.
    pub keep_out: &'a [KeepOut],
}

impl RoomSpace<'_> {
    /// Samples poses for all items except those in `omit`, placing big floor pieces first, then
    /// pictures, then objects on supports. Fails naming the model that could not be placed.
    pub fn arrange(
        &self,
        items: &[Item],
        omit: &[usize],
        rng: &mut Pcg64,
    ) -> Result<Vec<Placed>, String> {
        let mut order: Vec<usize> = (0..items.len()).filter(|i| !omit.contains(i)).collect();
        order.sort_by(|&a, &b| {
            let key = |i: usize| {
                let f = items[i].furniture;
                let rank = match f.placement.stand {
                    Stand::Floor => 0,
                    Stand::Wall { .. } => 1,
                    Stand::OnSupport => 2,
                };
                (rank, -(f.size.x * f.size.y))
            };
            key(a).partial_cmp(&key(b)).expect("finite sizes")
        });
        let mut stuck = 0;
        'restart: for _ in 0..50 {
            let mut placed: Vec<Placed> = Vec::new();
            for &i in &order {
                let Some(pose) = (0..TRIES).find_map(|_| self.try_place(items, i, &placed, rng))
                else {
                    stuck = i;
                    continue 'restart;
                };
                placed.push(Placed { index: i, pose });
            }
            placed.sort_by_key(|p| p.index);
            return Ok(placed);
        }
        let f = items[stuck].furniture;
        Err(format!(
            "no room for `{}` ({}, size {:.2?} m)",
            f.name,
            f.source,
            f.size.to_array()
        ))
    }

    fn try_place(
        &self,
        items: &[Item],
        i: usize,
        placed: &[Placed],
        rng: &mut Pcg64,
    ) -> Option<Pose> {
        let f = items[i].furniture;
        let pose = match f.placement.stand {
            Stand::Floor if f.placement.against_wall => self.against_wall(f, f.size.z * 0.5, rng),
            Stand::Floor => self.free(f, rng),
            Stand::Wall { centre_height } => self.against_wall(f, centre_height, rng),
            Stand::OnSupport => {
                let s = items[i].support?;
                let support = placed.iter().find(|p| p.index == s)?;
                on_top(f, items[s].furniture, &support.pose, rng)?
            }
        };
        let b = YawBox::of(&pose, f.size);
        let inside = b
            .footprint()
            .iter()
            .all(|c| c.x >= 0.0 && c.y >= 0.0 && c.x <= self.size.x && c.y <= self.size.y)
            && b.centre.z + b.half.z <= self.size.z;
        let on_floor = matches!(f.placement.stand, Stand::Floor);
        let blocked = on_floor
            && self
                .keep_out
                .iter()
                .any(|k| footprints_overlap(&b, &keep_out_box(k), 0.0));
        let collides = placed.iter().any(|p| {
            let other = items[p.index].furniture;
            let gap = if on_floor && matches!(other.placement.stand, Stand::Floor) {
                FLOOR_GAP
            } else {
                0.0
            };
            Some(p.index) != items[i].support && b.overlaps(&YawBox::of(&p.pose, other.size), gap)
        });
        (inside && !blocked && !collides).then_some(pose)
    }

    /// A pose with the back (−x) a small gap from a random wall, centre at height `z`.
    fn against_wall(&self, f: &Furniture, z: f64, rng: &mut Pcg64) -> Pose {
        let (w, d) = (self.size.x, self.size.y);
        let (hx, hy) = (f.size.x * 0.5, f.size.y * 0.5);
        let gap = rng.random_range(0.005..0.025);
        let wall = rng.random_range(0..4);
        let span = if wall < 2 { w } else { d };
        let s = if span > 2.0 * hy {
            rng.random_range(hy..span - hy)
        } else {
            span * 0.5
        };
        let off = hx + gap + 0.015; // the baseboards stand 1.5 cm proud of the walls
        let (x, y, yaw) = match wall {
            0 => (s, off, FRAC_PI_2),
            1 => (s, d - off, -FRAC_PI_2),
            2 => (off, s, 0.0),
            _ => (w - off, s, PI),
        };
        Pose::new(DMat3::from_rotation_z(yaw), DVec3::new(x, y, z))
    }

    /// A free-standing pose: anywhere on the floor, any yaw.
    fn free(&self, f: &Furniture, rng: &mut Pcg64) -> Pose {
        let r = (f.size.x * f.size.x + f.size.y * f.size.y).sqrt() * 0.5;
        let x = rng.random_range(0.0..self.size.x.max(2.0 * r));
        let y = rng.random_range(0.0..self.size.y.max(2.0 * r));
        Pose::new(
            DMat3::from_rotation_z(rng.random_range(0.0..TAU)),
            DVec3::new(x, y, f.size.z * 0.5),
        )
    }

    /// A panorama camera pose: 1.2–1.6 m high, at least `clearance` from walls and from every
    /// floor object's box, any heading. The camera frame is docs/formats.md's (+x forward, z up).
    pub fn camera(&self, boxes: &[YawBox], clearance: f64, rng: &mut Pcg64) -> Option<Pose> {
        (0..2000).find_map(|_| {
            let x = rng.random_range(clearance..self.size.x - clearance);
            let y = rng.random_range(clearance..self.size.y - clearance);
            let z = rng.random_range(1.2..1.6);
            let probe = YawBox {
                centre: DVec3::new(x, y, z * 0.5),
                half: DVec3::new(0.0, 0.0, z * 0.5),
                yaw: 0.0,
            };
            let free = boxes.iter().all(|b| !probe.overlaps(b, 2.0 * clearance));
            free.then(|| {
                Pose::new(
                    DMat3::from_rotation_z(rng.random_range(-PI..PI)),
                    DVec3::new(x, y, z),
                )
            })
        })
    }
}

/// A pose on the top of `support`: a random yaw, then a position keeping the turned footprint
/// inside the usable rectangle.
fn on_top(
    f: &Furniture,
    support: &Furniture,
    support_pose: &Pose,
    rng: &mut Pcg64,
) -> Option<Pose> {
    let top = support.placement.top?;
    let relative_yaw = rng.random_range(-PI..PI);
    let (s, c) = f64::sin_cos(relative_yaw);
    let (hx, hy) = (f.size.x * 0.5, f.size.y * 0.5);
    let extent = DVec2::new(c.abs() * hx + s.abs() * hy, s.abs() * hx + c.abs() * hy);
    let room = top.half_extent - extent;
    if room.min_element() < 0.0 {
        return None;
    }
    let local = DVec3::new(
        top.centre.x + rng.random_range(-room.x..=room.x),
        top.centre.y + rng.random_range(-room.y..=room.y),
        top.height + f.size.z * 0.5,
    );
    let yaw = support_pose.yaw() + relative_yaw;
    Some(Pose::new(
        DMat3::from_rotation_z(yaw),
        support_pose.transform_point(local),
    ))
}

fn keep_out_box(k: &KeepOut) -> YawBox {
    let c = (k.min + k.max) * 0.5;
    let h = (k.max - k.min) * 0.5;
    YawBox {
        centre: c.extend(0.0),
        half: h.extend(f64::INFINITY),
        yaw: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separating_axes_are_exact() {
        let a = YawBox {
            centre: DVec3::ZERO,
            half: DVec3::new(1.0, 0.5, 0.5),
            yaw: 0.0,
        };
        // A unit square turned 45° whose corner points at a: its corner reaches 1 + √2/2·… apart.
        let mut b = YawBox {
            centre: DVec3::new(1.0 + 0.5 * 2f64.sqrt() + 1e-3, 0.0, 0.0),
            half: DVec3::splat(0.5),
            yaw: PI / 4.0,
        };
        assert!(!a.overlaps(&b, 0.0));
        b.centre.x -= 2e-3;
        assert!(a.overlaps(&b, 0.0));
        b.centre.z = 1.0;
        assert!(
            !a.overlaps(&b, 0.0),
            "touching height intervals do not overlap"
        );
    }
}

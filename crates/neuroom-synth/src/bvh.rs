//! A bounding volume hierarchy built with the binned surface-area heuristic, used twice: over the
//! triangles of each mesh and over the instances of a scene. Traversal is front-to-back with an
//! explicit stack; the caller tests primitives through a closure, so one tree serves both levels.

use glam::Vec3;

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisBox {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl AxisBox {
    /// The empty box (grows to anything).
    pub const EMPTY: Self = Self {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box grown to hold a point.
    pub fn with_point(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// The union of two boxes.
    pub fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Full extents (negative when empty).
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }

    /// Centre point.
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    /// Half the surface area (enough for SAH ratios); 0 for an empty box.
    pub fn half_area(&self) -> f32 {
        let d = self.size().max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// The eight corners.
    pub fn corners(&self) -> [Vec3; 8] {
        std::array::from_fn(|i| {
            Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }

    /// Entry distance of a ray (given by origin and reciprocal direction) into the box, if it enters
    /// before `t_max`.
    #[inline(always)]
    pub fn entry(&self, origin: Vec3, inv_dir: Vec3, t_max: f32) -> Option<f32> {
        let t0 = (self.min - origin) * inv_dir;
        let t1 = (self.max - origin) * inv_dir;
        let near = t0.min(t1).max_element().max(0.0);
        let far = t0.max(t1).min_element().min(t_max);
        (near <= far).then_some(near)
    }
}

/// One tree node: a leaf holds `count > 0` primitives starting at `first` in [`Bvh::order`]; an
/// interior node (`count == 0`) has its two children at `first` and `first + 1`.
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: AxisBox,
    first: u32,
    count: u32,
}

/// A binned-SAH hierarchy over primitives given by their boxes.
#[derive(Clone, Debug)]
pub struct Bvh {
    nodes: Vec<Node>,
    /// Primitive indices in leaf order: leaves refer to contiguous ranges of this list.
    pub order: Vec<u32>,
}

const BINS: usize = 12;
const MAX_LEAF: usize = 4;
/// Cost of one node traversal relative to one primitive test.
const TRAVERSAL_COST: f32 = 1.0;

impl Bvh {
    /// Builds the tree over `boxes` (one per primitive).
    pub fn build(boxes: &[AxisBox]) -> Self {
        let centres: Vec<Vec3> = boxes.iter().map(AxisBox::centre).collect();
        let mut bvh = Self {
            nodes: Vec::with_capacity(2 * boxes.len().max(1)),
            order: (0..boxes.len() as u32).collect(),
        };
        let bounds = boxes.iter().fold(AxisBox::EMPTY, |b, x| b.union(*x));
        bvh.nodes.push(Node {
            bounds,
            first: 0,
            count: boxes.len() as u32,
        });
        bvh.subdivide(0, boxes, &centres);
        bvh
    }

    /// Bounds of everything in the tree.
    pub fn bounds(&self) -> AxisBox {
        self.nodes[0].bounds
    }

    fn subdivide(&mut self, node: usize, boxes: &[AxisBox], centres: &[Vec3]) {
        let Node { first, count, .. } = self.nodes[node];
        let (first, count) = (first as usize, count as usize);
        if count <= 1 {
            return;
        }
        let range = &self.order[first..first + count];
        let Some((axis, split, cost)) = best_split(range, boxes, centres) else {
            return;
        };
        let leaf_cost = count as f32 * self.nodes[node].bounds.half_area();
        if count <= MAX_LEAF && cost >= leaf_cost {
            return;
        }
        let mid = partition(&mut self.order[first..first + count], |i| {
            centres[i as usize][axis] < split
        });
        let mid = if mid == 0 || mid == count {
            count / 2
        } else {
            mid
        };
        let left = self.nodes.len();
        for (start, len) in [(first, mid), (first + mid, count - mid)] {
            let bounds = self.order[start..start + len]
                .iter()
                .fold(AxisBox::EMPTY, |b, &i| b.union(boxes[i as usize]));
            self.nodes.push(Node {
                bounds,
                first: start as u32,
                count: len as u32,
            });
        }
        self.nodes[node].first = left as u32;
        self.nodes[node].count = 0;
        self.subdivide(left, boxes, centres);
        self.subdivide(left + 1, boxes, centres);
    }

    /// Walks the tree front to back. `test(slot, t_max)` returns the hit distance of the primitive
    /// `order[slot]` if it is closer than `t_max` (callers may store primitives in slot order for
    /// locality). With `any_hit` the walk stops at the first hit.
    /// Returns the closest (or first) hit distance found.
    #[inline]
    pub fn traverse(
        &self,
        origin: Vec3,
        dir: Vec3,
        mut t_max: f32,
        any_hit: bool,
        mut test: impl FnMut(u32, f32) -> Option<f32>,
    ) -> Option<f32> {
        let inv = dir.recip();
        let mut stack = [0u32; 64];
        let mut top = 0usize;
        let mut node = &self.nodes[0];
        self.nodes[0].bounds.entry(origin, inv, t_max)?;
        let mut found = None;
        loop {
            if node.count > 0 {
                for slot in node.first..node.first + node.count {
                    if let Some(t) = test(slot, t_max) {
                        t_max = t;
                        found = Some(t);
                        if any_hit {
                            return found;
                        }
                    }
                }
            } else {
                let (a, b) = (
                    &self.nodes[node.first as usize],
                    &self.nodes[node.first as usize + 1],
                );
                let (ta, tb) = (
                    a.bounds.entry(origin, inv, t_max),
                    b.bounds.entry(origin, inv, t_max),
                );
                match (ta, tb) {
                    (Some(x), Some(y)) => {
                        let (near, far) = if x <= y {
                            (node.first, node.first + 1)
                        } else {
                            (node.first + 1, node.first)
                        };
                        stack[top] = far;
                        top += 1;
                        node = &self.nodes[near as usize];
                        continue;
                    }
                    (Some(_), None) => {
                        node = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            loop {
                if top == 0 {
                    return found;
                }
                top -= 1;
                let n = &self.nodes[stack[top] as usize];
                if n.bounds.entry(origin, inv, t_max).is_some() {
                    node = n;
                    break;
                }
            }
        }
    }
}

/// Finds the cheapest binned split over the three axes: (axis, split position, SAH cost).
fn best_split(range: &[u32], boxes: &[AxisBox], centres: &[Vec3]) -> Option<(usize, f32, f32)> {
    let cb = range
        .iter()
        .fold(AxisBox::EMPTY, |b, &i| b.with_point(centres[i as usize]));
    let mut best: Option<(usize, f32, f32)> = None;
    for axis in [0usize, 1, 2] {
        let (lo, hi) = (cb.min[axis], cb.max[axis]);
        if hi <= lo {
            continue;
        }
        let scale = BINS as f32 / (hi - lo);
        let mut bins = [(AxisBox::EMPTY, 0u32); BINS];
        for &i in range {
            let b = (((centres[i as usize][axis] - lo) * scale) as usize).min(BINS - 1);
            bins[b].0 = bins[b].0.union(boxes[i as usize]);
            bins[b].1 += 1;
        }
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut n) = (AxisBox::EMPTY, 0u32);
        for b in (1..BINS).rev() {
            acc = acc.union(bins[b].0);
            n += bins[b].1;
            right_cost[b] = acc.half_area() * n as f32;
        }
        let (mut acc, mut n) = (AxisBox::EMPTY, 0u32);
        for b in 0..BINS - 1 {
            acc = acc.union(bins[b].0);
            n += bins[b].1;
            let cost = TRAVERSAL_COST + acc.half_area() * n as f32 + right_cost[b + 1];
            if best.is_none_or(|(_, _, c)| cost < c) {
                best = Some((axis, lo + (b + 1) as f32 / scale, cost));
            }
        }
    }
    best
}

/// Moves the items satisfying `pred` to the front; returns how many there are.
fn partition(items: &mut [u32], pred: impl Fn(u32) -> bool) -> usize {
    let mut mid = 0;
    for i in 0..items.len() {
        if pred(items[i]) {
            items.swap(i, mid);
            mid += 1;
        }
    }
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn sphere_hit(c: Vec3, r: f32, o: Vec3, d: Vec3) -> Option<f32> {
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        (disc >= 0.0).then(|| -b - disc.sqrt()).filter(|t| *t > 0.0)
    }

    #[test]
    fn closest_hit_matches_brute_force() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(3);
        let spheres: Vec<(Vec3, f32)> = (0..500)
            .map(|_| {
                (
                    Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0,
                    rng.random_range(0.05..0.4),
                )
            })
            .collect();
        let boxes: Vec<AxisBox> = spheres
            .iter()
            .map(|(c, r)| AxisBox {
                min: *c - Vec3::splat(*r),
                max: *c + Vec3::splat(*r),
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        for _ in 0..2000 {
            let o = Vec3::new(rng.random(), rng.random(), rng.random()) * 10.0;
            let d = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize();
            let brute = spheres
                .iter()
                .filter_map(|(c, r)| sphere_hit(*c, *r, o, d))
                .fold(f32::INFINITY, f32::min);
            let got = bvh.traverse(o, d, f32::INFINITY, false, |slot, tmax| {
                let (c, r) = spheres[bvh.order[slot as usize] as usize];
                sphere_hit(c, r, o, d).filter(|t| *t < tmax)
            });
            assert_eq!(got.unwrap_or(f32::INFINITY), brute);
            let any = bvh.traverse(o, d, f32::INFINITY, true, |slot, tmax| {
                let (c, r) = spheres[bvh.order[slot as usize] as usize];
                sphere_hit(c, r, o, d).filter(|t| *t < tmax)
            });
            assert_eq!(any.is_some(), brute.is_finite());
        }
    }
}

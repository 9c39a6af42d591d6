//! Exact distances from points to a triangle mesh's surface.
//!
//! [`SurfaceDistance`] arranges the triangles in a tree of axis-aligned boxes (each box split at the
//! median of its triangles' centroids along its longest spread). A query descends nearest box first
//! and skips every box farther than the nearest triangle found so far, so it visits a few leaves of a
//! mesh of any size; the distance is the exact point–triangle distance to the nearest triangle of the
//! whole mesh, whatever its triangles' sizes and shapes.

use glam::Vec3;
use rayon::prelude::*;

use crate::mesh::{TriMesh, closest_point_on_triangle};
use crate::winding::split_at_median;

/// Triangles per leaf.
const LEAF_TRIANGLES: usize = 4;
/// Deepest tree the query's stack holds: median splits halve the triangles at each level, so even
/// 2^40 triangles stay far within it (the stack holds one entry per level and the one beside it).
const MAX_DEPTH: usize = 96;

/// One box of the tree: its bounds, the range of triangles it holds and its two halves.
#[derive(Clone, Debug)]
struct BoxNode {
    lo: Vec3,
    hi: Vec3,
    first: usize,
    count: usize,
    /// Indices of the two child nodes; `None` for a leaf.
    children: Option<(usize, usize)>,
}

impl BoxNode {
    /// Squared distance from `q` to the box (0 inside).
    fn distance_squared(&self, q: Vec3) -> f32 {
        (self.lo - q)
            .max(q - self.hi)
            .max(Vec3::ZERO)
            .length_squared()
    }
}

/// A mesh's triangles arranged for nearest-surface queries.
#[derive(Clone, Debug)]
pub struct SurfaceDistance {
    triangles: Vec<[Vec3; 3]>,
    nodes: Vec<BoxNode>,
}

impl SurfaceDistance {
    /// Builds the tree over every triangle of `mesh`.
    pub fn new(mesh: &TriMesh) -> Self {
        let mut triangles: Vec<[Vec3; 3]> =
            (0..mesh.triangles.len()).map(|t| mesh.corners(t)).collect();
        let mut nodes = Vec::new();
        if !triangles.is_empty() {
            let n = triangles.len();
            build(&mut triangles, 0, n, &mut nodes);
        }
        Self { triangles, nodes }
    }

    /// Distance from `q` to the surface (infinite when the mesh has no triangle).
    pub fn distance(&self, q: Vec3) -> f32 {
        self.distance_squared(q).sqrt()
    }

    /// Squared distance from `q` to the nearest triangle.
    fn distance_squared(&self, q: Vec3) -> f32 {
        let mut best = f32::INFINITY;
        let Some(root) = self.nodes.first() else {
            return best;
        };
        let mut stack = [(0usize, 0.0f32); MAX_DEPTH];
        stack[0] = (0, root.distance_squared(q));
        let mut depth = 1;
        while depth > 0 {
            depth -= 1;
            let (i, box_d2) = stack[depth];
            if box_d2 >= best {
                continue;
            }
            let node = &self.nodes[i];
            let Some((left, right)) = node.children else {
                for t in &self.triangles[node.first..node.first + node.count] {
                    best = best.min(closest_point_on_triangle(q, *t).distance_squared(q));
                }
                continue;
            };
            let (dl, dr) = (
                self.nodes[left].distance_squared(q),
                self.nodes[right].distance_squared(q),
            );
            // The farther half goes on the stack first, so the nearer is searched first and its
            // triangles prune the farther.
            let (near, far) = if dl <= dr {
                ((left, dl), (right, dr))
            } else {
                ((right, dr), (left, dl))
            };
            for entry in [far, near] {
                if entry.1 < best {
                    stack[depth] = entry;
                    depth += 1;
                }
            }
        }
        best
    }

    /// Mean distance of `queries` to the surface (infinite when the mesh is empty, 0 without queries).
    pub fn mean(&self, queries: &[Vec3]) -> f32 {
        if self.triangles.is_empty() {
            return f32::INFINITY;
        }
        if queries.is_empty() {
            return 0.0;
        }
        let sum: f64 = queries.par_iter().map(|q| self.distance(*q) as f64).sum();
        (sum / queries.len() as f64) as f32
    }
}

/// Builds the node over `triangles[first..first + count]` (reordering them) and its subtree; returns its
/// index.
fn build(
    triangles: &mut [[Vec3; 3]],
    first: usize,
    count: usize,
    nodes: &mut Vec<BoxNode>,
) -> usize {
    let part = &mut triangles[first..first + count];
    let (lo, hi) = part.iter().flatten().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let index = nodes.len();
    nodes.push(BoxNode {
        lo,
        hi,
        first,
        count,
        children: None,
    });
    if count > LEAF_TRIANGLES {
        split_at_median(part, |t| ((t[0] + t[1] + t[2]) / 3.0).as_dvec3());
        let half = count / 2;
        let left = build(triangles, first, half, nodes);
        let right = build(triangles, first + half, count - half, nodes);
        nodes[index].children = Some((left, right));
    }
    index
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The nearest triangle by trying every one.
    fn brute_force(mesh: &TriMesh, q: Vec3) -> f32 {
        (0..mesh.triangles.len())
            .map(|t| closest_point_on_triangle(q, mesh.corners(t)).distance_squared(q))
            .fold(f32::INFINITY, f32::min)
            .sqrt()
    }

    /// A scattered soup of triangles of every size and shape, slivers among them.
    fn soup(n: usize) -> TriMesh {
        let f = |k: usize, m: usize| ((k * m + 11) % 997) as f32 / 997.0;
        let mut mesh = TriMesh::default();
        for k in 0..n {
            let a = Vec3::new(f(k, 31), f(k, 57), f(k, 83)) * 2.0;
            let size = 0.01 + 0.3 * f(k, 101);
            let b = a + Vec3::new(f(k, 7) - 0.5, f(k, 13) - 0.5, f(k, 17) - 0.5) * size;
            let c = a + Vec3::new(f(k, 19) - 0.5, f(k, 23) - 0.5, f(k, 29) - 0.5) * size * 0.05;
            let base = mesh.positions.len() as u32;
            mesh.positions.extend([a, b, c]);
            mesh.triangles.push([base, base + 1, base + 2]);
        }
        mesh
    }

    #[test]
    fn the_tree_finds_the_nearest_of_all_triangles() {
        let mut mesh = soup(500);
        mesh.append(&TriMesh::cuboid(Vec3::splat(0.3), Vec3::splat(1.4), 6));
        let tree = SurfaceDistance::new(&mesh);
        for k in 0..400 {
            let f = |m: usize| ((k * m + 5) % 211) as f32 / 210.0;
            let q = Vec3::new(f(37), f(53), f(71)) * 3.0 - Vec3::splat(0.5);
            assert_eq!(tree.distance(q), brute_force(&mesh, q), "{q}");
        }
    }

    #[test]
    fn an_empty_mesh_is_infinitely_far_and_a_mean_without_queries_is_zero() {
        let empty = SurfaceDistance::new(&TriMesh::default());
        assert_eq!(empty.distance(Vec3::ZERO), f32::INFINITY);
        assert_eq!(empty.mean(&[Vec3::ZERO]), f32::INFINITY);
        let cube = SurfaceDistance::new(&TriMesh::cuboid(Vec3::ZERO, Vec3::ONE, 1));
        assert_eq!(cube.mean(&[]), 0.0);
        assert!((cube.distance(Vec3::new(0.5, 0.5, 3.0)) - 2.0).abs() < 1e-6);
        assert!((cube.distance(Vec3::splat(0.5)) - 0.5).abs() < 1e-6);
    }
}

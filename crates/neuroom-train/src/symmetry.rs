//! The turns about its up axis that leave an object's shape unchanged, read from its ground-truth mesh:
//! what the rotation error up to symmetry (`neuroom_core::metrics::Symmetry`) leaves out.
//!
//! A turn belongs to the symmetry when every point spread over the mesh's outer surface, turned about
//! the vertical axis through the surface's centroid, lands on the surface again (within a tolerance
//! that scales with the object's footprint). Every point must land, not most: a handle on one face of a
//! cabinet is a small part of its surface but shows its front. Only the shape is read; a texture that
//! tells the turns apart is not seen.

use glam::{Quat, Vec3};
use neuroom_core::mesh::TriMesh;
use neuroom_core::metrics::Symmetry;
use rayon::prelude::*;

use neuroom_core::nearest::SurfaceDistance;
use neuroom_core::surface::outer_surface_samples;

/// Points spread over the outer surface and turned.
const SAMPLES: usize = 4000;
/// Orders of finite symmetry tried, largest first: the first whose turn keeps the shape is taken.
const ORDERS: [u32; 6] = [8, 6, 5, 4, 3, 2];
/// Turns (radians) that no finite order below 100 holds: a shape kept by both is a body of revolution.
const ODD_TURNS: [f32; 2] = [0.37, 1.0];
/// Largest distance a turned point may land from the surface, as a fraction of the diagonal of the
/// footprint (the box's x–y extents), and at least [`MIN_TOLERANCE`]: a polygon of 32 sides standing
/// for a circle stays within it (0.5 % of its diameter), and so does the blender-lite stool turned by a
/// quarter (1.2 mm); a handle or a drawer front does not.
const TOLERANCE: f32 = 0.005;
/// Least tolerance, metres: a picture whose canvas lies 5 mm in front of its backing is not alike
/// turned by half a turn (it lands 8 mm off), while a polygon standing for a small round part stays
/// within it.
const MIN_TOLERANCE: f32 = 0.003;

/// The symmetry of `mesh` (canonical frame, z up) about its vertical axis. An empty mesh has none.
pub fn shape_symmetry(mesh: &TriMesh) -> Symmetry {
    let Some((lo, hi)) = mesh.bounds() else {
        return Symmetry::None;
    };
    let samples = outer_surface_samples(mesh, SAMPLES);
    if samples.is_empty() {
        return Symmetry::None;
    }
    let centroid = samples.iter().copied().sum::<Vec3>() / samples.len() as f32;
    let axis = Vec3::new(centroid.x, centroid.y, 0.0);
    let tolerance = (TOLERANCE * (hi - lo).truncate().length()).max(MIN_TOLERANCE);
    let surface = SurfaceDistance::new(mesh);
    let keeps = |angle: f32| {
        let turn = Quat::from_rotation_z(angle);
        samples
            .par_iter()
            .all(|&p| surface.distance(axis + turn * (p - axis)) <= tolerance)
    };
    if ODD_TURNS.iter().all(|&a| keeps(a)) {
        return Symmetry::Continuous;
    }
    ORDERS
        .into_iter()
        .find(|&n| keeps(std::f32::consts::TAU / n as f32))
        .map_or(Symmetry::None, Symmetry::Turns)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed prism of `sides` sides (radius `r`, height `h`) standing on z = `z0` around (cx, cy).
    fn prism(sides: u32, r: f32, h: f32, z0: f32, (cx, cy): (f32, f32), phase: f32) -> TriMesh {
        let mut mesh = TriMesh::default();
        let ring = |z: f32| -> Vec<Vec3> {
            (0..sides)
                .map(|k| {
                    let a = phase + std::f32::consts::TAU * k as f32 / sides as f32;
                    Vec3::new(cx + r * a.cos(), cy + r * a.sin(), z)
                })
                .collect()
        };
        let (bottom, top) = (ring(z0), ring(z0 + h));
        mesh.positions.extend(&bottom);
        mesh.positions.extend(&top);
        mesh.positions.push(Vec3::new(cx, cy, z0));
        mesh.positions.push(Vec3::new(cx, cy, z0 + h));
        let (cb, ct) = (2 * sides, 2 * sides + 1);
        for k in 0..sides {
            let j = (k + 1) % sides;
            let (b0, b1, t0, t1) = (k, j, sides + k, sides + j);
            mesh.triangles.push([b0, b1, t1]);
            mesh.triangles.push([b0, t1, t0]);
            mesh.triangles.push([cb, b1, b0]);
            mesh.triangles.push([ct, t0, t1]);
        }
        mesh
    }

    /// A two-part shape: `a` and `b` side by side.
    fn union(mut a: TriMesh, b: &TriMesh) -> TriMesh {
        a.append(b);
        a
    }

    #[test]
    fn round_bodies_have_no_heading() {
        let vase = prism(48, 0.1, 0.3, -0.15, (0.0, 0.0), 0.0);
        assert_eq!(shape_symmetry(&vase), Symmetry::Continuous);
    }

    #[test]
    fn boxes_tables_and_stools_keep_their_turns() {
        // A box longer than wide: a half turn.
        let long = TriMesh::cuboid(Vec3::new(-0.6, -0.3, -0.2), Vec3::new(0.6, 0.3, 0.2), 3);
        assert_eq!(shape_symmetry(&long), Symmetry::Turns(2));
        // A square box: quarter turns.
        let square = TriMesh::cuboid(Vec3::new(-0.3, -0.3, -0.2), Vec3::new(0.3, 0.3, 0.2), 3);
        assert_eq!(shape_symmetry(&square), Symmetry::Turns(4));
        // Three legs under a round top: a third of a turn.
        let mut stool = prism(48, 0.2, 0.03, 0.4, (0.0, 0.0), 0.0);
        for k in 0..3 {
            let a = std::f32::consts::TAU * k as f32 / 3.0;
            stool = union(
                stool,
                &prism(6, 0.02, 0.4, 0.0, (0.15 * a.cos(), 0.15 * a.sin()), a),
            );
        }
        assert_eq!(shape_symmetry(&stool), Symmetry::Turns(3));
    }

    #[test]
    fn a_handle_or_an_offset_part_shows_the_heading() {
        let body = TriMesh::cuboid(Vec3::new(-0.25, -0.4, -0.4), Vec3::new(0.25, 0.4, 0.4), 3);
        // A handle of 2 × 10 × 2 cm on the front face: a small part of the surface.
        let handle = TriMesh::cuboid(Vec3::new(0.25, -0.05, 0.2), Vec3::new(0.27, 0.05, 0.22), 1);
        assert_eq!(shape_symmetry(&union(body, &handle)), Symmetry::None);
        // A pot with a second crown off its axis (like the plants).
        let pot = prism(32, 0.1, 0.2, 0.0, (0.0, 0.0), 0.0);
        let crown = prism(32, 0.06, 0.1, 0.25, (0.05, -0.04), 0.0);
        assert_eq!(shape_symmetry(&union(pot, &crown)), Symmetry::None);
        // A picture: a frame 3.5 cm deep around a backing 1.5 cm deep and a canvas 5 mm in front of it.
        let cuboid = |lo: [f32; 3], hi: [f32; 3]| TriMesh::cuboid(lo.into(), hi.into(), 1);
        let mut picture = cuboid([0.0, -0.4, 0.0], [0.035, -0.36, 0.5]);
        for part in [
            cuboid([0.0, 0.36, 0.0], [0.035, 0.4, 0.5]),
            cuboid([0.0, -0.36, 0.0], [0.035, 0.36, 0.04]),
            cuboid([0.0, -0.36, 0.46], [0.035, 0.36, 0.5]),
            cuboid([0.0, -0.36, 0.04], [0.015, 0.36, 0.46]),
        ] {
            picture = union(picture, &part);
        }
        let base = picture.positions.len() as u32;
        picture.positions.extend([
            Vec3::new(0.02, -0.36, 0.04),
            Vec3::new(0.02, 0.36, 0.04),
            Vec3::new(0.02, 0.36, 0.46),
            Vec3::new(0.02, -0.36, 0.46),
        ]);
        picture
            .triangles
            .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        assert_eq!(shape_symmetry(&picture), Symmetry::None);
        assert_eq!(shape_symmetry(&TriMesh::default()), Symmetry::None);
    }
}

//! Triangle meshes with per-vertex normals and UVs and a material id per triangle, plus the
//! primitive builders (boxes, cylinders, quads) the procedural catalog and the room shell are made of.
//!
//! Procedural primitives carry UVs in metres (two tangential coordinates of the face), so procedural
//! textures keep one physical scale on every part; OBJ meshes carry their own UVs.

use glam::{Affine3A, Vec2, Vec3};

use crate::bvh::AxisBox;

/// An indexed triangle mesh. All vertex arrays have the same length; `materials[i]` indexes the
/// material list of the model the mesh belongs to.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions in metres.
    pub positions: Vec<Vec3>,
    /// Unit shading normals, one per vertex.
    pub normals: Vec<Vec3>,
    /// Texture coordinates, one per vertex.
    pub uvs: Vec<Vec2>,
    /// Vertex indices of each triangle, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
    /// Material index of each triangle.
    pub materials: Vec<u16>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// Adds one vertex and returns its index.
    pub fn push_vertex(&mut self, position: Vec3, normal: Vec3, uv: Vec2) -> u32 {
        self.positions.push(position);
        self.normals.push(normal);
        self.uvs.push(uv);
        (self.positions.len() - 1) as u32
    }

    /// Adds one triangle with a material.
    pub fn push_triangle(&mut self, indices: [u32; 3], material: u16) {
        self.triangles.push(indices);
        self.materials.push(material);
    }

    /// Appends another mesh (its material ids are kept as they are).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.normals.extend_from_slice(&other.normals);
        self.uvs.extend_from_slice(&other.uvs);
        self.triangles.extend(
            other
                .triangles
                .iter()
                .map(|t| [t[0] + base, t[1] + base, t[2] + base]),
        );
        self.materials.extend_from_slice(&other.materials);
    }

    /// Applies a rigid or scaling transform to positions and normals in place.
    pub fn transform(&mut self, m: &Affine3A) {
        let normal_matrix = m.matrix3.inverse().transpose();
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        for n in &mut self.normals {
            *n = Vec3::from(normal_matrix * glam::Vec3A::from(*n)).normalize_or_zero();
        }
        if m.matrix3.determinant() < 0.0 {
            for t in &mut self.triangles {
                t.swap(1, 2);
            }
        }
    }

    /// The axis-aligned bounds of all vertices.
    pub fn bounds(&self) -> AxisBox {
        self.positions
            .iter()
            .fold(AxisBox::EMPTY, |b, p| b.with_point(*p))
    }

    /// Adds a planar quad `corner + s·edge_u + t·edge_v`, s, t ∈ [0, 1], facing `edge_u × edge_v`.
    /// UVs are in metres along the two edges.
    pub fn add_quad(&mut self, corner: Vec3, edge_u: Vec3, edge_v: Vec3, material: u16) {
        let normal = edge_u.cross(edge_v).normalize();
        let (lu, lv) = (edge_u.length(), edge_v.length());
        let a = self.push_vertex(corner, normal, Vec2::ZERO);
        let b = self.push_vertex(corner + edge_u, normal, Vec2::new(lu, 0.0));
        let c = self.push_vertex(corner + edge_u + edge_v, normal, Vec2::new(lu, lv));
        let d = self.push_vertex(corner + edge_v, normal, Vec2::new(0.0, lv));
        self.push_triangle([a, b, c], material);
        self.push_triangle([a, c, d], material);
    }

    /// Adds an axis-aligned box with outward faces and flat normals.
    pub fn add_box(&mut self, min: Vec3, max: Vec3, material: u16) {
        let d = max - min;
        let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
        self.add_quad(min, y, x, material); // bottom, faces −z
        self.add_quad(min + z, x, y, material); // top, faces +z
        self.add_quad(min, x, z, material); // faces −y
        self.add_quad(min + y, z, x, material); // faces +y
        self.add_quad(min, z, y, material); // faces −x
        self.add_quad(min + x, y, z, material); // faces +x
    }

    /// Adds a box given by its centre and full extents.
    pub fn add_box_centered(&mut self, centre: Vec3, size: Vec3, material: u16) {
        self.add_box(centre - size * 0.5, centre + size * 0.5, material);
    }

    /// Adds a closed vertical cylinder (z axis) standing on `base`, with smooth sides and flat caps.
    /// UVs on the side run around the circumference and up, in metres.
    pub fn add_cylinder(
        &mut self,
        base: Vec3,
        radius: f32,
        height: f32,
        segments: u32,
        material: u16,
    ) {
        self.add_frustum(base, radius, radius, height, segments, material);
    }

    /// Adds a closed vertical truncated cone: radius `r0` at `base`, `r1` at `base + height·z`.
    pub fn add_frustum(
        &mut self,
        base: Vec3,
        r0: f32,
        r1: f32,
        height: f32,
        segments: u32,
        material: u16,
    ) {
        let slope = (r0 - r1) / height;
        let step = std::f32::consts::TAU / segments as f32;
        let mean_r = 0.5 * (r0 + r1);
        for i in 0..segments {
            let (a0, a1) = (i as f32 * step, (i + 1) as f32 * step);
            let (d0, d1) = (
                Vec3::new(a0.cos(), a0.sin(), 0.0),
                Vec3::new(a1.cos(), a1.sin(), 0.0),
            );
            let (n0, n1) = (
                (d0 + Vec3::Z * slope).normalize(),
                (d1 + Vec3::Z * slope).normalize(),
            );
            let (s0, s1) = (a0 * mean_r, a1 * mean_r);
            let top = base + Vec3::Z * height;
            let v0 = self.push_vertex(base + d0 * r0, n0, Vec2::new(s0, 0.0));
            let v1 = self.push_vertex(base + d1 * r0, n1, Vec2::new(s1, 0.0));
            let v2 = self.push_vertex(top + d1 * r1, n1, Vec2::new(s1, height));
            let v3 = self.push_vertex(top + d0 * r1, n0, Vec2::new(s0, height));
            self.push_triangle([v0, v1, v2], material);
            self.push_triangle([v0, v2, v3], material);
            self.add_cap_wedge(top, d0 * r1, d1 * r1, Vec3::Z, material);
            self.add_cap_wedge(base, d1 * r0, d0 * r0, -Vec3::Z, material);
        }
    }

    /// One triangle of a flat disc cap: centre, then two rim offsets in winding order.
    fn add_cap_wedge(
        &mut self,
        centre: Vec3,
        rim_a: Vec3,
        rim_b: Vec3,
        normal: Vec3,
        material: u16,
    ) {
        if rim_a.length_squared() == 0.0 {
            return;
        }
        let uv = |p: Vec3| Vec2::new(p.x, p.y);
        let c = self.push_vertex(centre, normal, uv(centre));
        let a = self.push_vertex(centre + rim_a, normal, uv(centre + rim_a));
        let b = self.push_vertex(centre + rim_b, normal, uv(centre + rim_b));
        self.push_triangle([c, a, b], material);
    }

    /// Adds a UV sphere (for lamp bulbs, vases, plant crowns).
    pub fn add_sphere(
        &mut self,
        centre: Vec3,
        radius: f32,
        rings: u32,
        segments: u32,
        material: u16,
    ) {
        let base = self.positions.len() as u32;
        for r in 0..=rings {
            let theta = std::f32::consts::PI * r as f32 / rings as f32;
            for s in 0..=segments {
                let phi = std::f32::consts::TAU * s as f32 / segments as f32;
                let n = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                self.push_vertex(
                    centre + n * radius,
                    n,
                    Vec2::new(phi * radius, theta * radius),
                );
            }
        }
        let row = segments + 1;
        for r in 0..rings {
            for s in 0..segments {
                let a = base + r * row + s;
                let (b, c, d) = (a + 1, a + row + 1, a + row);
                if r > 0 {
                    self.push_triangle([a, d, b], material);
                }
                if r + 1 < rings {
                    self.push_triangle([b, d, c], material);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed volume by the divergence theorem: positive iff faces point outwards.
    fn signed_volume(m: &Mesh) -> f32 {
        m.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| m.positions[i as usize]);
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    #[test]
    fn primitives_are_closed_and_outward() {
        let mut m = Mesh::default();
        m.add_box(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), 0);
        assert!((signed_volume(&m) - 6.0).abs() < 1e-4);
        let mut c = Mesh::default();
        c.add_cylinder(Vec3::ZERO, 1.0, 2.0, 256, 0);
        assert!((signed_volume(&c) - std::f32::consts::PI * 2.0).abs() < 1e-2);
        let mut s = Mesh::default();
        s.add_sphere(Vec3::ZERO, 1.0, 64, 128, 0);
        assert!((signed_volume(&s) - 4.0 / 3.0 * std::f32::consts::PI).abs() < 2e-2);
    }

    #[test]
    fn mirror_transform_keeps_faces_outward() {
        let mut m = Mesh::default();
        m.add_box(Vec3::ZERO, Vec3::ONE, 0);
        m.transform(&Affine3A::from_scale(Vec3::new(-2.0, 1.0, 1.0)));
        assert!((signed_volume(&m) - 2.0).abs() < 1e-4);
    }
}

//! The exact ray tracer: models (a mesh, its materials and a triangle BVH) instanced with rigid
//! poses under a top-level BVH. Hits carry the distance, the instance, the triangle and its
//! barycentrics; [`TracedScene::surface`] turns a hit into position, normals, UV and material.

use std::sync::Arc;

use glam::{Mat3, Vec2, Vec3};
use neuroom_core::Pose;

use crate::bvh::{AxisBox, Bvh};
use crate::material::Material;
use crate::mesh::Mesh;

/// A triangle prepared for Möller–Trumbore: one vertex and two edges.
#[derive(Clone, Copy, Debug)]
struct Tri {
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

impl Tri {
    /// Distance and barycentrics (u, v) of a two-sided hit in (1e-6, t_max).
    #[inline(always)]
    fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32, f32)> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det.abs() < 1e-12 {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v0;
        let u = s.dot(p) * inv;
        // A small tolerance keeps rays through shared edges from slipping between two triangles.
        const EPS: f32 = 1e-6;
        if !(-EPS..=1.0 + EPS).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = d.dot(q) * inv;
        if v < -EPS || u + v > 1.0 + EPS {
            return None;
        }
        let t = self.e2.dot(q) * inv;
        (t > 1e-6 && t < t_max).then_some((t, u, v))
    }
}

/// A renderable object: a mesh in its own frame, its materials and a BVH over its triangles.
#[derive(Debug)]
pub struct TracedModel {
    /// Name (catalog kind or OBJ model).
    pub name: String,
    /// The geometry.
    pub mesh: Mesh,
    /// Materials indexed by the mesh's per-triangle ids.
    pub materials: Vec<Material>,
    tris: Vec<Tri>,
    bvh: Bvh,
}

impl TracedModel {
    /// Builds the triangle BVH.
    pub fn new(name: impl Into<String>, mesh: Mesh, materials: Vec<Material>) -> Self {
        let boxes: Vec<AxisBox> = mesh
            .triangles
            .iter()
            .map(|t| {
                t.iter().fold(AxisBox::EMPTY, |b, &i| {
                    b.with_point(mesh.positions[i as usize])
                })
            })
            .collect();
        let bvh = Bvh::build(&boxes);
        let tris = bvh
            .order
            .iter()
            .map(|&i| {
                let [a, b, c] = mesh.triangles[i as usize].map(|k| mesh.positions[k as usize]);
                Tri {
                    v0: a,
                    e1: b - a,
                    e2: c - a,
                }
            })
            .collect();
        Self {
            name: name.into(),
            mesh,
            materials,
            tris,
            bvh,
        }
    }

    /// Bounds of the geometry in the model frame.
    pub fn bounds(&self) -> AxisBox {
        self.mesh.bounds()
    }

    /// Closest (or, with `any_hit`, first) hit: (t, triangle index, u, v).
    #[inline]
    fn intersect(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        any_hit: bool,
    ) -> Option<(f32, u32, f32, f32)> {
        let mut best = None;
        self.bvh.traverse(o, d, t_max, any_hit, |slot, tmax| {
            let (t, u, v) = self.tris[slot as usize].intersect(o, d, tmax)?;
            best = Some((t, self.bvh.order[slot as usize], u, v));
            Some(t)
        });
        best
    }
}

/// A model placed in the world by a rigid pose, with the instance id written to masks (0 = none).
#[derive(Clone, Debug)]
pub struct Instance {
    /// The shared model.
    pub model: Arc<TracedModel>,
    /// Object-to-world pose.
    pub pose: Pose,
    /// Instance-mask value (object id), 0 for the static room.
    pub id: u16,
    rotation: Mat3,
    translation: Vec3,
}

impl Instance {
    /// Places a model.
    pub fn new(model: Arc<TracedModel>, pose: Pose, id: u16) -> Self {
        Self {
            model,
            rotation: pose.rotation_f32(),
            translation: pose.translation_f32(),
            pose,
            id,
        }
    }

    fn world_bounds(&self) -> AxisBox {
        let b = self.model.bounds();
        b.corners().iter().fold(AxisBox::EMPTY, |acc, c| {
            acc.with_point(self.rotation * *c + self.translation)
        })
    }
}

/// The result of a closest-hit query.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray.
    pub t: f32,
    /// Index of the instance hit.
    pub instance: u32,
    /// Triangle index in the model's mesh.
    pub triangle: u32,
    /// Barycentric weights of vertices 1 and 2.
    pub bary: Vec2,
}

/// Everything shading needs at a hit.
#[derive(Clone, Copy, Debug)]
pub struct Surface<'a> {
    /// World position.
    pub position: Vec3,
    /// Interpolated shading normal, flipped to face the incoming ray.
    pub normal: Vec3,
    /// Geometric normal, flipped to face the incoming ray.
    pub geometric_normal: Vec3,
    /// Texture coordinate.
    pub uv: Vec2,
    /// The material there.
    pub material: &'a Material,
    /// Instance-mask value of the object hit.
    pub id: u16,
}

/// Instances under a top-level BVH.
#[derive(Debug)]
pub struct TracedScene {
    instances: Vec<Instance>,
    tlas: Bvh,
}

impl TracedScene {
    /// Builds the top-level BVH over the instances' world boxes.
    pub fn new(instances: Vec<Instance>) -> Self {
        let boxes: Vec<AxisBox> = instances.iter().map(Instance::world_bounds).collect();
        Self {
            tlas: Bvh::build(&boxes),
            instances,
        }
    }

    /// The placed instances.
    pub fn instances(&self) -> &[Instance] {
        &self.instances
    }

    /// Total triangle count over instances.
    pub fn triangle_count(&self) -> usize {
        self.instances
            .iter()
            .map(|i| i.model.mesh.triangle_count())
            .sum()
    }

    /// Closest hit along a unit-direction ray before `t_max`.
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<Hit> {
        if self.instances.is_empty() {
            return None;
        }
        let mut best = None;
        self.tlas.traverse(o, d, t_max, false, |slot, tmax| {
            let i = self.tlas.order[slot as usize];
            let inst = &self.instances[i as usize];
            let (lo, ld) = inst.to_local(o, d);
            let (t, triangle, u, v) = inst.model.intersect(lo, ld, tmax, false)?;
            best = Some(Hit {
                t,
                instance: i,
                triangle,
                bary: Vec2::new(u, v),
            });
            Some(t)
        });
        best
    }

    /// Whether anything blocks the ray before `t_max` (shadow rays).
    pub fn occluded(&self, o: Vec3, d: Vec3, t_max: f32) -> bool {
        if self.instances.is_empty() {
            return false;
        }
        self.tlas
            .traverse(o, d, t_max, true, |slot, tmax| {
                let inst = &self.instances[self.tlas.order[slot as usize] as usize];
                let (lo, ld) = inst.to_local(o, d);
                inst.model.intersect(lo, ld, tmax, true).map(|h| h.0)
            })
            .is_some()
    }

    /// Interpolates the attributes of a hit for a ray of direction `d`.
    pub fn surface(&self, hit: &Hit, o: Vec3, d: Vec3) -> Surface<'_> {
        let inst = &self.instances[hit.instance as usize];
        let mesh = &inst.model.mesh;
        let tri = mesh.triangles[hit.triangle as usize].map(|k| k as usize);
        let (b1, b2) = (hit.bary.x, hit.bary.y);
        let b0 = 1.0 - b1 - b2;
        let [p0, p1, p2] = tri.map(|k| mesh.positions[k]);
        let gn = inst.rotation * (p1 - p0).cross(p2 - p0).normalize_or_zero();
        let n = inst.rotation
            * (mesh.normals[tri[0]] * b0 + mesh.normals[tri[1]] * b1 + mesh.normals[tri[2]] * b2);
        let uv = mesh.uvs[tri[0]] * b0 + mesh.uvs[tri[1]] * b1 + mesh.uvs[tri[2]] * b2;
        let geometric_normal = if gn.dot(d) > 0.0 { -gn } else { gn };
        let mut normal = n.normalize_or(geometric_normal);
        if normal.dot(geometric_normal) < 0.0 {
            normal = -normal;
        }
        let material = &inst.model.materials[mesh.materials[hit.triangle as usize] as usize];
        Surface {
            position: o + d * hit.t,
            normal,
            geometric_normal,
            uv,
            material,
            id: inst.id,
        }
    }
}

impl Instance {
    #[inline(always)]
    fn to_local(&self, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        let rt = self.rotation.transpose();
        (rt * (o - self.translation), rt * d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Texture;

    fn cube_model() -> Arc<TracedModel> {
        let mut m = Mesh::default();
        m.add_box(Vec3::splat(-0.5), Vec3::splat(0.5), 0);
        Arc::new(TracedModel::new(
            "cube",
            m,
            vec![Material::diffuse("grey", Texture::solid(Vec3::splat(0.5)))],
        ))
    }

    #[test]
    fn hits_rotated_instances_exactly() {
        let cube = cube_model();
        let pose = Pose::from_yaw_translation(
            std::f64::consts::FRAC_PI_4,
            glam::DVec3::new(3.0, 0.0, 0.0),
        );
        let scene = TracedScene::new(vec![Instance::new(cube.clone(), pose, 7)]);
        let (o, d) = (Vec3::ZERO, Vec3::X);
        let hit = scene.intersect(o, d, f32::INFINITY).unwrap();
        // A 45°-rotated unit cube presents its edge at 3 − √2/2.
        assert!(
            (hit.t - (3.0 - std::f32::consts::FRAC_1_SQRT_2)).abs() < 1e-5,
            "{}",
            hit.t
        );
        let s = scene.surface(&hit, o, d);
        assert_eq!(s.id, 7);
        assert!(s.geometric_normal.dot(d) < 0.0);
        assert!(scene.occluded(o, d, 3.0));
        assert!(!scene.occluded(o, d, 2.0));
        assert!(scene.intersect(o, -d, f32::INFINITY).is_none());
    }

    #[test]
    fn closest_of_many_instances() {
        let cube = cube_model();
        let instances = (1..20)
            .map(|k| {
                Instance::new(
                    cube.clone(),
                    Pose::from_yaw_translation(
                        0.1 * k as f64,
                        glam::DVec3::new(2.0 * k as f64, 0.0, 0.0),
                    ),
                    k,
                )
            })
            .collect();
        let scene = TracedScene::new(instances);
        let hit = scene
            .intersect(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, f32::INFINITY)
            .unwrap();
        assert_eq!(scene.surface(&hit, Vec3::ZERO, Vec3::X).id, 1);
        let back = scene
            .intersect(Vec3::new(100.0, 0.0, 0.0), -Vec3::X, f32::INFINITY)
            .unwrap();
        assert_eq!(scene.instances()[back.instance as usize].id, 19);
    }
}

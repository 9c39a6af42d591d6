//! Surface points of an object, found once at setup on its SDF's zero set: points drawn on the faces of
//! its box march inward along the face's normal by sphere tracing until they reach the surface. Each point
//! remembers its face, so the bottom points are the object's support and the back points its wall contact.
//! The contact faces (bottom, back) also get their outermost points from a dense trace, so that thin
//! supports such as chair legs are represented.

use glam::Vec3;
use neuroom_field::Field;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The face of the object's box a surface point was traced from (docs/formats.md: the front faces +x).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Face {
    /// −x.
    Back,
    /// +x.
    Front,
    /// −y.
    Right,
    /// +y.
    Left,
    /// −z.
    Bottom,
    /// +z.
    Top,
}

impl Face {
    const ALL: [Face; 6] = [
        Face::Back,
        Face::Front,
        Face::Right,
        Face::Left,
        Face::Bottom,
        Face::Top,
    ];

    /// Axis and sign of the face's outward normal.
    fn axis_sign(self) -> (usize, f32) {
        (
            self as usize / 2,
            if (self as usize).is_multiple_of(2) {
                -1.0
            } else {
                1.0
            },
        )
    }
}

/// Points on an object's surface in its own frame, with the face each was traced from.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SurfacePoints {
    /// Points (object frame, metres).
    pub points: Vec<Vec3>,
    /// Face of each point.
    pub faces: Vec<Face>,
}

impl SurfacePoints {
    /// The points traced from `face`.
    pub fn on(&self, face: Face) -> impl Iterator<Item = Vec3> + '_ {
        self.points
            .iter()
            .zip(&self.faces)
            .filter(move |(_, f)| **f == face)
            .map(|(p, _)| *p)
    }
}

/// Sphere-tracing steps per point.
const TRACE_STEPS: usize = 64;
/// Distance below which a traced point is on the surface (metres).
const HIT: f32 = 2e-3;

/// About `count` surface points of the field inside the box of half extents `half`: faces drawn in
/// proportion to their area, points uniform on them (inset by 1 %), traced inward; points that reach no
/// surface are dropped; then the contact points of the bottom and the back (`CONTACT_KEEP` at most
/// each). Deterministic for a `seed`.
pub fn sample_surface<F: Field>(field: &F, half: Vec3, count: usize, seed: u64) -> SurfacePoints {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let areas = Face::ALL.map(|f| {
        let (a, _) = f.axis_sign();
        half[(a + 1) % 3] * half[(a + 2) % 3]
    });
    let total: f32 = areas.iter().sum();
    let mut starts = Vec::with_capacity(count);
    let mut faces = Vec::with_capacity(count);
    for _ in 0..count {
        let mut pick = rng.random::<f32>() * total;
        let face = *Face::ALL
            .iter()
            .zip(areas)
            .find(|(_, a)| {
                pick -= a;
                pick <= 0.0
            })
            .map_or(&Face::Top, |(f, _)| f);
        let (axis, sign) = face.axis_sign();
        let mut p = Vec3::ZERO;
        for a in 0..3 {
            p[a] = half[a] * (0.99 * (2.0 * rng.random::<f32>() - 1.0));
        }
        p[axis] = sign * half[axis];
        starts.push(p);
        faces.push(face);
    }
    let mut surface = trace_inward(field, half, starts, faces);
    for face in [Face::Bottom, Face::Back] {
        let contact = contact_points(field, half, face, &mut rng);
        surface.faces.extend(contact.iter().map(|_| face));
        surface.points.extend(contact);
    }
    surface
}

/// Starts traced per contact face (bottom, back) on top of the area-proportional ones: thin supports
/// (chair legs) cover a few percent of a face, and the magnetic loss needs points on them.
const CONTACT_STARTS: usize = 2048;
/// Contact points kept are within this distance (metres) of the face's outermost surface point.
const CONTACT_BAND: f32 = 0.01;
/// Most contact points kept per face.
const CONTACT_KEEP: usize = 48;

/// The outermost surface points seen from `face`: a dense set of starts traced inward, of which those
/// within [`CONTACT_BAND`] of the outermost are kept (at most [`CONTACT_KEEP`], evenly spread).
fn contact_points<F: Field>(field: &F, half: Vec3, face: Face, rng: &mut impl Rng) -> Vec<Vec3> {
    let (axis, sign) = face.axis_sign();
    let starts: Vec<Vec3> = (0..CONTACT_STARTS)
        .map(|_| {
            let mut p = Vec3::ZERO;
            for a in 0..3 {
                p[a] = half[a] * (0.99 * (2.0 * rng.random::<f32>() - 1.0));
            }
            p[axis] = sign * half[axis];
            p
        })
        .collect();
    let traced = trace_inward(field, half, starts, vec![face; CONTACT_STARTS]);
    let Some(outer) = traced
        .points
        .iter()
        .map(|p| sign * p[axis])
        .max_by(f32::total_cmp)
    else {
        return Vec::new();
    };
    let band: Vec<Vec3> = traced
        .points
        .into_iter()
        .filter(|p| sign * p[axis] >= outer - CONTACT_BAND)
        .collect();
    let stride = band.len().div_ceil(CONTACT_KEEP).max(1);
    band.into_iter().step_by(stride).collect()
}

/// Marches every start point along its face's inward normal to the surface.
fn trace_inward<F: Field>(
    field: &F,
    half: Vec3,
    mut points: Vec<Vec3>,
    faces: Vec<Face>,
) -> SurfacePoints {
    let dirs: Vec<Vec3> = faces
        .iter()
        .map(|f| {
            let (axis, sign) = f.axis_sign();
            let mut d = Vec3::ZERO;
            d[axis] = -sign;
            d
        })
        .collect();
    let limits: Vec<f32> = faces.iter().map(|f| 2.0 * half[f.axis_sign().0]).collect();
    let mut travelled = vec![0.0f32; points.len()];
    let mut sdf = vec![0.0f32; points.len()];
    for _ in 0..TRACE_STEPS {
        field.sdf(&points, &mut sdf);
        for k in 0..points.len() {
            if sdf[k] > HIT && travelled[k] < limits[k] {
                points[k] += dirs[k] * sdf[k];
                travelled[k] += sdf[k];
            }
        }
    }
    field.sdf(&points, &mut sdf);
    let keep = |k: usize| sdf[k].abs() <= HIT && travelled[k] < limits[k];
    let kept: Vec<usize> = (0..points.len()).filter(|&k| keep(k)).collect();
    SurfacePoints {
        points: kept.iter().map(|&k| points[k]).collect(),
        faces: kept.iter().map(|&k| faces[k]).collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_field::{AnalyticColor, AnalyticField};

    /// A stool: a seat 0.4 m above the floor on four 3 cm legs, in a box of half extents 0.2 × 0.2 × 0.25.
    fn stool() -> AnalyticField {
        let color = AnalyticColor::Constant(Vec3::splat(0.5));
        let mut parts = vec![AnalyticField::Cuboid {
            centre: Vec3::new(0.0, 0.0, 0.2),
            half: Vec3::new(0.2, 0.2, 0.03),
            color,
        }];
        for (x, y) in [(-1.0, -1.0), (-1.0, 1.0), (1.0, -1.0), (1.0, 1.0)] {
            parts.push(AnalyticField::Cuboid {
                centre: Vec3::new(0.17 * x, 0.17 * y, -0.03),
                half: Vec3::new(0.015, 0.015, 0.22),
                color,
            });
        }
        AnalyticField::Union(parts)
    }

    #[test]
    fn bottom_points_include_the_feet_of_thin_legs() {
        let half = Vec3::new(0.2, 0.2, 0.25);
        let surface = sample_surface(&stool(), half, 256, 1);
        let bottom: Vec<Vec3> = surface.on(Face::Bottom).collect();
        let feet = bottom.iter().filter(|p| p.z < -0.24).count();
        assert!(
            feet >= 8,
            "{feet} of {} bottom points on the feet",
            bottom.len()
        );
        let lowest = bottom.iter().map(|p| p.z).fold(f32::INFINITY, f32::min);
        assert!(
            (lowest + 0.25).abs() < 2e-3,
            "lowest bottom point at {lowest}"
        );
        // The area-proportional points alone would mostly land on the seat's underside.
        assert!(bottom.iter().any(|p| p.z > 0.1));
    }
}

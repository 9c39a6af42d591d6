//! Surface points of an object, found once at setup on its SDF's zero set: points drawn on the faces of
//! its box march inward along the face's normal by sphere tracing until they reach the surface. Each point
//! remembers its face, so the bottom points are the object's support and the back points its wall contact.

use glam::Vec3;
use neuroom_field::Field;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// The face of the object's box a surface point was traced from (FORMAT.md: the front faces +x).
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
/// surface are dropped. Deterministic for a `seed`.
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
    trace_inward(field, half, starts, faces)
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

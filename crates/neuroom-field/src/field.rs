//! The [`Field`] trait — batched SDF and colour queries with gradients — for the neural field and for
//! analytic fields (sphere, box, room shell, union) used by tests of later stages.

use crate::batch::Tape;
use crate::neus::{CodeSet, NeusField, Outputs};
use crate::params::Params;
use glam::Vec3;

/// A batch of points to query in the field's frame, with unit view directions and codes.
#[derive(Clone, Copy, Debug)]
pub struct Query<'a> {
    /// Points (field frame, metres).
    pub points: &'a [Vec3],
    /// Unit view directions (field frame), one per point.
    pub dirs: &'a [Vec3],
    /// Code rows (ignored by analytic fields).
    pub codes: CodeSet<'a>,
}

/// What a full query returns.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FieldOutput {
    /// Signed distance (positive outside).
    pub sdf: Vec<f32>,
    /// Colour in `[0, 1]`.
    pub rgb: Vec<Vec3>,
    /// `∂SDF/∂x` (not normalised).
    pub gradient: Vec<Vec3>,
}

/// A signed-distance + radiance field queried in batches. Backward passes follow a forward pass on the
/// same query and tape.
pub trait Field: Sync {
    /// What a forward pass saves for its backward pass.
    type Tape: Default + Send;

    /// Signed distances at `points` (no gradient).
    fn sdf(&self, points: &[Vec3], sdf: &mut [f32]);

    /// Signed distances and `∂SDF/∂x` at `points`.
    fn sdf_gradient(&self, points: &[Vec3], sdf: &mut [f32], gradient: &mut [Vec3]);

    /// Full query: SDF, gradient and colour, saving what the backward pass needs.
    fn forward(&self, query: &Query, tape: &mut Self::Tape, out: &mut FieldOutput);

    /// Backward pass of [`Field::forward`]: adds parameter gradients to `grads` (shape of the field's
    /// parameters; analytic fields have none) and, with `d_points`, writes `∂loss/∂x` (the path through the
    /// normal fed to the colour network excluded).
    fn backward(
        &self,
        query: &Query,
        tape: &mut Self::Tape,
        d_sdf: &[f32],
        d_rgb: &[Vec3],
        grads: &mut Params<f32>,
        d_points: Option<&mut [Vec3]>,
    );
}

fn as_arrays(v: &[Vec3]) -> &[[f32; 3]] {
    // SAFETY: glam's `Vec3` is `#[repr(C)]` of three `f32` with no padding (size 12, align 4), the layout
    // of `[f32; 3]`.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast(), v.len()) }
}

fn as_arrays_mut(v: &mut [Vec3]) -> &mut [[f32; 3]] {
    // SAFETY: as in `as_arrays`.
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast(), v.len()) }
}

fn as_flat(v: &[Vec3]) -> &[f32] {
    // SAFETY: as in `as_arrays`; `[[f32; 3]]` flattens to `3 · len` floats.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast(), v.len() * 3) }
}

impl Field for NeusField<f32> {
    type Tape = Tape<f32>;

    fn sdf(&self, points: &[Vec3], sdf: &mut [f32]) {
        let mut tape = self.spare_tapes.take();
        NeusField::forward(
            self,
            as_arrays(points),
            &[],
            &CodeSet::default(),
            Outputs::Sdf,
            &mut tape,
        );
        tape.copy_sdf(sdf);
        self.spare_tapes.give_back(tape);
    }

    fn sdf_gradient(&self, points: &[Vec3], sdf: &mut [f32], gradient: &mut [Vec3]) {
        let mut tape = self.spare_tapes.take();
        NeusField::forward(
            self,
            as_arrays(points),
            &[],
            &CodeSet::default(),
            Outputs::SdfGradient,
            &mut tape,
        );
        tape.copy_sdf(sdf);
        tape.copy_gradient(as_arrays_mut(gradient));
        self.spare_tapes.give_back(tape);
    }

    fn forward(&self, query: &Query, tape: &mut Tape<f32>, out: &mut FieldOutput) {
        let n = query.points.len();
        NeusField::forward(
            self,
            as_arrays(query.points),
            as_arrays(query.dirs),
            &query.codes,
            Outputs::Full,
            tape,
        );
        out.sdf.resize(n, 0.0);
        out.rgb.resize(n, Vec3::ZERO);
        out.gradient.resize(n, Vec3::ZERO);
        tape.copy_sdf(&mut out.sdf);
        // SAFETY: as in `as_arrays`.
        let rgb =
            unsafe { std::slice::from_raw_parts_mut(out.rgb.as_mut_ptr().cast::<f32>(), n * 3) };
        tape.copy_rgb(rgb);
        tape.copy_gradient(as_arrays_mut(&mut out.gradient));
    }

    fn backward(
        &self,
        query: &Query,
        tape: &mut Tape<f32>,
        d_sdf: &[f32],
        d_rgb: &[Vec3],
        grads: &mut Params<f32>,
        d_points: Option<&mut [Vec3]>,
    ) {
        let dp = d_points.map(as_arrays_mut);
        NeusField::backward(
            self,
            &query.codes,
            tape,
            d_sdf,
            Some(as_flat(d_rgb)),
            grads,
            dp,
        );
    }
}

/// How an analytic field is coloured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AnalyticColor {
    /// One colour everywhere.
    Constant(Vec3),
    /// `clamp(0.5 + 0.5 · (x − origin) / scale, 0, 1)` per channel: varies with position, so colour
    /// gradients reach the points.
    Position {
        /// Where the colour is mid-grey.
        origin: Vec3,
        /// Distance over which a channel goes from grey to saturated.
        scale: f32,
    },
}

impl AnalyticColor {
    fn eval(&self, x: Vec3) -> Vec3 {
        match *self {
            AnalyticColor::Constant(c) => c,
            AnalyticColor::Position { origin, scale } => {
                (Vec3::splat(0.5) + 0.5 * (x - origin) / scale).clamp(Vec3::ZERO, Vec3::ONE)
            }
        }
    }

    /// `Σ_c d_rgb_c · ∂rgb_c/∂x`.
    fn backward(&self, x: Vec3, d_rgb: Vec3) -> Vec3 {
        match *self {
            AnalyticColor::Constant(_) => Vec3::ZERO,
            AnalyticColor::Position { origin, scale } => {
                let v = Vec3::splat(0.5) + 0.5 * (x - origin) / scale;
                let inside = Vec3::select(
                    v.cmpgt(Vec3::ZERO) & v.cmplt(Vec3::ONE),
                    Vec3::ONE,
                    Vec3::ZERO,
                );
                d_rgb * inside * (0.5 / scale)
            }
        }
    }
}

/// An exact analytic SDF with a colour: the reference field of tests.
#[derive(Clone, Debug, PartialEq)]
pub enum AnalyticField {
    /// A ball.
    Sphere {
        /// Centre.
        centre: Vec3,
        /// Radius.
        radius: f32,
        /// Colour.
        color: AnalyticColor,
    },
    /// An axis-aligned solid box.
    Cuboid {
        /// Centre.
        centre: Vec3,
        /// Half extents.
        half: Vec3,
        /// Colour.
        color: AnalyticColor,
    },
    /// The inside of an axis-aligned box seen from within (a room): positive inside, negative in the walls.
    RoomShell {
        /// Centre.
        centre: Vec3,
        /// Half extents of the free space.
        half: Vec3,
        /// Colour.
        color: AnalyticColor,
    },
    /// The union of fields (minimum SDF; colour and gradient of the nearest member).
    Union(Vec<AnalyticField>),
}

impl AnalyticField {
    /// SDF, gradient and colour at one point.
    pub fn eval(&self, x: Vec3) -> (f32, Vec3, Vec3) {
        self.nearest(x).eval_leaf(x)
    }

    fn nearest(&self, x: Vec3) -> &AnalyticField {
        match self {
            AnalyticField::Union(members) => members
                .iter()
                .map(|m| m.nearest(x))
                .min_by(|a, b| a.eval_leaf(x).0.total_cmp(&b.eval_leaf(x).0))
                .expect("a union needs at least one member"),
            leaf => leaf,
        }
    }

    fn eval_leaf(&self, x: Vec3) -> (f32, Vec3, Vec3) {
        match self {
            AnalyticField::Sphere {
                centre,
                radius,
                color,
            } => {
                let d = x - *centre;
                (d.length() - radius, d.normalize_or_zero(), color.eval(x))
            }
            AnalyticField::Cuboid {
                centre,
                half,
                color,
            } => {
                let (s, g) = box_sdf(x - *centre, *half);
                (s, g, color.eval(x))
            }
            AnalyticField::RoomShell {
                centre,
                half,
                color,
            } => {
                let (s, g) = box_sdf(x - *centre, *half);
                (-s, -g, color.eval(x))
            }
            AnalyticField::Union(_) => unreachable!("nearest() returns a leaf"),
        }
    }

    fn color(&self) -> AnalyticColor {
        match self {
            AnalyticField::Sphere { color, .. }
            | AnalyticField::Cuboid { color, .. }
            | AnalyticField::RoomShell { color, .. } => *color,
            AnalyticField::Union(_) => unreachable!("nearest() returns a leaf"),
        }
    }
}

/// Exact SDF of a box of half extents `h` centred at the origin, and its gradient.
fn box_sdf(p: Vec3, h: Vec3) -> (f32, Vec3) {
    let q = p.abs() - h;
    let outside = q.max(Vec3::ZERO);
    let len = outside.length();
    if len > 0.0 {
        return (len, (outside / len) * p.signum());
    }
    let m = q.max_element();
    let axis = if q.x == m {
        Vec3::X
    } else if q.y == m {
        Vec3::Y
    } else {
        Vec3::Z
    };
    (m, axis * p.signum())
}

impl Field for AnalyticField {
    type Tape = ();

    fn sdf(&self, points: &[Vec3], sdf: &mut [f32]) {
        for (s, x) in sdf.iter_mut().zip(points) {
            *s = self.eval(*x).0;
        }
    }

    fn sdf_gradient(&self, points: &[Vec3], sdf: &mut [f32], gradient: &mut [Vec3]) {
        for ((s, g), x) in sdf.iter_mut().zip(gradient.iter_mut()).zip(points) {
            (*s, *g, _) = self.eval(*x);
        }
    }

    fn forward(&self, query: &Query, _tape: &mut (), out: &mut FieldOutput) {
        let n = query.points.len();
        out.sdf.resize(n, 0.0);
        out.rgb.resize(n, Vec3::ZERO);
        out.gradient.resize(n, Vec3::ZERO);
        for (i, x) in query.points.iter().enumerate() {
            (out.sdf[i], out.gradient[i], out.rgb[i]) = self.eval(*x);
        }
    }

    fn backward(
        &self,
        query: &Query,
        _tape: &mut (),
        d_sdf: &[f32],
        d_rgb: &[Vec3],
        _grads: &mut Params<f32>,
        d_points: Option<&mut [Vec3]>,
    ) {
        let Some(d_points) = d_points else { return };
        for (i, x) in query.points.iter().enumerate() {
            let leaf = self.nearest(*x);
            let (_, g, _) = leaf.eval_leaf(*x);
            d_points[i] = d_sdf[i] * g + leaf.color().backward(*x, d_rgb[i]);
        }
    }
}

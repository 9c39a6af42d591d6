//! The NeuS field: hash encoding → SDF network → (SDF, geometry feature), and a colour network on the
//! geometry feature, the view direction (SH), the normal and the appearance / light codes.
//!
//! Batch layout: points are `[T; 3]` rows (SoA is not needed: every stage reads all three coordinates).
//! Work is done per chunk of at most [`CHUNK`] points with a reusable [`Workspace`]; the batched
//! [`NeusField::forward`] / [`NeusField::backward`] run chunks in parallel, keep one small gradient
//! accumulator per thread (everything but the hash tables), and scatter the hash-table gradient afterwards
//! with one rayon task per level (see [`crate::hash`]).
//!
//! Geometric initialisation: the SDF is `network(x) + base(x)` with a fixed analytic
//! `base(x) = ±(|x − c| − r)` (sign `−` for a room, so the inside of the room is positive), and the
//! network's output layer starts near zero; the field therefore starts as a sphere (or an inside-out
//! sphere) exactly, whatever the hash grid holds. This replaces the bias trick of NeuS, which does not carry
//! over to a one-hidden-layer network on a hash encoding.
//!
//! Normals: the colour network sees the analytic gradient `∂SDF/∂x` (through the hash grid's trilinear
//! weights and the network), normalised, as an input without gradient through it. The eikonal loss instead
//! uses central finite differences ([`NeusField::eikonal`]), so no second derivatives are ever needed.

use crate::hash::{HashGrid, HashGridConfig, Strides};
use crate::kernel::Precision;
use crate::mlp::{Activation, Mlp, MlpConfig, MlpPack, MlpWorkspace};
use crate::params::{Group, Params};
use crate::real::Real;
use crate::rng::SplitMix;
use crate::sh::{SH_DIM, sh4};
use serde::{Deserialize, Serialize};

/// Points per chunk: small enough that a chunk's activations stay in L2 cache.
pub const CHUNK: usize = 256;

/// The analytic base SDF added to the network output (see the module documentation): a sphere, or a box
/// when `box_half_extent` is given.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeometricInit {
    /// Sphere or box centre (field coordinates, metres).
    pub centre: [f32; 3],
    /// Sphere radius (metres).
    pub radius: f32,
    /// Flip the sign: positive inside (the room).
    pub inside_out: bool,
    /// Half extent of a box base instead of the sphere. The room uses its box: a part of the room no
    /// capture saw (often the ceiling above the panorama) then stays closed where the room box says,
    /// instead of opening onto an inside-out sphere beyond the field's bounds.
    #[serde(default)]
    pub box_half_extent: Option<[f32; 3]>,
}

/// Everything that fixes a field's shape; stored as JSON beside the weights.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NeusConfig {
    /// Hash encoding.
    pub hash: HashGridConfig,
    /// Hidden widths of the SDF network (default one layer of 64).
    pub sdf_hidden: Vec<usize>,
    /// Hidden activation of the SDF network.
    pub sdf_activation: Activation,
    /// Width of the geometry feature passed to the colour network (default 15).
    pub geometry_features: usize,
    /// Hidden widths of the colour network (default two layers of 64).
    pub color_hidden: Vec<usize>,
    /// Width of every code: appearance, light and object (default 16).
    pub code_dim: usize,
    /// Number of appearance codes (capture frames).
    pub appearance_codes: usize,
    /// Number of light codes (lightings).
    pub light_codes: usize,
    /// Number of object codes; 0 = the SDF network takes no object code.
    pub object_codes: usize,
    /// Lower corner of the field's box: points are mapped from this box to `[0,1]³` for the hash grid.
    pub bounds_min: [f32; 3],
    /// Upper corner of the field's box.
    pub bounds_max: [f32; 3],
    /// Analytic base SDF.
    pub init: GeometricInit,
    /// Initial NeuS variance (`inv_s = exp(10 · variance)`).
    pub init_variance: f32,
    /// Seed of the initialisation.
    pub seed: u64,
    /// Arithmetic of both networks' products (default `f32`).
    #[serde(default, skip_serializing_if = "Precision::is_f32")]
    pub mlp_precision: Precision,
}

impl NeusConfig {
    /// The default object field: L = 16, F = 2, T = 2^15, base resolution 16, finest 1024, SDF network one
    /// hidden layer of 64 (ReLU), geometry feature 15, colour network 2 × 64, codes of 16; a sphere of
    /// radius 0.8 × the smallest half-extent; the box is the object box padded on every side by 10 % of its
    /// largest half-extent (a flat object, such as a picture, still gets room in front of its face for rays
    /// to build up opacity).
    pub fn object(half_extent: [f32; 3]) -> Self {
        let margin = 0.1 * half_extent.iter().copied().fold(0.0, f32::max);
        let pad = half_extent.map(|h| h + margin);
        let r = 0.8 * half_extent.iter().copied().fold(f32::INFINITY, f32::min);
        Self::with_bounds(
            pad.map(|h| -h),
            pad,
            15,
            1024,
            GeometricInit {
                centre: [0.0; 3],
                radius: r,
                inside_out: false,
                box_half_extent: None,
            },
        )
    }

    /// The default room (background) field: as [`NeusConfig::object`] but T = 2^19, finest 2048 over the
    /// room box padded by 5 %, and the room box itself as an inside-out base, positive inside.
    pub fn room(bounds_min: [f32; 3], bounds_max: [f32; 3]) -> Self {
        let centre = std::array::from_fn(|a| 0.5 * (bounds_min[a] + bounds_max[a]));
        let half: [f32; 3] = std::array::from_fn(|a| 0.5 * (bounds_max[a] - bounds_min[a]));
        let radius = half.iter().map(|h| h * h).sum::<f32>().sqrt();
        let lo = std::array::from_fn(|a| bounds_min[a] - 0.05 * half[a]);
        let hi = std::array::from_fn(|a| bounds_max[a] + 0.05 * half[a]);
        Self::with_bounds(
            lo,
            hi,
            19,
            2048,
            GeometricInit {
                centre,
                radius,
                inside_out: true,
                box_half_extent: Some(half),
            },
        )
    }

    fn with_bounds(
        lo: [f32; 3],
        hi: [f32; 3],
        log2_table: u32,
        finest: usize,
        init: GeometricInit,
    ) -> Self {
        Self {
            hash: HashGridConfig {
                levels: 16,
                features: 2,
                log2_table,
                base_resolution: 16,
                finest_resolution: finest,
            },
            sdf_hidden: vec![64],
            sdf_activation: Activation::Relu,
            geometry_features: 15,
            color_hidden: vec![64, 64],
            code_dim: 16,
            appearance_codes: 1,
            light_codes: 1,
            object_codes: 0,
            bounds_min: lo,
            bounds_max: hi,
            init,
            init_variance: 0.3,
            seed: 0x5EED,
            mlp_precision: Precision::F32,
        }
    }

    fn object_dim(&self) -> usize {
        if self.object_codes > 0 {
            self.code_dim
        } else {
            0
        }
    }
}

/// Which outputs a forward pass computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outputs {
    /// SDF (and geometry feature) only: sphere tracing, eikonal loss, SDF regression.
    Sdf,
    /// SDF and its gradient `∂SDF/∂x`; needed for position gradients in the backward pass.
    SdfGradient,
    /// SDF, gradient and colour.
    Full,
}

/// Code indices of a batch: one for all points, or one per point.
#[derive(Clone, Copy, Debug)]
pub enum Codes<'a> {
    /// The same row for every point.
    Fixed(u32),
    /// One row per point.
    PerPoint(&'a [u32]),
}

impl<'a> Codes<'a> {
    /// Row of point `i`.
    #[inline(always)]
    pub fn get(&self, i: usize) -> usize {
        match self {
            Codes::Fixed(c) => *c as usize,
            Codes::PerPoint(c) => c[i] as usize,
        }
    }

    /// The codes of points `start..end`.
    pub fn slice(&self, start: usize, end: usize) -> Codes<'a> {
        match self {
            Codes::Fixed(c) => Codes::Fixed(*c),
            Codes::PerPoint(c) => Codes::PerPoint(&c[start..end]),
        }
    }
}

/// The appearance, light and object codes of a batch.
#[derive(Clone, Copy, Debug)]
pub struct CodeSet<'a> {
    /// Appearance code rows.
    pub appearance: Codes<'a>,
    /// Light code rows.
    pub light: Codes<'a>,
    /// Object code rows (ignored when the field has no object codes).
    pub object: Codes<'a>,
}

impl Default for CodeSet<'_> {
    fn default() -> Self {
        Self {
            appearance: Codes::Fixed(0),
            light: Codes::Fixed(0),
            object: Codes::Fixed(0),
        }
    }
}

impl<'a> CodeSet<'a> {
    /// The codes of points `start..end`.
    pub fn slice(&self, start: usize, end: usize) -> CodeSet<'a> {
        CodeSet {
            appearance: self.appearance.slice(start, end),
            light: self.light.slice(start, end),
            object: self.object.slice(start, end),
        }
    }
}

/// Both networks' weights packed for one batched pass (see [`MlpPack`]).
#[derive(Clone, Debug, Default)]
pub struct FieldPack<T> {
    sdf: MlpPack<T>,
    color: MlpPack<T>,
}

/// Buffers of one chunk, allocated once and reused: inputs, activations, outputs and gradients.
#[derive(Clone, Debug, Default)]
pub struct Workspace<T> {
    n: usize,
    outputs: Option<Outputs>,
    u: Vec<[T; 3]>,
    enc: Vec<T>,
    sdf_in: Vec<T>,
    jac: Vec<T>,
    sdf_ws: MlpWorkspace<T>,
    color_in: Vec<T>,
    color_ws: MlpWorkspace<T>,
    sdf: Vec<T>,
    gradient: Vec<[T; 3]>,
    base_grad: Vec<[T; 3]>,
    d_out: Vec<T>,
    d_sdf_in: Vec<T>,
    d_enc: Vec<T>,
    d_color_in: Vec<T>,
    rgb: Vec<T>,
    pos_acc: Vec<T>,
    code_sum: Vec<T>,
}

impl<T: Real> Workspace<T> {
    /// Number of points of the last forward pass.
    pub fn len(&self) -> usize {
        self.n
    }

    /// The outputs the last forward pass computed (`None` before any).
    pub fn outputs(&self) -> Option<Outputs> {
        self.outputs
    }

    /// Whether the last forward pass had no points.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// SDF of the last forward pass.
    pub fn sdf(&self) -> &[T] {
        &self.sdf[..self.n]
    }

    /// `∂SDF/∂x` of the last forward pass (not normalised); valid unless it ran with [`Outputs::Sdf`].
    pub fn gradient(&self) -> &[[T; 3]] {
        &self.gradient[..self.n]
    }

    /// RGB rows (`n × 3`) of the last [`Outputs::Full`] forward pass.
    pub fn rgb(&self) -> &[T] {
        &self.rgb[..self.n * 3]
    }
}

/// A NeuS field with its parameters (`f32` to train and render, `f64` for gradient tests).
#[derive(Clone, Debug)]
pub struct NeusField<T = f32> {
    config: NeusConfig,
    grid: HashGrid,
    sdf_mlp: Mlp,
    color_mlp: Mlp,
    /// The parameters, one flat vector per [`Group`].
    pub params: Params<T>,
    active_levels: usize,
    lo: [T; 3],
    inv_ext: [T; 3],
    /// Tapes of finished SDF queries, for the next ones ([`crate::batch::SpareTapes`]).
    pub(crate) spare_tapes: crate::batch::SpareTapes<T>,
}

/// Signed distance from `d` (relative to the centre) to a box of half extent `half`, and its gradient.
fn box_sdf<T: Real>(d: &[T; 3], half: &[T; 3]) -> (T, [T; 3]) {
    let sign = |v: T| if v < T::ZERO { -T::ONE } else { T::ONE };
    let abs = |v: T| if v < T::ZERO { -v } else { v };
    let q: [T; 3] = std::array::from_fn(|a| abs(d[a]) - half[a]);
    let out: [T; 3] = q.map(|v| v.max(T::ZERO));
    let len = (out[0] * out[0] + out[1] * out[1] + out[2] * out[2]).sqrt();
    if len > T::ZERO {
        return (len, std::array::from_fn(|a| sign(d[a]) * out[a] / len));
    }
    let a = (0..3).fold(0, |m, a| if q[a] > q[m] { a } else { m });
    let mut grad = [T::ZERO; 3];
    grad[a] = sign(d[a]);
    (q[a], grad)
}

impl<T: Real> NeusField<T> {
    /// A freshly initialised field: tables uniform in ±1e-4, networks He-uniform, the SDF output layer
    /// scaled by 0.01 (the field starts as its analytic base), codes uniform in ±0.01.
    pub fn new(config: NeusConfig) -> Self {
        let mut field = Self::uninit(config);
        let mut rng = SplitMix::new(field.config.seed);
        let uniform = |v: &mut [T], rng: &mut SplitMix, s: f64| {
            v.iter_mut()
                .for_each(|x| *x = T::from_f64(s * (2.0 * rng.next_f64() - 1.0)))
        };
        uniform(field.params.get_mut(Group::Hash), &mut rng, 1e-4);
        field
            .sdf_mlp
            .init(field.params.get_mut(Group::SdfMlp), &mut rng, 0.01);
        field
            .color_mlp
            .init(field.params.get_mut(Group::ColorMlp), &mut rng, 1.0);
        for g in [Group::Appearance, Group::Light, Group::Object] {
            uniform(field.params.get_mut(g), &mut rng, 0.01);
        }
        field.params.get_mut(Group::Variance)[0] = T::from_f64(field.config.init_variance as f64);
        field
    }

    /// A field of this configuration with all parameters zero (checkpoint loading fills them).
    pub fn uninit(config: NeusConfig) -> Self {
        let grid = HashGrid::new(config.hash.clone());
        let enc = config.hash.output_dim();
        let sdf_mlp = Mlp::new(MlpConfig {
            input: enc + 3 + config.object_dim(),
            hidden: config.sdf_hidden.clone(),
            output: 1 + config.geometry_features,
            hidden_activation: config.sdf_activation,
            output_activation: Activation::None,
            precision: config.mlp_precision,
        });
        let color_mlp = Mlp::new(MlpConfig {
            input: config.geometry_features + 2 * config.code_dim + SH_DIM + 3,
            hidden: config.color_hidden.clone(),
            output: 3,
            hidden_activation: Activation::Relu,
            output_activation: Activation::Sigmoid,
            precision: config.mlp_precision,
        });
        let sizes = [
            grid.num_params(),
            sdf_mlp.num_params(),
            color_mlp.num_params(),
            config.appearance_codes * config.code_dim,
            config.light_codes * config.code_dim,
            config.object_codes * config.object_dim(),
            1,
        ];
        let params = Params {
            groups: sizes.map(|s| vec![T::ZERO; s]),
        };
        let lo = config.bounds_min.map(|v| T::from_f64(v as f64));
        let inv_ext = std::array::from_fn(|a| {
            T::from_f64(1.0 / (config.bounds_max[a] - config.bounds_min[a]) as f64)
        });
        let active_levels = config.hash.levels;
        Self {
            config,
            grid,
            sdf_mlp,
            color_mlp,
            params,
            active_levels,
            lo,
            inv_ext,
            spare_tapes: Default::default(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &NeusConfig {
        &self.config
    }

    /// The hash grid layout.
    pub fn grid(&self) -> &HashGrid {
        &self.grid
    }

    /// The SDF network layout.
    pub fn sdf_mlp(&self) -> &Mlp {
        &self.sdf_mlp
    }

    /// The colour network layout.
    pub fn color_mlp(&self) -> &Mlp {
        &self.color_mlp
    }

    /// Number of hash levels in use (coarse-to-fine training); finer levels output zero.
    pub fn active_levels(&self) -> usize {
        self.active_levels
    }

    /// Uses only the first `k` hash levels (clamped to `1..=L`).
    pub fn set_active_levels(&mut self, k: usize) {
        self.active_levels = k.clamp(1, self.config.hash.levels);
    }

    /// NeuS sharpness `inv_s = exp(10 · variance)`.
    pub fn inv_s(&self) -> T {
        (T::from_f64(10.0) * self.params.get(Group::Variance)[0]).exp()
    }

    /// Adds the gradient of a loss with respect to `inv_s` (from the volume renderer) to the variance.
    pub fn backward_inv_s(&self, d_inv_s: T, grads: &mut Params<T>) {
        grads.get_mut(Group::Variance)[0] += d_inv_s * T::from_f64(10.0) * self.inv_s();
    }

    /// A workspace for chunks of up to [`CHUNK`] points.
    pub fn workspace(&self) -> Workspace<T> {
        let (si, so) = (self.sdf_in_dim(), 1 + self.config.geometry_features);
        let ci = self.color_mlp.config().input;
        Workspace {
            n: 0,
            outputs: None,
            u: vec![[T::ZERO; 3]; CHUNK],
            enc: vec![T::ZERO; CHUNK * self.config.hash.output_dim()],
            sdf_in: vec![T::ZERO; CHUNK * si],
            jac: vec![T::ZERO; CHUNK * self.config.hash.output_dim() * 3],
            sdf_ws: self.sdf_mlp.workspace(CHUNK),
            color_in: vec![T::ZERO; CHUNK * (ci - 2 * self.config.code_dim)],
            color_ws: self.color_mlp.workspace(CHUNK),
            sdf: vec![T::ZERO; CHUNK],
            gradient: vec![[T::ZERO; 3]; CHUNK],
            base_grad: vec![[T::ZERO; 3]; CHUNK],
            d_out: vec![T::ZERO; CHUNK * so],
            d_sdf_in: vec![T::ZERO; CHUNK * si],
            d_enc: vec![T::ZERO; CHUNK * self.config.hash.output_dim()],
            d_color_in: vec![T::ZERO; CHUNK * self.config.geometry_features],
            code_sum: vec![T::ZERO; self.color_mlp.config().hidden.first().map_or(3, |h| *h)],
            rgb: vec![T::ZERO; CHUNK * 3],
            pos_acc: vec![T::ZERO; CHUNK * 3],
        }
    }

    fn sdf_in_dim(&self) -> usize {
        self.sdf_mlp.config().input
    }

    /// Input columns of the colour network that hold the appearance and light codes. They are left out of
    /// the per-point product ([`Mlp::forward_split`]): a code's contribution to the first layer is computed
    /// once per run of points sharing it, and its gradient summed over the run before the product with the
    /// weights (exact, and it takes a third of the colour network's first-layer work away).
    fn code_columns(&self) -> std::ops::Range<usize> {
        let g = self.config.geometry_features;
        g..g + 2 * self.config.code_dim
    }

    /// The analytic base SDF and its gradient at `x`.
    #[inline]
    fn base(&self, x: &[T; 3]) -> (T, [T; 3]) {
        let init = &self.config.init;
        let d: [T; 3] = std::array::from_fn(|a| x[a] - T::from_f64(init.centre[a] as f64));
        let (sdf, grad) = match init.box_half_extent {
            Some(half) => box_sdf(&d, &half.map(|h| T::from_f64(h as f64))),
            None => {
                let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
                    .sqrt()
                    .max(T::from_f64(1e-12));
                (r - T::from_f64(init.radius as f64), d.map(|v| v / r))
            }
        };
        let s = if init.inside_out { -T::ONE } else { T::ONE };
        (s * sdf, grad.map(|g| s * g))
    }

    /// Packs both networks' weights for the chunks of one batched pass.
    pub(crate) fn pack_into(&self, pack: &mut FieldPack<T>) {
        self.sdf_mlp
            .pack_into(self.params.get(Group::SdfMlp), 0..0, &mut pack.sdf);
        self.color_mlp.pack_into(
            self.params.get(Group::ColorMlp),
            self.code_columns(),
            &mut pack.color,
        );
    }

    /// First stage of a chunk's forward pass: maps the points into the unit cube.
    pub(crate) fn begin_chunk(&self, points: &[[T; 3]], outputs: Outputs, ws: &mut Workspace<T>) {
        let n = points.len();
        assert!(n <= CHUNK, "begin_chunk: {n} points exceed CHUNK");
        ws.n = n;
        ws.outputs = Some(outputs);
        for (u, x) in ws.u.iter_mut().zip(points) {
            *u = std::array::from_fn(|a| {
                ((x[a] - self.lo[a]) * self.inv_ext[a])
                    .max(T::ZERO)
                    .min(T::ONE)
            });
        }
    }

    /// Hash level `l` of a chunk (after [`NeusField::begin_chunk`]): the encoding columns of the SDF input
    /// and, when a gradient is wanted, the level's Jacobian. Batched passes run the levels outermost across
    /// several chunks so a level's table stays in cache.
    pub(crate) fn encode_level(&self, l: usize, ws: &mut Workspace<T>) {
        let n = ws.n;
        let block = n * self.config.hash.features * 3;
        let jac =
            (ws.outputs != Some(Outputs::Sdf)).then(|| &mut ws.jac[l * block..(l + 1) * block]);
        self.grid.forward_level(
            l,
            self.params.get(Group::Hash),
            &ws.u[..n],
            self.active_levels,
            &mut ws.enc,
            Strides::columns(CHUNK),
            jac,
        );
    }

    /// Last stage of a chunk's forward pass, after every level is encoded: the networks.
    pub(crate) fn finish_chunk(
        &self,
        pack: &FieldPack<T>,
        points: &[[T; 3]],
        dirs: &[[T; 3]],
        codes: &CodeSet,
        ws: &mut Workspace<T>,
    ) {
        let n = ws.n;
        let outputs = ws.outputs.expect("begin_chunk ran");
        let si = self.sdf_in_dim();
        let enc = self.config.hash.output_dim();
        let od = self.config.object_dim();
        let objects = self.params.get(Group::Object);
        transpose(&ws.enc, CHUNK, &mut ws.sdf_in, si, enc, n);
        for (p, u) in ws.u[..n].iter().enumerate() {
            let row = &mut ws.sdf_in[p * si + enc..(p + 1) * si];
            for a in 0..3 {
                row[a] = T::from_f64(2.0) * u[a] - T::ONE;
            }
            if od > 0 {
                let c = codes.object.get(p);
                row[3..].copy_from_slice(&objects[c * od..(c + 1) * od]);
            }
        }
        self.sdf_mlp
            .forward(&pack.sdf, &ws.sdf_in, n, &mut ws.sdf_ws);
        let (out, os) = ws.sdf_ws.output();
        for (p, x) in points.iter().enumerate() {
            let (b, gb) = self.base(x);
            ws.sdf[p] = out[p * os] + b;
            ws.base_grad[p] = gb;
        }
        if outputs != Outputs::Sdf {
            self.sdf_gradient(pack, ws);
        }
        if outputs == Outputs::Full {
            self.color_forward(pack, dirs, codes, ws);
        }
    }

    /// `∂SDF/∂x` through the network (input gradient only) and the hash grid's Jacobian.
    fn sdf_gradient(&self, pack: &FieldPack<T>, ws: &mut Workspace<T>) {
        let n = ws.n;
        let si = self.sdf_in_dim();
        self.sdf_mlp.output_input_gradient(
            &pack.sdf,
            (&ws.sdf_in, si),
            n,
            &mut ws.sdf_ws,
            0,
            (&mut ws.d_sdf_in, si),
        );
        self.split_encoding_grad(ws, si);
        let mut gradient = std::mem::take(&mut ws.gradient);
        self.position_grads(ws, &mut gradient);
        ws.gradient = gradient;
        for (g, b) in ws.gradient[..n].iter_mut().zip(&ws.base_grad) {
            *g = std::array::from_fn(|a| g[a] + b[a]);
        }
    }

    /// Copies the encoding's columns of the SDF input gradient (`ws.d_sdf_in`, row-major) into `ws.d_enc`
    /// (column-major), where [`NeusField::position_grads`] and the hash-table scatter read them. `stride`
    /// is the row stride `ws.d_sdf_in` was written with.
    fn split_encoding_grad(&self, ws: &mut Workspace<T>, stride: usize) {
        let enc = self.config.hash.output_dim();
        transpose(&ws.d_sdf_in, stride, &mut ws.d_enc, CHUNK, ws.n, enc);
    }

    /// `∂/∂x` of the network part for the `n` points of `ws`'s chunk, given the gradient of a loss with
    /// respect to the SDF network's input (`ws.d_sdf_in`, and its encoding part in `ws.d_enc`).
    fn position_grads(&self, ws: &mut Workspace<T>, out: &mut [[T; 3]]) {
        let (n, enc, si) = (ws.n, self.config.hash.output_dim(), self.sdf_in_dim());
        let acc = &mut ws.pos_acc;
        acc.fill(T::ZERO);
        for c in 0..enc {
            let dc = &ws.d_enc[c * CHUNK..c * CHUNK + n];
            for (a, acc_a) in acc.chunks_exact_mut(CHUNK).enumerate() {
                let j = &ws.jac[(c * 3 + a) * n..(c * 3 + a + 1) * n];
                for ((g, d), j) in acc_a[..n].iter_mut().zip(dc).zip(j) {
                    *g += *d * *j;
                }
            }
        }
        for (p, g) in out[..n].iter_mut().enumerate() {
            for a in 0..3 {
                let direct = T::from_f64(2.0) * ws.d_sdf_in[p * si + enc + a];
                g[a] = (acc[a * CHUNK + p] + direct) * self.inv_ext[a];
            }
        }
    }

    /// Colour network forward. Input row `[feature, appearance, light, SH(dir), normal]`; the codes enter
    /// through the first layer's pre-activation (see [`NeusField::code_columns`]), the rest row by row.
    pub(crate) fn color_forward(
        &self,
        pack: &FieldPack<T>,
        dirs: &[[T; 3]],
        codes: &CodeSet,
        ws: &mut Workspace<T>,
    ) {
        let n = ws.n;
        let g = self.config.geometry_features;
        let ci = self.color_mlp.config().input - self.code_columns().len();
        let so = 1 + g;
        let (feat, fs) = ws.sdf_ws.output();
        for p in 0..n {
            let row = &mut ws.color_in[p * ci..(p + 1) * ci];
            row[..g].copy_from_slice(&feat[p * fs + 1..p * fs + so]);
            sh4(dirs[p], &mut row[g..g + SH_DIM]);
            let nv = ws.gradient[p];
            let len = (nv[0] * nv[0] + nv[1] * nv[1] + nv[2] * nv[2])
                .sqrt()
                .max(T::from_f64(1e-12));
            for a in 0..3 {
                row[g + SH_DIM + a] = nv[a] / len;
            }
        }
        self.code_pre_activation(codes, ws);
        self.color_mlp
            .forward_split(&pack.color, &ws.color_in, ci, n, &mut ws.color_ws);
        let (rgb, rs) = ws.color_ws.output();
        for (p, dst) in ws.rgb[..n * 3].chunks_exact_mut(3).enumerate() {
            dst.copy_from_slice(&rgb[p * rs..p * rs + 3]);
        }
    }

    /// Writes each point's colour first-layer start: bias + appearance code · W_a + light code · W_l,
    /// recomputed only where the pair of codes changes from the previous point.
    fn code_pre_activation(&self, codes: &CodeSet, ws: &mut Workspace<T>) {
        let (w, o) = self.color_first_layer();
        let (cols, cd) = (self.code_columns(), self.config.code_dim);
        let (app, light) = (
            self.params.get(Group::Appearance),
            self.params.get(Group::Light),
        );
        let term = &mut ws.code_sum;
        let (pre, ps) = ws.color_ws.first_layer_mut();
        let mut last = None;
        for p in 0..ws.n {
            let key = (codes.appearance.get(p), codes.light.get(p));
            if last != Some(key) {
                let (a, l) = key;
                term.copy_from_slice(&w[w.len() - o..]);
                let rows = w[cols.start * o..cols.end * o].chunks_exact(o);
                let code = app[a * cd..(a + 1) * cd]
                    .iter()
                    .chain(&light[l * cd..(l + 1) * cd]);
                for (c, row) in code.zip(rows) {
                    for (t, wv) in term.iter_mut().zip(row) {
                        *t += *c * *wv;
                    }
                }
                last = Some(key);
            }
            pre[p * ps..p * ps + o].copy_from_slice(term);
        }
    }

    /// The colour network's first-layer weights (`[input][o]`, bias row after the last) and width `o`.
    fn color_first_layer(&self) -> (&[T], usize) {
        let c = self.color_mlp.config();
        let o = c.hidden.first().copied().unwrap_or(c.output);
        (&self.params.get(Group::ColorMlp)[..(c.input + 1) * o], o)
    }

    /// Gradients of the appearance and light codes and of their first-layer weight rows, from the first
    /// layer's pre-activation gradient: summed over each run of points with the same code, then multiplied
    /// by the weights once per run.
    fn code_backward(&self, codes: &CodeSet, ws: &mut Workspace<T>, grads: &mut Params<T>) {
        let (w, o) = self.color_first_layer();
        let (cols, cd) = (self.code_columns(), self.config.code_dim);
        let (delta, ds) = ws.color_ws.first_layer_delta();
        let sum = &mut ws.code_sum;
        for (which, group) in [(0, Group::Appearance), (1, Group::Light)] {
            let rows = cols.start + which * cd;
            let of = |p: usize| match which {
                0 => codes.appearance.get(p),
                _ => codes.light.get(p),
            };
            let mut p = 0;
            while p < ws.n {
                let c = of(p);
                sum.fill(T::ZERO);
                while p < ws.n && of(p) == c {
                    add(sum, &delta[p * ds..p * ds + o]);
                    p += 1;
                }
                let code = &self.params.get(group)[c * cd..(c + 1) * cd];
                for (r, cv) in code.iter().enumerate() {
                    let wr = (rows + r) * o;
                    let gw = &mut grads.get_mut(Group::ColorMlp)[wr..wr + o];
                    let mut dot = T::ZERO;
                    for ((g, s), wv) in gw.iter_mut().zip(sum.iter()).zip(&w[wr..wr + o]) {
                        *g += *cv * *s;
                        dot += *wv * *s;
                    }
                    grads.get_mut(group)[c * cd + r] += dot;
                }
            }
        }
    }

    /// Backward pass of the chunk last run through the forward stages (with the same `pack`). `d_sdf` (`n`) and `d_rgb`
    /// (`n × 3`, only after [`Outputs::Full`]) are the loss gradients. Adds the gradients of every group
    /// except the hash tables to `grads` (which may have an empty hash group); the hash tables' gradient is
    /// left in the workspace for [`NeusField::scatter_hash_grads`]. With `d_points`, writes `∂loss/∂x`
    /// (requires a forward pass with a gradient; the path through the normal is excluded by design).
    #[allow(clippy::too_many_arguments)] // the pass's weights, codes, saved chunk, both loss gradients and outputs
    pub(crate) fn backward_chunk(
        &self,
        pack: &FieldPack<T>,
        codes: &CodeSet,
        ws: &mut Workspace<T>,
        d_sdf: &[T],
        d_rgb: Option<&[T]>,
        grads: &mut Params<T>,
        d_points: Option<&mut [[T; 3]]>,
    ) {
        let n = ws.n;
        let g = self.config.geometry_features;
        let (si, so) = (self.sdf_in_dim(), 1 + g);
        ws.d_out[..n * so].fill(T::ZERO);
        for (p, d) in d_sdf[..n].iter().enumerate() {
            ws.d_out[p * so] = *d;
        }
        if let Some(d_rgb) = d_rgb {
            assert_eq!(
                ws.outputs,
                Some(Outputs::Full),
                "backward_chunk: d_rgb needs a Full forward pass"
            );
            let ci = self.color_mlp.config().input - self.code_columns().len();
            let gc = Some(&mut grads.groups[Group::ColorMlp as usize][..]);
            self.color_mlp.backward_split(
                &pack.color,
                (&ws.color_in, ci),
                n,
                &mut ws.color_ws,
                (d_rgb, 3),
                gc,
                Some((&mut ws.d_color_in, g)),
            );
            for p in 0..n {
                ws.d_out[p * so + 1..(p + 1) * so]
                    .copy_from_slice(&ws.d_color_in[p * g..(p + 1) * g]);
            }
            self.code_backward(codes, ws, grads);
        }
        let gs = Some(&mut grads.groups[Group::SdfMlp as usize][..]);
        let (enc, od) = (self.config.hash.output_dim(), self.config.object_dim());
        // The position columns' gradient is needed only for `d_points`: without it (and without object
        // codes) the input gradient stops at the encoding, a whole 16-lane column block less.
        let cols = if d_points.is_some() || od > 0 {
            si
        } else {
            enc
        };
        self.sdf_mlp.backward(
            &pack.sdf,
            &ws.sdf_in,
            n,
            &mut ws.sdf_ws,
            &ws.d_out,
            gs,
            Some((&mut ws.d_sdf_in, cols)),
        );
        self.split_encoding_grad(ws, cols);
        if od > 0 {
            for p in 0..n {
                let c = codes.object.get(p);
                let src = &ws.d_sdf_in[p * si + enc + 3..(p + 1) * si];
                add(&mut grads.get_mut(Group::Object)[c * od..(c + 1) * od], src);
            }
        }
        if let Some(d_points) = d_points {
            assert!(
                matches!(ws.outputs, Some(o) if o != Outputs::Sdf),
                "backward_chunk: d_points needs a gradient"
            );
            self.position_grads(ws, d_points);
            for ((dp, gb), d) in d_points[..n].iter_mut().zip(&ws.base_grad).zip(d_sdf) {
                *dp = std::array::from_fn(|a| dp[a] + *d * gb[a]);
            }
        }
    }

    /// Adds the hash-table gradient left by [`NeusField::backward_chunk`] in `workspaces` to the hash
    /// group of `grads`, one rayon task per level.
    pub(crate) fn scatter_hash_grads(&self, workspaces: &[Workspace<T>], grads: &mut Params<T>) {
        let segments: Vec<(&[[T; 3]], &[T])> = workspaces
            .iter()
            .map(|w| (&w.u[..w.n], &w.d_enc[..]))
            .collect();
        self.grid.backward_table(
            &segments,
            Strides::columns(CHUNK),
            self.active_levels,
            grads.get_mut(Group::Hash),
        );
    }
}

/// Copies the `rows × cols` matrix held row-major in `src` (row stride `src_rs`) into `dst` as its
/// transpose (row stride `dst_rs`): `dst[c · dst_rs + r] = src[r · src_rs + c]`.
fn transpose<T: Real>(
    src: &[T],
    src_rs: usize,
    dst: &mut [T],
    dst_rs: usize,
    rows: usize,
    cols: usize,
) {
    for r in 0..rows {
        for c in 0..cols {
            dst[c * dst_rs + r] = src[r * src_rs + c];
        }
    }
}

fn add<T: Real>(dst: &mut [T], src: &[T]) {
    for (d, s) in dst.iter_mut().zip(src) {
        *d += *s;
    }
}

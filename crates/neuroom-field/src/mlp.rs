//! Tiny fully connected networks, batch-major, forward and backward by hand.
//!
//! Parameters of a layer: weights `W` as `[in][out]` row-major, then bias `[out]`, so a batch
//! `Y = act(X · W + b)` reads rows of `X` and `W` contiguously.
//!
//! Products go through [`crate::kernel::matmul`], a register-blocked kernel written for these shapes
//! (a few hundred rows, widths of 3 to 66): a general BLAS spends more time packing and dispatching than
//! multiplying here. Activations and deltas are stored with rows padded to [`crate::kernel::LANES`] values so that every
//! right-hand operand can be read in whole vectors; the weights are copied into the same padded shape
//! (and transposed, for the input gradient) once per call.

use crate::kernel::{Init, Precision, matmul, padded};
use crate::real::Real;
use crate::rng::SplitMix;
use serde::{Deserialize, Serialize};
use std::ops::Range;

/// Pointwise non-linearity after a layer.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Activation {
    /// Identity.
    None,
    /// `max(x, 0)`.
    Relu,
    /// `ln(1 + e^{βx}) / β`: smooth, for SDF nets that need smooth normals.
    Softplus {
        /// Sharpness β.
        beta: f32,
    },
    /// Logistic sigmoid, for colours in `[0, 1]`.
    Sigmoid,
}

impl Activation {
    #[inline(always)]
    fn apply<T: Real>(self, x: T) -> T {
        match self {
            Activation::None => x,
            Activation::Relu => x.max(T::ZERO),
            Activation::Softplus { beta } => {
                let b = T::from_f64(beta as f64);
                let z = b * x;
                (z.max(T::ZERO) + (T::ONE + (-(z.max(-z))).exp()).ln()) / b
            }
            Activation::Sigmoid => x.sigmoid(),
        }
    }

    /// `y ← act(y)` on the first `width` values of every `stride`-long row; the match is outside the loops
    /// so that each activation's loop vectorises.
    fn apply_rows<T: Real>(self, y: &mut [T], stride: usize, width: usize) {
        let rows = y.chunks_exact_mut(stride).map(|r| &mut r[..width]);
        match self {
            Activation::None => {}
            Activation::Relu => rows.flatten().for_each(|v| *v = v.max(T::ZERO)),
            _ => rows.flatten().for_each(|v| *v = self.apply(*v)),
        }
    }

    /// `d ← d · act'(x)` on the first `width` values of every `stride`-long row, with `act'` expressed
    /// through the saved outputs `y` (same layout as `d`).
    fn scale_by_derivative<T: Real>(self, d: &mut [T], y: &[T], stride: usize, width: usize) {
        let rows = d.chunks_exact_mut(stride).zip(y.chunks_exact(stride));
        match self {
            Activation::None => {}
            Activation::Relu => {
                for (dr, yr) in rows {
                    for (dv, yv) in dr[..width].iter_mut().zip(&yr[..width]) {
                        // An unconditional store, so the loop becomes a vector select.
                        *dv = if *yv > T::ZERO { *dv } else { T::ZERO };
                    }
                }
            }
            _ => {
                for (dr, yr) in rows {
                    for (dv, yv) in dr[..width].iter_mut().zip(&yr[..width]) {
                        *dv *= self.derivative(*yv);
                    }
                }
            }
        }
    }

    /// Derivative expressed through the output `y = act(x)`.
    #[inline(always)]
    fn derivative<T: Real>(self, y: T) -> T {
        match self {
            Activation::None => T::ONE,
            Activation::Relu => {
                if y > T::ZERO {
                    T::ONE
                } else {
                    T::ZERO
                }
            }
            Activation::Softplus { beta } => T::ONE - (-(T::from_f64(beta as f64) * y)).exp(),
            Activation::Sigmoid => y * (T::ONE - y),
        }
    }
}

/// Widths and activations of a network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MlpConfig {
    /// Input width.
    pub input: usize,
    /// Hidden layer widths.
    pub hidden: Vec<usize>,
    /// Output width.
    pub output: usize,
    /// Activation after every hidden layer.
    pub hidden_activation: Activation,
    /// Activation after the output layer.
    pub output_activation: Activation,
    /// Arithmetic of the products in `f32` (`f64` networks ignore it).
    #[serde(default, skip_serializing_if = "Precision::is_f32")]
    pub precision: Precision,
}

/// A network's layout: widths, activations and parameter offsets. Parameters live outside.
#[derive(Clone, Debug)]
pub struct Mlp {
    config: MlpConfig,
    dims: Vec<usize>,
    offsets: Vec<usize>,
    num_params: usize,
}

/// Reusable buffers of one chunk: the output of every layer and two gradient buffers. Rows of activations
/// and deltas are padded (see the module documentation).
#[derive(Clone, Debug, Default)]
pub struct MlpWorkspace<T> {
    acts: Vec<Vec<T>>,
    widths: Vec<usize>,
    delta: Vec<T>,
    delta_prev: Vec<T>,
}

/// A network's weights copied into the padded layouts the products read, made once per batched pass and
/// read by every chunk: per layer, `[in][padded(out)]` with the bias row last (the first layer without its
/// `shared` input rows, see [`Mlp::forward_split`]), and the transpose `[out][padded(in)]` for input
/// gradients.
#[derive(Clone, Debug, Default)]
pub struct MlpPack<T> {
    forward: Vec<Vec<T>>,
    transposed: Vec<Vec<T>>,
    shared: Range<usize>,
}

impl<T: Real> MlpWorkspace<T> {
    /// The network output of the last forward pass and its row stride: value `j` of row `p` is at
    /// `p · stride + j`.
    pub fn output(&self) -> (&[T], usize) {
        let last = self.acts.len() - 1;
        (&self.acts[last], padded(self.widths[last]))
    }

    /// The first layer's pre-activation rows and their stride, for a caller of [`Mlp::forward_split`] to
    /// fill before the call.
    pub fn first_layer_mut(&mut self) -> (&mut [T], usize) {
        (&mut self.acts[0], padded(self.widths[0]))
    }

    /// After [`Mlp::backward_split`]: the loss gradient of the first layer's pre-activation and its row
    /// stride (what the rows left out of the input need for their own gradients).
    pub fn first_layer_delta(&self) -> (&[T], usize) {
        (&self.delta, padded(self.widths[0]))
    }
}

impl Mlp {
    /// The layout of a configuration.
    pub fn new(config: MlpConfig) -> Self {
        let mut dims = vec![config.input];
        dims.extend(&config.hidden);
        dims.push(config.output);
        let mut offsets = Vec::with_capacity(dims.len());
        let mut off = 0;
        for w in dims.windows(2) {
            offsets.push(off);
            off += w[0] * w[1] + w[1];
        }
        Self {
            config,
            dims,
            offsets,
            num_params: off,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &MlpConfig {
        &self.config
    }

    /// Number of parameters.
    pub fn num_params(&self) -> usize {
        self.num_params
    }

    /// Multiply–adds per point of one forward pass.
    pub fn macs(&self) -> usize {
        self.dims.windows(2).map(|w| w[0] * w[1]).sum()
    }

    fn layers(&self) -> usize {
        self.dims.len() - 1
    }

    fn activation(&self, layer: usize) -> Activation {
        if layer + 1 == self.layers() {
            self.config.output_activation
        } else {
            self.config.hidden_activation
        }
    }

    /// He-uniform weights (`±√(6/fan_in)`), zero biases; the output layer's weights are scaled by
    /// `output_scale` (small values start the network near its bias).
    pub fn init<T: Real>(&self, params: &mut [T], rng: &mut SplitMix, output_scale: f64) {
        for l in 0..self.layers() {
            let (i, o) = (self.dims[l], self.dims[l + 1]);
            let scale = (6.0 / i as f64).sqrt()
                * if l + 1 == self.layers() {
                    output_scale
                } else {
                    1.0
                };
            let off = self.offsets[l];
            for w in &mut params[off..off + i * o] {
                *w = T::from_f64(scale * (2.0 * rng.next_f64() - 1.0));
            }
            params[off + i * o..off + i * o + o].fill(T::ZERO);
        }
    }

    /// Allocates a workspace for up to `rows` points.
    pub fn workspace<T: Real>(&self, rows: usize) -> MlpWorkspace<T> {
        let max = padded(*self.dims.iter().max().unwrap_or(&0));
        MlpWorkspace {
            acts: self.dims[1..]
                .iter()
                .map(|d| vec![T::ZERO; rows * padded(*d)])
                .collect(),
            widths: self.dims[1..].to_vec(),
            delta: vec![T::ZERO; rows * max],
            delta_prev: vec![T::ZERO; rows * max],
        }
    }

    /// Packs `params` for the passes of a batch; the first layer's input columns `shared` are left out
    /// (see [`Mlp::forward_split`]; `0..0` for none). Reuses `pack`'s buffers.
    pub fn pack_into<T: Real>(&self, params: &[T], shared: Range<usize>, pack: &mut MlpPack<T>) {
        let layers = self.layers();
        pack.forward.resize_with(layers, Vec::new);
        pack.transposed.resize_with(layers, Vec::new);
        for l in 0..layers {
            let (i, o) = (self.dims[l], self.dims[l + 1]);
            let w = &params[self.offsets[l]..self.offsets[l] + i * o + o];
            let skip = if l == 0 { shared.clone() } else { 0..0 };
            let fwd = &mut pack.forward[l];
            fwd.resize((i - skip.len() + 1) * padded(o), T::ZERO);
            pack_weights(w, i, o, skip, fwd);
            let tr = &mut pack.transposed[l];
            tr.resize(o * padded(i), T::ZERO);
            pack_transposed(w, i, o, i, tr);
        }
        pack.shared = shared;
    }

    /// [`Mlp::pack_into`] into a new pack.
    pub fn pack<T: Real>(&self, params: &[T], shared: Range<usize>) -> MlpPack<T> {
        let mut pack = MlpPack::default();
        self.pack_into(params, shared, &mut pack);
        pack
    }

    /// Forward pass of `n` rows of `input` (`n × input`, contiguous); read the result with
    /// [`MlpWorkspace::output`].
    pub fn forward<T: Real>(
        &self,
        pack: &MlpPack<T>,
        input: &[T],
        n: usize,
        ws: &mut MlpWorkspace<T>,
    ) {
        self.forward_split(pack, input, self.config.input, n, ws);
    }

    /// Forward pass of `n` rows of `input`, rows `stride` values apart. With a pack made with `shared`
    /// input columns, those columns are left out of `input` (whose rows then hold the other columns, in
    /// order): the caller has already written, in [`MlpWorkspace::first_layer_mut`], each row's bias plus
    /// the contribution of its `shared` columns. Inputs that repeat across many rows (per-frame codes) are
    /// cheaper that way: their product is computed once per distinct value.
    pub fn forward_split<T: Real>(
        &self,
        pack: &MlpPack<T>,
        input: &[T],
        stride: usize,
        n: usize,
        ws: &mut MlpWorkspace<T>,
    ) {
        for l in 0..self.layers() {
            let (mut i, o) = (self.dims[l], self.dims[l + 1]);
            let op = padded(o);
            let skip = if l == 0 { pack.shared.clone() } else { 0..0 };
            i -= skip.len();
            let (w, b) = pack.forward[l].split_at(i * op);
            let init = if skip.is_empty() {
                Init::Bias(&b[..op])
            } else {
                Init::Accumulate
            };
            let (before, after) = ws.acts.split_at_mut(l);
            let (x, xs) = if l == 0 {
                (input, stride)
            } else {
                (&before[l - 1][..], padded(i))
            };
            let y = &mut after[0][..n * op];
            matmul(self.config.precision, n, o, i, x, xs, 1, w, op, y, op, init);
            self.activation(l).apply_rows(y, op, o);
        }
    }

    /// Backward pass after [`Mlp::forward`]. `d_out` (`n × output`) is the loss gradient of the output.
    /// Adds parameter gradients into `grads` (layout of the parameters) when given. With `d_input = Some((buf, cols))`,
    /// writes the gradient of the first `cols` input columns into `buf` (`n × cols`): callers ask only for
    /// the columns that need it.
    #[allow(clippy::too_many_arguments)] // the stage's inputs, saved activations and both gradient outputs
    pub fn backward<T: Real>(
        &self,
        pack: &MlpPack<T>,
        input: &[T],
        n: usize,
        ws: &mut MlpWorkspace<T>,
        d_out: &[T],
        grads: Option<&mut [T]>,
        d_input: Option<(&mut [T], usize)>,
    ) {
        let (out, stride) = (self.config.output, self.config.input);
        self.backward_split(pack, (input, stride), n, ws, (d_out, out), grads, d_input);
    }

    /// Backward pass after [`Mlp::forward_split`] with the same pack, input and output-gradient rows given
    /// as `(values, row stride)`. With `shared` columns in the pack, the first layer's weight gradient is
    /// added for the other rows only, `d_input` may ask for columns before `shared` only, and
    /// [`MlpWorkspace::first_layer_delta`] then holds what the caller needs for the `shared` rows.
    #[allow(clippy::too_many_arguments)] // as `backward`
    pub fn backward_split<T: Real>(
        &self,
        pack: &MlpPack<T>,
        input: (&[T], usize),
        n: usize,
        ws: &mut MlpWorkspace<T>,
        d_out: (&[T], usize),
        grads: Option<&mut [T]>,
        d_input: Option<(&mut [T], usize)>,
    ) {
        let last = self.layers() - 1;
        let (out_w, dp) = (self.dims[last + 1], padded(self.dims[last + 1]));
        for (p, row) in ws.delta[..n * dp].chunks_exact_mut(dp).enumerate() {
            row[..out_w].copy_from_slice(&d_out.0[p * d_out.1..p * d_out.1 + out_w]);
        }
        let y = &ws.acts[last][..n * dp];
        self.activation(last)
            .scale_by_derivative(&mut ws.delta[..n * dp], y, dp, out_w);
        self.backward_layers(pack, input, n, ws, last + 1, grads, d_input);
    }

    /// The gradient of output `column` with respect to the first `d_input.1` input columns, written to
    /// `d_input.0` (`n × cols`), after [`Mlp::forward`]; no parameter gradient. What a field's normal
    /// needs: the output layer's product with a one-hot gradient is a copy of one weight column, so it is
    /// not multiplied out.
    pub fn output_input_gradient<T: Real>(
        &self,
        pack: &MlpPack<T>,
        input: (&[T], usize),
        n: usize,
        ws: &mut MlpWorkspace<T>,
        column: usize,
        d_input: (&mut [T], usize),
    ) {
        let last = self.layers() - 1;
        let (i, dp) = (self.dims[last], padded(self.dims[last + 1]));
        let ip = padded(i);
        let out_act = self.activation(last);
        let weights = &pack.transposed[last][column * ip..(column + 1) * ip];
        let y = &ws.acts[last];
        for (p, row) in ws.delta[..n * ip].chunks_exact_mut(ip).enumerate() {
            let scale = out_act.derivative(y[p * dp + column]);
            for (d, w) in row.iter_mut().zip(weights) {
                *d = scale * *w;
            }
        }
        if last == 0 {
            let (buf, cols) = d_input;
            for (p, row) in buf[..n * cols].chunks_exact_mut(cols).enumerate() {
                row.copy_from_slice(&ws.delta[p * ip..p * ip + cols]);
            }
            return;
        }
        let x = &ws.acts[last - 1][..n * ip];
        self.activation(last - 1)
            .scale_by_derivative(&mut ws.delta[..n * ip], x, ip, i);
        self.backward_layers(pack, input, n, ws, last, None, Some(d_input));
    }

    /// The backward pass through layers `layers − 1` down to 0, with `ws.delta` holding the loss gradient
    /// of layer `layers − 1`'s pre-activation.
    #[allow(clippy::too_many_arguments)] // as `backward`
    fn backward_layers<T: Real>(
        &self,
        pack: &MlpPack<T>,
        input: (&[T], usize),
        n: usize,
        ws: &mut MlpWorkspace<T>,
        layers: usize,
        mut grads: Option<&mut [T]>,
        mut d_input: Option<(&mut [T], usize)>,
    ) {
        let shared = &pack.shared;
        for l in (0..layers).rev() {
            let (i, o) = (self.dims[l], self.dims[l + 1]);
            let op = padded(o);
            let (x, xs) = if l == 0 {
                input
            } else {
                (&ws.acts[l - 1][..], padded(i))
            };
            let delta = &ws.delta[..n * op];
            if let Some(grads) = grads.as_deref_mut() {
                let (wo, bo) = (self.offsets[l], self.offsets[l] + i * o);
                let (gw, gb) = grads[wo..bo + o].split_at_mut(i * o);
                // dW += Xᵀ · Δ, for the weight rows before and after the shared ones.
                let skip = if l == 0 { shared.clone() } else { i..i };
                matmul(
                    self.config.precision,
                    skip.start,
                    o,
                    n,
                    x,
                    1,
                    xs,
                    delta,
                    op,
                    gw,
                    o,
                    Init::Accumulate,
                );
                let (after, gw_after) = (i - skip.end, &mut gw[skip.end * o..]);
                let x_after = &x[skip.start..];
                matmul(
                    self.config.precision,
                    after,
                    o,
                    n,
                    x_after,
                    1,
                    xs,
                    delta,
                    op,
                    gw_after,
                    o,
                    Init::Accumulate,
                );
                for row in delta.chunks_exact(op) {
                    for (b, d) in gb.iter_mut().zip(row) {
                        *b += *d;
                    }
                }
            }
            let ip = padded(i);
            let wt = &pack.transposed[l];
            if l > 0 {
                // Δ_prev = (Δ · Wᵀ) ⊙ act'(x)
                let dprev = &mut ws.delta_prev[..n * ip];
                matmul(
                    self.config.precision,
                    n,
                    i,
                    o,
                    delta,
                    op,
                    1,
                    wt,
                    ip,
                    dprev,
                    ip,
                    Init::Zero,
                );
                self.activation(l - 1)
                    .scale_by_derivative(dprev, &x[..n * ip], ip, i);
                std::mem::swap(&mut ws.delta, &mut ws.delta_prev);
            } else if let Some((buf, cols)) = d_input.take() {
                assert!(
                    shared.is_empty() || cols <= shared.start,
                    "backward_split: input gradient of shared columns"
                );
                matmul(
                    self.config.precision,
                    n,
                    cols,
                    o,
                    delta,
                    op,
                    1,
                    wt,
                    ip,
                    buf,
                    cols,
                    Init::Zero,
                );
            }
        }
    }
}

/// Copies a layer's `i × o` weights, except rows `skip`, and its bias (the `o` values after them) into
/// `dst` as rows of `padded(o)` values, zero-filled beyond `o`.
fn pack_weights<T: Real>(params: &[T], i: usize, o: usize, skip: Range<usize>, dst: &mut [T]) {
    let op = padded(o);
    let rows = (0..skip.start).chain(skip.end..=i);
    for (r, row) in rows.zip(dst.chunks_exact_mut(op)) {
        row[..o].copy_from_slice(&params[r * o..(r + 1) * o]);
        row[o..].fill(T::ZERO);
    }
}

/// Copies the first `cols` rows of the `i × o` weights `w`, transposed, into `dst` as `o` rows of
/// `padded(cols)` values, zero-filled beyond `cols`: the right-hand operand of `Δ · Wᵀ`.
fn pack_transposed<T: Real>(w: &[T], i: usize, o: usize, cols: usize, dst: &mut [T]) {
    debug_assert!(cols <= i);
    let cp = padded(cols);
    for (j, row) in dst[..o * cp].chunks_exact_mut(cp).enumerate() {
        for (c, v) in row[..cols].iter_mut().enumerate() {
            *v = w[c * o + j];
        }
        row[cols..].fill(T::ZERO);
    }
}

//! Tiny fully connected networks, batch-major, forward and backward by hand; products go through `gemm`.
//!
//! Parameters of a layer: weights `W` as `[in][out]` row-major, then bias `[out]`, so a batch
//! `Y = act(X · W + b)` reads rows of `X` and `W` contiguously.

use crate::real::Real;
use crate::rng::SplitMix;
use serde::{Deserialize, Serialize};

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
}

/// A network's layout: widths, activations and parameter offsets. Parameters live outside.
#[derive(Clone, Debug)]
pub struct Mlp {
    config: MlpConfig,
    dims: Vec<usize>,
    offsets: Vec<usize>,
    num_params: usize,
}

/// Reusable buffers of one chunk: the output of every layer and two gradient buffers.
#[derive(Clone, Debug, Default)]
pub struct MlpWorkspace<T> {
    /// `acts[i]`: output of layer `i` (after its activation), `n × width`. The last is the network output.
    pub acts: Vec<Vec<T>>,
    delta: Vec<T>,
    delta_prev: Vec<T>,
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
        let max = *self.dims.iter().max().unwrap_or(&0);
        MlpWorkspace {
            acts: self.dims[1..]
                .iter()
                .map(|d| vec![T::ZERO; rows * d])
                .collect(),
            delta: vec![T::ZERO; rows * max],
            delta_prev: vec![T::ZERO; rows * max],
        }
    }

    /// Forward pass of `n` rows of `input` (`n × input`, contiguous); outputs land in `ws.acts`.
    pub fn forward<T: Real>(&self, params: &[T], input: &[T], n: usize, ws: &mut MlpWorkspace<T>) {
        for l in 0..self.layers() {
            let (i, o) = (self.dims[l], self.dims[l + 1]);
            let (w, b) = self.weights(params, l);
            let (before, after) = ws.acts.split_at_mut(l);
            let x = if l == 0 {
                &input[..n * i]
            } else {
                &before[l - 1][..n * i]
            };
            let y = &mut after[0][..n * o];
            for row in y.chunks_exact_mut(o) {
                row.copy_from_slice(b);
            }
            matmul(n, o, i, y, o, true, x, i, 1, w, o, 1);
            let act = self.activation(l);
            if act != Activation::None {
                for v in y.iter_mut() {
                    *v = act.apply(*v);
                }
            }
        }
    }

    /// Backward pass after [`Mlp::forward`]. `d_out` (`n × output`) is the loss gradient of the output.
    /// Adds parameter gradients into `grads` (layout of the parameters) when given. With `d_input = Some((buf, cols))`,
    /// writes the gradient of the first `cols` input columns into `buf` (`n × cols`): callers ask only for
    /// the columns that need it.
    #[allow(clippy::too_many_arguments)] // the stage's inputs, saved activations and both gradient outputs
    pub fn backward<T: Real>(
        &self,
        params: &[T],
        input: &[T],
        n: usize,
        ws: &mut MlpWorkspace<T>,
        d_out: &[T],
        mut grads: Option<&mut [T]>,
        mut d_input: Option<(&mut [T], usize)>,
    ) {
        let last = self.layers() - 1;
        let out_w = self.dims[last + 1];
        let act = self.activation(last);
        for ((d, g), y) in ws.delta[..n * out_w]
            .iter_mut()
            .zip(&d_out[..n * out_w])
            .zip(&ws.acts[last])
        {
            *d = *g * act.derivative(*y);
        }
        for l in (0..=last).rev() {
            let (i, o) = (self.dims[l], self.dims[l + 1]);
            let x = if l == 0 {
                &input[..n * i]
            } else {
                &ws.acts[l - 1][..n * i]
            };
            let delta = &ws.delta[..n * o];
            let (wo, bo) = (self.offsets[l], self.offsets[l] + i * o);
            if let Some(grads) = grads.as_deref_mut() {
                let (gw, gb) = grads[wo..bo + o].split_at_mut(i * o);
                // dW += Xᵀ · Δ
                matmul(i, o, n, gw, o, true, x, 1, i, delta, o, 1);
                for row in delta.chunks_exact(o) {
                    for (b, d) in gb.iter_mut().zip(row) {
                        *b += *d;
                    }
                }
            }
            let w = &params[wo..bo];
            if l > 0 {
                // Δ_prev = (Δ · Wᵀ) ⊙ act'(x)
                let dp = &mut ws.delta_prev[..n * i];
                matmul(n, i, o, dp, i, false, delta, o, 1, w, 1, o);
                let act = self.activation(l - 1);
                for (d, y) in dp.iter_mut().zip(x) {
                    *d *= act.derivative(*y);
                }
                std::mem::swap(&mut ws.delta, &mut ws.delta_prev);
            } else if let Some((buf, cols)) = d_input.take() {
                matmul(
                    n,
                    cols,
                    o,
                    &mut buf[..n * cols],
                    cols,
                    false,
                    delta,
                    o,
                    1,
                    w,
                    1,
                    o,
                );
            }
        }
    }

    fn weights<'a, T>(&self, params: &'a [T], l: usize) -> (&'a [T], &'a [T]) {
        let (i, o) = (self.dims[l], self.dims[l + 1]);
        let off = self.offsets[l];
        (
            &params[off..off + i * o],
            &params[off + i * o..off + i * o + o],
        )
    }
}

/// `dst (m×n) [+]= lhs (m×k) · rhs (k×n)` with explicit row/column strides (`*_rs`, `*_cs`), via `gemm`.
/// `dst` is row-major with row stride `dst_rs`; `accumulate` keeps what `dst` holds.
#[allow(clippy::too_many_arguments)]
pub(crate) fn matmul<T: Real>(
    m: usize,
    n: usize,
    k: usize,
    dst: &mut [T],
    dst_rs: usize,
    accumulate: bool,
    lhs: &[T],
    lhs_rs: usize,
    lhs_cs: usize,
    rhs: &[T],
    rhs_rs: usize,
    rhs_cs: usize,
) {
    if m == 0 || n == 0 {
        return;
    }
    assert!(
        dst.len() >= (m - 1) * dst_rs + n,
        "matmul: destination too small"
    );
    assert!(
        k == 0 || lhs.len() > (m - 1) * lhs_rs + (k - 1) * lhs_cs,
        "matmul: lhs too small"
    );
    assert!(
        k == 0 || rhs.len() > (k - 1) * rhs_rs + (n - 1) * rhs_cs,
        "matmul: rhs too small"
    );
    // SAFETY: the asserts above keep every index gemm touches inside the three slices.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            dst_rs as isize,
            accumulate,
            lhs.as_ptr(),
            lhs_cs as isize,
            lhs_rs as isize,
            rhs.as_ptr(),
            rhs_cs as isize,
            rhs_rs as isize,
            T::ONE,
            T::ONE,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

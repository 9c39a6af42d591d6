//! NeuS volume rendering of one ray, forward and backward, written by hand.
//!
//! Opacity: the simple consecutive-sample form of NeuS. For `N` sorted samples `t_i` with SDF `f_i`, the
//! interval `[t_i, t_{i+1}]` has
//! `α_i = max((Φ_s(f_i) − Φ_s(f_{i+1})) / Φ_s(f_i), 0)`, `Φ_s(f) = σ(s·f)`, `s = inv_s` (the learnable
//! sharpness). It is evaluated in log space, `α_i = 1 − exp(log σ(s f_{i+1}) − log σ(s f_i))`, so it stays
//! finite deep inside a surface where both sigmoids underflow. The interval's colour and depth are the mean
//! of its two end samples (no half-interval bias toward either end).
//!
//! Compositing is separate from opacity ([`composite`]), over any list of intervals sorted by depth, so
//! several fields can later be composited by merging their intervals by `t`.
//! Outputs: `rgb = Σ w_i c_i`, `depth = Σ w_i t_i` and `opacity = Σ w_i`, with `w_i = T_i α_i`; colour and
//! depth are *not* normalised by the opacity (a caller adds `(1 − opacity) · background`, and divides the
//! depth by the opacity where it wants an expected depth).

use neuroom_field::Real;

/// What a ray renders to.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayOutput<T> {
    /// Accumulated colour.
    pub rgb: [T; 3],
    /// Accumulated depth (weighted sum of interval depths).
    pub depth: T,
    /// Accumulated weight (opacity).
    pub opacity: T,
}

/// `log σ(z) = −softplus(−z)`, stable for any `z`.
#[inline]
fn log_sigmoid<T: Real>(z: T) -> T {
    let a = if z > T::ZERO { z } else { -z };
    -((-z).max(T::ZERO) + (T::ONE + (-a).exp()).ln())
}

/// NeuS opacities of the `N − 1` intervals between consecutive samples (`alpha.len() == sdf.len() − 1`).
pub fn neus_alphas<T: Real>(sdf: &[T], inv_s: T, alpha: &mut [T]) {
    for (i, a) in alpha.iter_mut().enumerate() {
        let delta = log_sigmoid(inv_s * sdf[i + 1]) - log_sigmoid(inv_s * sdf[i]);
        *a = if delta < T::ZERO {
            T::ONE - delta.exp()
        } else {
            T::ZERO
        };
    }
}

/// Backward of [`neus_alphas`]: adds `∂loss/∂f` to `d_sdf` and returns `∂loss/∂inv_s`.
pub fn neus_alphas_backward<T: Real>(sdf: &[T], inv_s: T, d_alpha: &[T], d_sdf: &mut [T]) -> T {
    let mut d_s = T::ZERO;
    for (i, da) in d_alpha.iter().enumerate() {
        let (z0, z1) = (inv_s * sdf[i], inv_s * sdf[i + 1]);
        let delta = log_sigmoid(z1) - log_sigmoid(z0);
        if delta >= T::ZERO {
            continue;
        }
        // α = 1 − e^Δ, Δ = log σ(z1) − log σ(z0), d log σ(z)/dz = 1 − σ(z).
        let d_delta = -*da * delta.exp();
        let (g0, g1) = (T::ONE - z0.sigmoid(), T::ONE - z1.sigmoid());
        d_sdf[i] -= d_delta * inv_s * g0;
        d_sdf[i + 1] += d_delta * inv_s * g1;
        d_s += d_delta * (sdf[i + 1] * g1 - sdf[i] * g0);
    }
    d_s
}

/// Weights and transmittances of a composited ray, kept for its backward pass.
#[derive(Clone, Debug, Default)]
pub struct CompositeTape<T> {
    /// `w_i = T_i α_i`.
    pub weights: Vec<T>,
    /// `T_i = Π_{j<i} (1 − α_j)`.
    pub transmittance: Vec<T>,
}

/// Composites intervals sorted by depth: opacities `alpha`, colours `rgb` and depths `t` (one per interval).
/// Fills `tape` with the weights and transmittances.
pub fn composite<T: Real>(
    alpha: &[T],
    rgb: &[[T; 3]],
    t: &[T],
    tape: &mut CompositeTape<T>,
) -> RayOutput<T> {
    let mut out = RayOutput {
        rgb: [T::ZERO; 3],
        depth: T::ZERO,
        opacity: T::ZERO,
    };
    let mut trans = T::ONE;
    tape.weights.clear();
    tape.transmittance.clear();
    for i in 0..alpha.len() {
        let w = trans * alpha[i];
        tape.transmittance.push(trans);
        tape.weights.push(w);
        for (o, c) in out.rgb.iter_mut().zip(rgb[i]) {
            *o += w * c;
        }
        out.depth += w * t[i];
        out.opacity += w;
        trans *= T::ONE - alpha[i];
    }
    out
}

/// Backward of [`composite`]: writes `∂loss/∂α` into `d_alpha` and adds `∂loss/∂c` to `d_rgb`, given the
/// gradient `d_out` of the outputs. Runs back to front with the suffix `R_i = g_i α_i + (1 − α_i) R_{i+1}`
/// (`g_i = ∂loss/∂w_i`), so `∂loss/∂α_i = T_i (g_i − R_{i+1})` needs no division by `1 − α`.
pub fn composite_backward<T: Real>(
    alpha: &[T],
    rgb: &[[T; 3]],
    t: &[T],
    tape: &CompositeTape<T>,
    d_out: &RayOutput<T>,
    d_alpha: &mut [T],
    d_rgb: &mut [[T; 3]],
) {
    let mut suffix = T::ZERO;
    for i in (0..alpha.len()).rev() {
        let g = d_out.rgb[0] * rgb[i][0]
            + d_out.rgb[1] * rgb[i][1]
            + d_out.rgb[2] * rgb[i][2]
            + d_out.depth * t[i]
            + d_out.opacity;
        d_alpha[i] = tape.transmittance[i] * (g - suffix);
        suffix = g * alpha[i] + (T::ONE - alpha[i]) * suffix;
        for (d, o) in d_rgb[i].iter_mut().zip(d_out.rgb) {
            *d += tape.weights[i] * o;
        }
    }
}

/// Reusable per-ray buffers of [`render_ray`] (no allocation once grown).
#[derive(Clone, Debug, Default)]
pub struct RayTape<T> {
    /// Interval opacities.
    pub alpha: Vec<T>,
    /// Interval weights and transmittances.
    pub composite: CompositeTape<T>,
    mid_rgb: Vec<[T; 3]>,
    mid_t: Vec<T>,
    d_alpha: Vec<T>,
    d_mid_rgb: Vec<[T; 3]>,
}

/// Renders one ray of a single field from its samples: sorted `t`, SDF `sdf` and colour `rgb` per sample,
/// sharpness `inv_s`. Fewer than two samples render nothing.
pub fn render_ray<T: Real>(
    t: &[T],
    sdf: &[T],
    rgb: &[[T; 3]],
    inv_s: T,
    tape: &mut RayTape<T>,
) -> RayOutput<T> {
    let m = t.len().saturating_sub(1);
    let half = T::from_f64(0.5);
    tape.alpha.resize(m, T::ZERO);
    tape.mid_rgb.clear();
    tape.mid_rgb
        .extend((0..m).map(|i| std::array::from_fn(|c| half * (rgb[i][c] + rgb[i + 1][c]))));
    tape.mid_t.clear();
    tape.mid_t.extend((0..m).map(|i| half * (t[i] + t[i + 1])));
    if m == 0 {
        return RayOutput::default();
    }
    neus_alphas(sdf, inv_s, &mut tape.alpha);
    composite(&tape.alpha, &tape.mid_rgb, &tape.mid_t, &mut tape.composite)
}

/// Backward of [`render_ray`]: adds `∂loss/∂f` to `d_sdf` and `∂loss/∂c` to `d_rgb` (one per sample) and
/// returns `∂loss/∂inv_s`.
pub fn render_ray_backward<T: Real>(
    sdf: &[T],
    inv_s: T,
    tape: &mut RayTape<T>,
    d_out: &RayOutput<T>,
    d_sdf: &mut [T],
    d_rgb: &mut [[T; 3]],
) -> T {
    let m = tape.alpha.len();
    if m == 0 {
        return T::ZERO;
    }
    tape.d_alpha.resize(m, T::ZERO);
    tape.d_mid_rgb.clear();
    tape.d_mid_rgb.resize(m, [T::ZERO; 3]);
    composite_backward(
        &tape.alpha,
        &tape.mid_rgb,
        &tape.mid_t,
        &tape.composite,
        d_out,
        &mut tape.d_alpha,
        &mut tape.d_mid_rgb,
    );
    let half = T::from_f64(0.5);
    for (i, d) in tape.d_mid_rgb.iter().enumerate() {
        for c in 0..3 {
            d_rgb[i][c] += half * d[c];
            d_rgb[i + 1][c] += half * d[c];
        }
    }
    neus_alphas_backward(sdf, inv_s, &tape.d_alpha, d_sdf)
}

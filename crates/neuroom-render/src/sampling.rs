//! Where to put samples along a ray: uniform, stratified, depth-guided (RGB-D captures), hierarchical
//! importance resampling from weights, and merging of sorted sample lists (several fields along one ray).
//!
//! Randomness comes from a caller's closure returning uniform numbers in `[0, 1)`, so any generator fits
//! and tests can pass a deterministic one.

/// `n` evenly spaced samples from `near` to `far`, both included (`n ≥ 2`).
pub fn uniform(near: f32, far: f32, n: usize, out: &mut Vec<f32>) {
    out.clear();
    let step = (far - near) / (n.max(2) - 1) as f32;
    out.extend((0..n).map(|k| near + k as f32 * step));
}

/// `n` stratified samples: one uniformly at random in each of `n` equal bins of `[near, far]`.
pub fn stratified(
    near: f32,
    far: f32,
    n: usize,
    rng: &mut impl FnMut() -> f32,
    out: &mut Vec<f32>,
) {
    out.clear();
    let step = (far - near) / n as f32;
    out.extend((0..n).map(|k| near + (k as f32 + rng()) * step));
}

/// Samples for a ray whose surface depth is known (RGB-D): `n_shell` stratified in
/// `[depth − half_width, depth + half_width]` and `n_uniform` stratified over `[near, far]` (both clipped
/// to `[near, far]`), merged in order.
#[allow(clippy::too_many_arguments)]
pub fn depth_guided(
    near: f32,
    far: f32,
    depth: f32,
    half_width: f32,
    n_shell: usize,
    n_uniform: usize,
    rng: &mut impl FnMut() -> f32,
    out: &mut Vec<f32>,
) {
    let mut shell = Vec::with_capacity(n_shell);
    if let Some((a, b)) = depth_guided_shell(near, far, depth, half_width) {
        stratified(a, b, n_shell, rng, &mut shell);
    }
    let mut coarse = Vec::with_capacity(n_uniform);
    stratified(near, far, n_uniform, rng, &mut coarse);
    merge_sorted(&shell, &coarse, out);
}

/// The shell `[depth − half_width, depth + half_width]` of [`depth_guided`] clipped to `[near, far]`,
/// or `None` when nothing of it is left: then [`depth_guided`] writes (and draws) its `n_uniform`
/// samples only, else `n_shell` more. So a caller knows how many numbers a ray draws before it draws
/// them, and can hand each ray its own place in one stream and sample the rays in parallel.
pub fn depth_guided_shell(near: f32, far: f32, depth: f32, half_width: f32) -> Option<(f32, f32)> {
    let (a, b) = (
        (depth - half_width).max(near),
        (depth + half_width).min(far),
    );
    (b > a).then_some((a, b))
}

/// Where SDF values taken at evenly spaced points along a ray first cross from outside (positive) to
/// inside (zero or negative).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Index of the last value outside.
    pub before: usize,
    /// Where the zero lies between that value and the next, in `(0, 1]` (linear interpolation).
    pub fraction: f32,
}

impl Crossing {
    /// The first crossing of `sdf`, or `None` when it never goes from outside to inside.
    pub fn first(sdf: &[f32]) -> Option<Self> {
        let j = sdf.windows(2).position(|w| w[0] > 0.0 && w[1] <= 0.0)?;
        Some(Self {
            before: j,
            fraction: sdf[j] / (sdf[j] - sdf[j + 1]),
        })
    }

    /// The crossing as a fractional index into the values.
    pub fn at(&self) -> f32 {
        self.before as f32 + self.fraction
    }
}

/// Hierarchical resampling: `n` new depths drawn from the piecewise-constant density whose interval
/// `[t_i, t_{i+1}]` has mass `weights[i] + 1e-5` (the small floor keeps empty rays sampled), by inverse CDF.
/// Returns them sorted in `out`; merge them with `t` via [`merge_sorted`].
pub fn importance(
    t: &[f32],
    weights: &[f32],
    n: usize,
    rng: &mut impl FnMut() -> f32,
    out: &mut Vec<f32>,
) {
    let mut cdf = Vec::with_capacity(weights.len() + 1);
    importance_with(t, weights, n, rng, &mut cdf, out);
}

/// [`importance`] with a caller's buffer for the CDF, so hot loops allocate nothing once it has grown.
pub fn importance_with(
    t: &[f32],
    weights: &[f32],
    n: usize,
    rng: &mut impl FnMut() -> f32,
    cdf: &mut Vec<f32>,
    out: &mut Vec<f32>,
) {
    out.clear();
    if t.len() < 2 {
        return;
    }
    cdf.clear();
    cdf.push(0.0f32);
    for w in weights {
        cdf.push(cdf.last().copied().unwrap_or(0.0) + w.max(0.0) + 1e-5);
    }
    let total = *cdf.last().expect("cdf has a first entry");
    // Stratified targets keep the new samples spread over the CDF and already sorted.
    let mut bin = 0;
    for k in 0..n {
        let u = (k as f32 + rng()) / n as f32 * total;
        while bin + 1 < weights.len() && cdf[bin + 1] < u {
            bin += 1;
        }
        let span = (cdf[bin + 1] - cdf[bin]).max(1e-12);
        let f = ((u - cdf[bin]) / span).clamp(0.0, 1.0);
        out.push(t[bin] + f * (t[bin + 1] - t[bin]));
    }
}

/// Merges two sorted lists into `out` (sorted).
pub fn merge_sorted(a: &[f32], b: &[f32], out: &mut Vec<f32>) {
    out.clear();
    out.reserve(a.len() + b.len());
    let (mut i, mut j) = (0, 0);
    while i < a.len() || j < b.len() {
        if j == b.len() || (i < a.len() && a[i] <= b[j]) {
            out.push(a[i]);
            i += 1;
        } else {
            out.push(b[j]);
            j += 1;
        }
    }
}

/// Merges the sorted sample lists of several fields along one ray into one order by `t`: each entry is
/// `(t, field, index within that field's list)`. Multi-object compositing walks this order.
pub fn merge_by_t(lists: &[&[f32]], out: &mut Vec<(f32, usize, usize)>) {
    out.clear();
    for (f, list) in lists.iter().enumerate() {
        out.extend(list.iter().enumerate().map(|(i, t)| (*t, f, i)));
    }
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first change from outside to inside, interpolated; a ray that starts inside or never
    /// enters has none.
    #[test]
    fn the_first_crossing_is_the_first_entry_from_outside() {
        let c = Crossing::first(&[0.3, 0.1, -0.1, 0.2, -0.4]).unwrap();
        assert_eq!(c.before, 1);
        assert!((c.at() - 1.5).abs() < 1e-6, "{c:?}");
        let touching = Crossing::first(&[0.2, 0.0, 0.1]).unwrap();
        assert_eq!((touching.before, touching.fraction), (0, 1.0));
        assert_eq!(Crossing::first(&[-0.1, -0.2, 0.3]), None);
        assert_eq!(Crossing::first(&[0.4, 0.2, 0.1]), None);
        assert_eq!(Crossing::first(&[0.4]), None);
    }

    /// `depth_guided` writes and draws `n_shell` more samples exactly when `depth_guided_shell` finds
    /// a shell, for shells inside, across and outside `[near, far]`.
    #[test]
    fn the_count_of_depth_guided_samples_is_known_before_drawing() {
        for (depth, half) in [(1.0, 0.1), (0.25, 0.1), (3.5, 0.2), (-1.0, 0.1), (1.0, 0.0)] {
            let mut draws = 0;
            let mut rng = || {
                draws += 1;
                0.5
            };
            let mut out = Vec::new();
            depth_guided(0.2, 3.0, depth, half, 8, 16, &mut rng, &mut out);
            let count = 16 + depth_guided_shell(0.2, 3.0, depth, half).map_or(0, |_| 8);
            assert_eq!(out.len(), count, "depth {depth}");
            assert_eq!(draws, count, "depth {depth}");
        }
        assert_eq!(depth_guided_shell(0.2, 3.0, -1.0, 0.1), None);
        assert!(depth_guided_shell(0.2, 3.0, 1.0, 0.1).is_some());
    }
}

//! Flat parameter groups of a neural field, shared by the field, its gradients, Adam and checkpoints.

use crate::real::Real;
use rayon::prelude::*;

/// The parameter groups of a [`crate::NeusField`], in storage order. Each group has its own learning rate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Group {
    /// Hash-grid tables.
    Hash = 0,
    /// SDF network weights and biases.
    SdfMlp = 1,
    /// Colour network weights and biases.
    ColorMlp = 2,
    /// Appearance codes `l_a`, one row per capture frame.
    Appearance = 3,
    /// Light codes `l_l`, one row per lighting.
    Light = 4,
    /// Object codes `l_obj`, one row per object held by the model.
    Object = 5,
    /// NeuS variance (one value; sharpness `inv_s = exp(10 · variance)`).
    Variance = 6,
}

/// Number of groups.
pub const NUM_GROUPS: usize = 7;

impl Group {
    /// All groups in storage order.
    pub const ALL: [Group; NUM_GROUPS] = [
        Group::Hash,
        Group::SdfMlp,
        Group::ColorMlp,
        Group::Appearance,
        Group::Light,
        Group::Object,
        Group::Variance,
    ];

    /// Stable name (safetensors key).
    pub fn name(self) -> &'static str {
        [
            "hash",
            "sdf_mlp",
            "color_mlp",
            "appearance",
            "light",
            "object",
            "variance",
        ][self as usize]
    }
}

/// One flat vector per [`Group`]: the parameters of a field, or their gradients, or Adam moments.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Params<T> {
    /// The groups, indexed by `Group as usize`.
    pub groups: [Vec<T>; NUM_GROUPS],
}

impl<T: Real> Params<T> {
    /// Zeros with the same shape as `other`.
    pub fn zeros_like(other: &Params<T>) -> Self {
        Self {
            groups: std::array::from_fn(|g| vec![T::ZERO; other.groups[g].len()]),
        }
    }

    /// Zeros like `other` except the hash group, left empty: a per-thread gradient accumulator (hash
    /// gradients are scattered by whole levels instead).
    pub fn zeros_like_without_hash(other: &Params<T>) -> Self {
        let mut p = Self::zeros_like(other);
        p.groups[Group::Hash as usize] = Vec::new();
        p
    }

    /// A group.
    pub fn get(&self, g: Group) -> &[T] {
        &self.groups[g as usize]
    }

    /// A group, mutably.
    pub fn get_mut(&mut self, g: Group) -> &mut [T] {
        &mut self.groups[g as usize]
    }

    /// Whether every value is finite (no NaN or infinity): the optimisers check gradients with it before
    /// they step.
    pub fn all_finite(&self) -> bool {
        self.groups
            .iter()
            .all(|g| g.par_chunks(1 << 16).all(all_finite))
    }

    /// Sets every value to zero (in parallel; the hash group can hold millions).
    pub fn fill_zero(&mut self) {
        self.fill_zero_where(|_| true);
    }

    /// Sets every value of the groups `which` picks to zero, in parallel.
    pub fn fill_zero_where(&mut self, which: impl Fn(Group) -> bool) {
        for (g, values) in Group::ALL.into_iter().zip(&mut self.groups) {
            if which(g) {
                values.par_chunks_mut(1 << 16).for_each(|c| c.fill(T::ZERO));
            }
        }
    }

    /// Adds every one of `parts` group-wise, each value summing the parts in their order (the bits of
    /// adding one part after the other), in parallel over ranges of values; groups empty in a part are
    /// skipped for it.
    pub fn add_in_order(&mut self, parts: &[Params<T>]) {
        const RANGE: usize = 4096;
        for (g, values) in self.groups.iter_mut().enumerate() {
            if parts.iter().all(|p| p.groups[g].is_empty()) {
                continue;
            }
            values
                .par_chunks_mut(RANGE)
                .enumerate()
                .for_each(|(r, range)| {
                    for part in parts.iter().filter(|p| !p.groups[g].is_empty()) {
                        let src = &part.groups[g][r * RANGE..r * RANGE + range.len()];
                        for (x, y) in range.iter_mut().zip(src) {
                            *x += *y;
                        }
                    }
                });
        }
    }

    /// Total number of values.
    pub fn len(&self) -> usize {
        self.groups.iter().map(Vec::len).sum()
    }

    /// Whether every group is empty.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Whether every value of `values` is finite. `x · 0` is 0 for a finite `x` and NaN for an infinite
/// or NaN one, so the sums of those products are 0 exactly when every value is finite; summed in
/// independent lanes without an early exit, the loop vectorises, where a test per value would not.
fn all_finite<T: Real>(values: &[T]) -> bool {
    const LANES: usize = 16;
    let mut sums = [T::ZERO; LANES];
    let mut lanes = values.chunks_exact(LANES);
    for lane in &mut lanes {
        for (sum, &v) in sums.iter_mut().zip(lane) {
            *sum += v * T::ZERO;
        }
    }
    let rest = lanes
        .remainder()
        .iter()
        .fold(T::ZERO, |sum, &v| sum + v * T::ZERO);
    sums.iter().fold(rest, |total, &sum| total + sum) == T::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_that_is_not_finite_is_found_in_any_lane_and_in_the_remainder() {
        let finite: Vec<f32> = (0..37).map(|i| (i as f32 - 18.0) * 1e37).collect();
        assert!(all_finite(&finite));
        assert!(all_finite::<f32>(&[]));
        assert!(all_finite(&[f32::MAX, -f32::MAX, f32::MIN_POSITIVE / 4.0]));
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for at in [0, 5, 15, 16, 31, 32, 36] {
                let mut values = finite.clone();
                values[at] = bad;
                assert!(!all_finite(&values), "{bad} at {at}");
            }
        }
        let mut params = Params::<f64> {
            groups: Default::default(),
        };
        params.groups[Group::Light as usize] = vec![0.0, 1.0, f64::NAN];
        assert!(!params.all_finite());
        params.groups[Group::Light as usize][2] = 2.0;
        assert!(params.all_finite());
    }

    #[test]
    fn adding_parts_in_order_gives_the_bits_of_a_loop_of_adds() {
        let shape = |seed: u64| Params::<f32> {
            groups: std::array::from_fn(|g| {
                (0..(g * 3_000 + 7))
                    .map(|i| {
                        ((i as u64 * 2_654_435_761 + seed * 97 + g as u64) % 1_000) as f32 * 1e-3
                            - 0.37
                    })
                    .collect()
            }),
        };
        let mut parts: Vec<Params<f32>> = (1..6).map(shape).collect();
        parts[2].groups[Group::Hash as usize].clear();
        let mut looped = shape(0);
        let mut ordered = looped.clone();
        for part in &parts {
            for (a, b) in looped.groups.iter_mut().zip(&part.groups) {
                if !b.is_empty() {
                    for (x, y) in a.iter_mut().zip(b) {
                        *x += *y;
                    }
                }
            }
        }
        ordered.add_in_order(&parts);
        assert_eq!(looped, ordered);
    }
}

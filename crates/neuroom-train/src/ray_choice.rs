//! Which surface rays a step trains on: uniformly, or guided by where the model's colour error is
//! (as instant-ngp samples training pixels from an error map).
//!
//! The surface rays of a capture are stored frame by frame in pixel order, so a run of consecutive rays is
//! a strip of neighbouring pixels. The pool is cut into groups of [`GROUP_RAYS`] consecutive rays; each
//! group keeps the mean squared colour error of the rays it last gave a step. A guided draw picks a group
//! with probability proportional to that error and a ray uniformly inside it. A share of every batch stays
//! uniform so that no part of a capture is starved, and a group never drawn counts as [`UNSEEN_ERROR`], the
//! largest error a colour in `[0, 1]` can have, so every group is visited early in a run.
//!
//! Each drawn ray carries the weight `p_uniform / p_drawn`: with [`RayChoice::importance_weighted`] the
//! losses are scaled by it, so the expected gradient is the uniform one (importance sampling); without, the
//! hard rays simply count more often, as instant-ngp does.

use crate::rng::Pcg32;
use serde::{Deserialize, Serialize};

/// Consecutive rays of the pool that share one error estimate (a strip of a pixel row).
pub const GROUP_RAYS: usize = 32;

/// The error of a group no step has drawn from yet: the largest mean squared error of a colour in
/// `[0, 1]`.
pub const UNSEEN_ERROR: f32 = 1.0;

/// How a step chooses its surface rays.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RayChoice {
    /// Share of the surface rays drawn by their group's error (0: every ray uniformly).
    pub guided_share: f32,
    /// Whether each ray's losses are scaled by `p_uniform / p_drawn`.
    pub importance_weighted: bool,
}

impl Default for RayChoice {
    fn default() -> Self {
        Self {
            guided_share: 0.0,
            importance_weighted: false,
        }
    }
}

impl RayChoice {
    /// Whether every ray is drawn uniformly (then the choice is not serialised).
    pub fn is_uniform(&self) -> bool {
        self.guided_share <= 0.0
    }
}

/// One drawn ray: its index into the pool and the weight of its losses.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DrawnRay {
    /// Index into the pool of surface rays.
    pub index: usize,
    /// `p_uniform / p_drawn` when importance-weighted, else 1.
    pub weight: f32,
}

/// The per-group colour errors of a pool of rays and the draws they guide.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ErrorMap {
    /// Rays in the pool.
    rays: usize,
    /// Last observed mean squared colour error of each group.
    errors: Vec<f32>,
    /// Running sums of `errors` (rebuilt by [`ErrorMap::commit`]).
    #[serde(skip)]
    cumulative: Vec<f64>,
    /// `(group, squared colour error)` of every ray observed in the current step.
    #[serde(skip)]
    pending: Vec<(u32, f32)>,
}

impl ErrorMap {
    /// A map over a pool of `rays` rays, every group unseen.
    pub fn new(rays: usize) -> Self {
        let mut map = Self {
            rays,
            errors: vec![UNSEEN_ERROR; rays.div_ceil(GROUP_RAYS)],
            cumulative: Vec::new(),
            pending: Vec::new(),
        };
        map.rebuild();
        map
    }

    /// Rays in the pool the map covers.
    pub fn rays(&self) -> usize {
        self.rays
    }

    /// The map after deserialisation: rebuilds what is not stored.
    pub fn restored(mut self) -> Self {
        self.rebuild();
        self
    }

    /// Draws one ray of the pool: guided by the errors with probability `choice.guided_share`, else
    /// uniformly.
    pub fn draw(&self, choice: &RayChoice, rng: &mut Pcg32) -> DrawnRay {
        let n = self.rays as u32;
        let share = choice.guided_share.clamp(0.0, 1.0);
        // With no guided share the coin is not tossed, so uniform runs draw as they always did.
        let index = if share > 0.0 && rng.next_f32() < share {
            let group = self.group_at(rng.next_f32() as f64);
            let (start, end) = self.span(group);
            start + rng.below((end - start) as u32) as usize
        } else {
            rng.below(n) as usize
        };
        let weight = if choice.importance_weighted {
            let p_uniform = 1.0 / self.rays as f64;
            let p =
                (1.0 - share as f64) * p_uniform + share as f64 * self.guided_probability(index);
            (p_uniform / p) as f32
        } else {
            1.0
        };
        DrawnRay { index, weight }
    }

    /// Records the squared colour error a step saw on pool ray `index`.
    pub fn observe(&mut self, index: usize, error: f32) {
        self.pending.push(((index / GROUP_RAYS) as u32, error));
    }

    /// Ends a step: every group drawn in it takes the mean error its rays showed, and the draws of the
    /// next step follow.
    pub fn commit(&mut self) {
        if self.pending.is_empty() {
            return;
        }
        self.pending.sort_unstable_by_key(|&(g, _)| g);
        for run in self.pending.chunk_by(|a, b| a.0 == b.0) {
            let sum: f32 = run.iter().map(|&(_, e)| e).sum();
            self.errors[run[0].0 as usize] = sum / run.len() as f32;
        }
        self.pending.clear();
        self.rebuild();
    }

    /// Probability that a guided draw returns pool ray `index`.
    fn guided_probability(&self, index: usize) -> f64 {
        let group = index / GROUP_RAYS;
        let (start, end) = self.span(group);
        let total = self.cumulative.last().copied().unwrap_or(0.0);
        if total <= 0.0 {
            return 1.0 / self.rays as f64;
        }
        self.errors[group] as f64 / total / (end - start) as f64
    }

    /// The group whose share of the running sum holds `u ∈ [0, 1)`.
    fn group_at(&self, u: f64) -> usize {
        let total = self.cumulative.last().copied().unwrap_or(0.0);
        if total <= 0.0 {
            return ((u * self.errors.len() as f64) as usize).min(self.errors.len() - 1);
        }
        let target = u * total;
        self.cumulative
            .partition_point(|&c| c <= target)
            .min(self.errors.len() - 1)
    }

    /// Pool indices `start..end` of `group`.
    fn span(&self, group: usize) -> (usize, usize) {
        let start = group * GROUP_RAYS;
        (start, (start + GROUP_RAYS).min(self.rays))
    }

    fn rebuild(&mut self) {
        self.cumulative.clear();
        let mut sum = 0.0f64;
        for &e in &self.errors {
            sum += e.max(0.0) as f64;
            self.cumulative.push(sum);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn guided(weighted: bool) -> RayChoice {
        RayChoice {
            guided_share: 1.0,
            importance_weighted: weighted,
        }
    }

    #[test]
    fn guided_draws_follow_the_observed_errors() {
        let mut map = ErrorMap::new(4 * GROUP_RAYS);
        for (g, e) in [0.1f32, 0.0, 0.3, 0.0].iter().enumerate() {
            map.observe(g * GROUP_RAYS, *e);
        }
        map.commit();
        let mut rng = Pcg32::new(7, 1);
        let mut counts = [0usize; 4];
        for _ in 0..20_000 {
            counts[map.draw(&guided(false), &mut rng).index / GROUP_RAYS] += 1;
        }
        assert_eq!(counts[1] + counts[3], 0, "{counts:?}");
        let ratio = counts[2] as f64 / counts[0] as f64;
        assert!((ratio - 3.0).abs() < 0.2, "{counts:?}");
    }

    #[test]
    fn unseen_groups_are_drawn_first() {
        let mut map = ErrorMap::new(3 * GROUP_RAYS);
        map.observe(0, 0.01);
        map.commit();
        let mut rng = Pcg32::new(3, 1);
        let first_group = (0..1000)
            .filter(|_| map.draw(&guided(false), &mut rng).index < GROUP_RAYS)
            .count();
        // Group 0 holds 0.01 of the 2.01 total.
        assert!(first_group < 20, "{first_group}");
    }

    #[test]
    fn importance_weights_keep_the_uniform_expectation() {
        // E[w · f(ray)] under the guided draw must equal the uniform mean of f.
        let mut map = ErrorMap::new(5 * GROUP_RAYS + 7);
        for (g, e) in [0.5f32, 0.05, 0.2, 0.01, 0.3, 0.9].iter().enumerate() {
            map.observe(g * GROUP_RAYS, *e);
        }
        map.commit();
        let f = |i: usize| (i % 11) as f64 + 1.0;
        let uniform: f64 = (0..map.rays()).map(f).sum::<f64>() / map.rays() as f64;
        let choice = RayChoice {
            guided_share: 0.7,
            importance_weighted: true,
        };
        let mut rng = Pcg32::new(11, 2);
        let n = 400_000;
        let estimate: f64 = (0..n)
            .map(|_| {
                let d = map.draw(&choice, &mut rng);
                d.weight as f64 * f(d.index)
            })
            .sum::<f64>()
            / n as f64;
        assert!(
            (estimate - uniform).abs() < 0.02 * uniform,
            "{estimate} vs {uniform}"
        );
    }

    #[test]
    fn a_stored_map_draws_as_the_original() {
        let mut map = ErrorMap::new(10 * GROUP_RAYS);
        for g in 0..10 {
            map.observe(g * GROUP_RAYS + 3, 0.01 * (g as f32 + 1.0));
        }
        map.commit();
        let json = serde_json::to_string(&map).unwrap();
        let back: ErrorMap = serde_json::from_str::<ErrorMap>(&json).unwrap().restored();
        let (mut a, mut b) = (Pcg32::new(5, 5), Pcg32::new(5, 5));
        for _ in 0..100 {
            assert_eq!(
                map.draw(&guided(true), &mut a),
                back.draw(&guided(true), &mut b)
            );
        }
    }
}

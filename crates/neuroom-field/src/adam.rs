//! Adam over the flat parameter groups of a field, with one learning rate per group, and learning-rate
//! schedules.

use crate::params::{NUM_GROUPS, Params};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Adam hyper-parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct AdamConfig {
    /// First-moment decay.
    pub beta1: f32,
    /// Second-moment decay.
    pub beta2: f32,
    /// Denominator guard.
    pub eps: f32,
}

impl Default for AdamConfig {
    /// instant-ngp's choice: β = (0.9, 0.99), ε = 1e-15.
    fn default() -> Self {
        Self {
            beta1: 0.9,
            beta2: 0.99,
            eps: 1e-15,
        }
    }
}

/// Adam state: moments of every parameter and the step count (checkpointed to resume exactly).
#[derive(Clone, Debug, PartialEq)]
pub struct Adam {
    /// Hyper-parameters.
    pub config: AdamConfig,
    /// First moments (shape of the parameters).
    pub m: Params<f32>,
    /// Second moments.
    pub v: Params<f32>,
    /// Steps taken.
    pub step: u64,
}

impl Adam {
    /// Zero state for parameters shaped like `params`.
    pub fn new(config: AdamConfig, params: &Params<f32>) -> Self {
        Self {
            config,
            m: Params::zeros_like(params),
            v: Params::zeros_like(params),
            step: 0,
        }
    }

    /// One step: `params -= lr_g · m̂ / (√v̂ + ε)` with bias-corrected moments, group `g` at rate `lr[g]`.
    /// A group with rate 0 is left untouched (frozen), moments and gradients included. The step
    /// consumes the gradients of the groups it moves: it leaves them zero, cleared in the same pass
    /// that reads them (the table of a room's model is too large to pass over twice for free).
    pub fn step(
        &mut self,
        params: &mut Params<f32>,
        grads: &mut Params<f32>,
        lr: &[f32; NUM_GROUPS],
    ) {
        self.step += 1;
        let update = AdamUpdate::at(self.config, self.step);
        for (g, &rate) in lr.iter().enumerate() {
            if rate == 0.0 {
                continue;
            }
            params.groups[g]
                .par_chunks_mut(1 << 14)
                .zip(grads.groups[g].par_chunks_mut(1 << 14))
                .zip(self.m.groups[g].par_chunks_mut(1 << 14))
                .zip(self.v.groups[g].par_chunks_mut(1 << 14))
                .for_each(|(((p, gr), m), v)| {
                    update.apply(rate, p, gr, m, v);
                    gr.fill(0.0);
                });
        }
    }
}

/// One Adam step's update rule: the hyper-parameters with the bias corrections of step `t`. Shared by
/// [`Adam`] and the small parameter sets optimised beside a field (per-frame corrections).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdamUpdate {
    config: AdamConfig,
    /// `1 / (1 − β₁ᵗ)`.
    c1: f32,
    /// `1 / (1 − β₂ᵗ)`.
    c2: f32,
}

impl AdamUpdate {
    /// The update of step `step` (1-based: the first step is 1).
    pub fn at(config: AdamConfig, step: u64) -> Self {
        let t = step.min(i32::MAX as u64) as i32;
        Self {
            config,
            c1: 1.0 / (1.0 - config.beta1.powi(t)),
            c2: 1.0 / (1.0 - config.beta2.powi(t)),
        }
    }

    /// Updates the moments `m`, `v` with the gradient `grads` and moves `params` at rate `rate`.
    pub fn apply(
        &self,
        rate: f32,
        params: &mut [f32],
        grads: &[f32],
        m: &mut [f32],
        v: &mut [f32],
    ) {
        let AdamConfig { beta1, beta2, eps } = self.config;
        for i in 0..params.len() {
            m[i] = beta1 * m[i] + (1.0 - beta1) * grads[i];
            v[i] = beta2 * v[i] + (1.0 - beta2) * grads[i] * grads[i];
            params[i] -= rate * (m[i] * self.c1) / ((v[i] * self.c2).sqrt() + eps);
        }
    }
}

/// A learning-rate schedule: a multiplier of the base rate as a function of the step, with linear warm-up.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Schedule {
    /// Always 1 (after warm-up).
    Constant {
        /// Warm-up steps.
        warmup: u64,
    },
    /// `gamma^(step / every)`.
    Exponential {
        /// Warm-up steps.
        warmup: u64,
        /// Factor per `every` steps.
        gamma: f32,
        /// Steps per factor.
        every: u64,
    },
    /// `(1 − step/total)^power` down to `floor` (the paper's polynomial decay).
    Polynomial {
        /// Warm-up steps.
        warmup: u64,
        /// Steps of the whole run.
        total: u64,
        /// Exponent.
        power: f32,
        /// Smallest multiplier.
        floor: f32,
    },
}

impl Schedule {
    /// Multiplier of the base learning rate at `step` (0-based).
    pub fn factor(&self, step: u64) -> f32 {
        let (warmup, decay) = match *self {
            Schedule::Constant { warmup } => (warmup, 1.0),
            Schedule::Exponential {
                warmup,
                gamma,
                every,
            } => (warmup, gamma.powf(step as f32 / every.max(1) as f32)),
            Schedule::Polynomial {
                warmup,
                total,
                power,
                floor,
            } => {
                let x = 1.0 - (step as f32 / total.max(1) as f32).min(1.0);
                (warmup, x.powf(power).max(floor))
            }
        };
        let ramp = if step < warmup {
            (step + 1) as f32 / warmup as f32
        } else {
            1.0
        };
        ramp * decay
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::Group;

    /// A step moves every group at its rate by the update rule and leaves its gradients zero, and
    /// leaves a frozen group as it was, gradients included.
    #[test]
    fn a_step_applies_the_update_rule_and_clears_the_gradients() {
        let mut params = Params::<f32>::default();
        params.groups[Group::Hash as usize] = (0..40_000).map(|i| (i % 7) as f32 * 0.1).collect();
        params.groups[Group::Light as usize] = vec![0.5, -0.5];
        let mut grads = Params::zeros_like(&params);
        grads.groups[Group::Hash as usize] = (0..40_000).map(|i| (i % 5) as f32 - 2.0).collect();
        grads.groups[Group::Light as usize] = vec![1.0, 2.0];
        let mut lr = [0.0; NUM_GROUPS];
        lr[Group::Hash as usize] = 0.01;

        let mut expected = params.groups[Group::Hash as usize].clone();
        let hash_grads = grads.groups[Group::Hash as usize].clone();
        let (mut m, mut v) = (vec![0.0; 40_000], vec![0.0; 40_000]);
        AdamUpdate::at(AdamConfig::default(), 1).apply(
            0.01,
            &mut expected,
            &hash_grads,
            &mut m,
            &mut v,
        );

        let mut adam = Adam::new(AdamConfig::default(), &params);
        adam.step(&mut params, &mut grads, &lr);
        assert_eq!(params.groups[Group::Hash as usize], expected);
        assert_eq!(adam.m.groups[Group::Hash as usize], m);
        assert_eq!(params.groups[Group::Light as usize], vec![0.5, -0.5]);
        assert!(
            adam.m.groups[Group::Light as usize]
                .iter()
                .all(|&x| x == 0.0)
        );
        assert!(grads.groups[Group::Hash as usize].iter().all(|&g| g == 0.0));
        assert_eq!(grads.groups[Group::Light as usize], vec![1.0, 2.0]);
    }
}

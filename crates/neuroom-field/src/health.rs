//! Optimisation health: the guard the trainer and the fit share against non-finite and exploding steps.

use serde::{Deserialize, Serialize};

/// The health of an optimisation: steps whose loss or gradient was not finite, or whose loss exploded, are
/// not applied (the parameters stay at the last good state) and the learning rate is halved. Too many
/// faults in a row stop the run.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Health {
    /// Faulty steps skipped over the whole run.
    pub faults: u64,
    /// Faulty steps in a row, up to the last step.
    pub in_a_row: u64,
    /// Multiplier of the learning rates (1, halved at every fault).
    pub lr_scale: f32,
    /// Running mean of the total loss of good steps (0 before the first).
    pub loss_mean: f32,
}

impl Default for Health {
    fn default() -> Self {
        Self {
            faults: 0,
            in_a_row: 0,
            lr_scale: 1.0,
            loss_mean: 0.0,
        }
    }
}

/// A step whose loss is this many times the running mean counts as exploding.
pub const EXPLODING_LOSS: f32 = 20.0;
/// Faulty steps in a row after which a run stops.
pub const MAX_FAULTS_IN_A_ROW: u64 = 20;

impl Health {
    /// Whether a step with loss `total` and gradients `grads_finite` may be applied; records a fault if not.
    pub fn admit(&mut self, total: f32, grads_finite: bool) -> bool {
        let exploding = self.loss_mean > 0.0 && total > EXPLODING_LOSS * self.loss_mean;
        if total.is_finite() && grads_finite && !exploding {
            self.in_a_row = 0;
            self.loss_mean = if self.loss_mean > 0.0 {
                0.95 * self.loss_mean + 0.05 * total
            } else {
                total
            };
            return true;
        }
        self.faults += 1;
        self.in_a_row += 1;
        self.lr_scale *= 0.5;
        false
    }

    /// Whether a step whose values are all `finite` may be applied, for losses without a stable running
    /// mean (the fit's relations change its loss in jumps); records a fault if not.
    pub fn admit_finite(&mut self, finite: bool) -> bool {
        self.admit(if finite { 0.0 } else { f32::NAN }, finite)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn health_skips_non_finite_and_exploding_steps_and_halves_the_rate() {
        let mut h = Health::default();
        assert!(h.admit(1.0, true));
        assert!(!h.admit(f32::NAN, true));
        assert!(!h.admit(1.0, false));
        assert!(!h.admit(100.0, true), "20× the running mean explodes");
        assert_eq!((h.faults, h.in_a_row), (3, 3));
        assert_eq!(h.lr_scale, 0.125);
        assert!(h.admit(1.2, true));
        assert_eq!((h.faults, h.in_a_row), (3, 0));
        assert!((h.loss_mean - 1.01).abs() < 1e-6, "{}", h.loss_mean);
        assert!(!h.admit_finite(false));
        assert_eq!(h.in_a_row, 1);
        assert!(h.admit_finite(true));
    }
}

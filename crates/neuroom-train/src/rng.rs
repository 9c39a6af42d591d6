//! The trainer's random number generator: PCG-XSH-RR 64/32 with a public, serialisable state, so a
//! checkpoint stores it and a resumed run draws exactly the numbers an uninterrupted run would.

use serde::{Deserialize, Serialize};

/// PCG32 (O'Neill 2014): 64-bit LCG state, 32-bit output by xorshift and random rotation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Pcg32 {
    /// LCG state.
    pub state: u64,
    /// Stream increment (odd).
    pub inc: u64,
}

const MULTIPLIER: u64 = 6_364_136_223_846_793_005;

impl Pcg32 {
    /// A generator from a seed and a stream number (independent sequences for the same seed).
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut rng = Self {
            state: 0,
            inc: (stream << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(seed);
        rng.next_u32();
        rng
    }

    /// Next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULTIPLIER).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        xorshifted.rotate_right((old >> 59) as u32)
    }

    /// Uniform in `[0, 1)` with 24 bits of resolution.
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// A standard normal draw (Box–Muller on two uniform draws).
    pub fn next_normal(&mut self) -> f32 {
        let (u, v) = (self.next_f32().max(1e-7), self.next_f32());
        (-2.0 * u.ln()).sqrt() * (std::f32::consts::TAU * v).cos()
    }

    /// Uniform integer in `0..n` (`n > 0`), by Lemire's multiply-shift (bias below 2⁻³² · n).
    pub fn below(&mut self, n: u32) -> u32 {
        ((self.next_u32() as u64 * n as u64) >> 32) as u32
    }

    /// A generator for a sub-task: seeded from this one's next output and `stream` (rayon tasks get their
    /// own streams so results do not depend on scheduling).
    pub fn fork(&mut self, stream: u64) -> Self {
        let seed = ((self.next_u32() as u64) << 32) | self.next_u32() as u64;
        Self::new(seed, stream)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reproducible_and_uniform() {
        let mut a = Pcg32::new(42, 7);
        let mut b = Pcg32::new(42, 7);
        let xs: Vec<f32> = (0..10_000).map(|_| a.next_f32()).collect();
        assert!(xs.iter().all(|x| (0.0..1.0).contains(x)));
        assert!(
            xs.iter()
                .zip((0..).map(|_| b.next_f32()))
                .all(|(x, y)| *x == y)
        );
        let mean = xs.iter().sum::<f32>() / xs.len() as f32;
        assert!((mean - 0.5).abs() < 0.01, "{mean}");
        let mut c = Pcg32::new(42, 8);
        assert_ne!(Pcg32::new(42, 7).next_u32(), c.next_u32());
    }
}

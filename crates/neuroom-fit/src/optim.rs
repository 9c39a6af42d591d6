//! Adam over a flat vector of scalars with one learning rate per entry: the poses and tone adjusters of
//! the fit (a few numbers per object), where the field's grouped Adam would be overkill.

/// Adam state over `n` scalars (β = 0.9, 0.999; ε = 1e-8).
#[derive(Clone, Debug, Default)]
pub struct ScalarAdam {
    m: Vec<f32>,
    v: Vec<f32>,
    step: i32,
}

impl ScalarAdam {
    /// Zero state for `n` scalars.
    pub fn new(n: usize) -> Self {
        Self {
            m: vec![0.0; n],
            v: vec![0.0; n],
            step: 0,
        }
    }

    /// One step: `params[i] -= factor · lr[i] · m̂ᵢ / (√v̂ᵢ + ε)`.
    pub fn step(&mut self, params: &mut [f32], grads: &[f32], lr: &[f32], factor: f32) {
        const B1: f32 = 0.9;
        const B2: f32 = 0.999;
        self.step += 1;
        let (c1, c2) = (
            1.0 / (1.0 - B1.powi(self.step)),
            1.0 / (1.0 - B2.powi(self.step)),
        );
        for i in 0..params.len() {
            let g = grads[i];
            self.m[i] = B1 * self.m[i] + (1.0 - B1) * g;
            self.v[i] = B2 * self.v[i] + (1.0 - B2) * g * g;
            params[i] -= factor * lr[i] * self.m[i] * c1 / ((self.v[i] * c2).sqrt() + 1e-8);
        }
    }
}

//! What the second stage of the fit changes inside the models: their light and appearance code rows.
//! Analytic fields have none; a trained NeuS field exposes its parameters.

use neuroom_field::{AnalyticField, Field, Group, NeusField, Params};

/// A field the fit can render and whose code rows it may adapt.
pub trait FitField: Field {
    /// A zero gradient shaped like the field's parameters (empty for fields without parameters).
    fn zero_grads(&self) -> Params<f32>;

    /// The parameters holding the code rows, if the field has any.
    fn params_mut(&mut self) -> Option<&mut Params<f32>>;

    /// The light code at `row` (empty when the field has none).
    fn light_code(&self, row: u32) -> Vec<f32>;
}

impl FitField for NeusField<f32> {
    fn zero_grads(&self) -> Params<f32> {
        Params::zeros_like(&self.params)
    }

    fn params_mut(&mut self) -> Option<&mut Params<f32>> {
        Some(&mut self.params)
    }

    fn light_code(&self, row: u32) -> Vec<f32> {
        let d = self.config().code_dim;
        let start = row as usize * d;
        self.params
            .get(Group::Light)
            .get(start..start + d)
            .map_or_else(Vec::new, <[f32]>::to_vec)
    }
}

impl FitField for AnalyticField {
    fn zero_grads(&self) -> Params<f32> {
        Params::default()
    }

    fn params_mut(&mut self) -> Option<&mut Params<f32>> {
        None
    }

    fn light_code(&self, _row: u32) -> Vec<f32> {
        Vec::new()
    }
}

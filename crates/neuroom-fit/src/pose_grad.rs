//! Pose gradients in matrix form, accumulated by the geometric losses and turned into 6D gradients once
//! per iteration.
//!
//! A point `p` of object `i` sits at `x = Rᵢ p + Tᵢ` in the world; a world point `x` seen by object `j`
//! sits at `y = Rⱼᵀ (x − Tⱼ)` in its frame. With `g = ∂loss/∂x` or `∂loss/∂y`, the pose gradients are
//! `∂/∂Tᵢ = g`, `∂/∂Rᵢ = g pᵀ` and `∂/∂Tⱼ = −Rⱼ g`, `∂/∂Rⱼ = (x − Tⱼ) gᵀ`.

use glam::{Mat3, Vec3};
use neuroom_core::rotation6d::rotation_from_6d_backward_f32;
use neuroom_render::SceneObject;

/// `∂loss/∂translation` and `∂loss/∂R` (the rotation matrix) of one object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseGrad {
    /// `∂loss/∂T`.
    pub translation: Vec3,
    /// `∂loss/∂R`, same column layout as `R`.
    pub rotation: Mat3,
}

impl Default for PoseGrad {
    fn default() -> Self {
        Self::ZERO
    }
}

/// `a bᵀ`.
#[inline]
fn outer(a: Vec3, b: Vec3) -> Mat3 {
    Mat3::from_cols(a * b.x, a * b.y, a * b.z)
}

impl PoseGrad {
    /// No gradient.
    pub const ZERO: PoseGrad = PoseGrad {
        translation: Vec3::ZERO,
        rotation: Mat3::ZERO,
    };

    /// Adds the gradient of a posed point `x = R p + T` given `g = ∂loss/∂x`.
    #[inline]
    pub fn add_posed_point(&mut self, p: Vec3, g: Vec3) {
        self.translation += g;
        self.rotation += outer(g, p);
    }

    /// Adds the gradient of a world point seen in this object's frame, `y = Rᵀ (x − T)`, given
    /// `g = ∂loss/∂y` and `x − T`; returns `∂loss/∂x = R g`.
    #[inline]
    pub fn add_observed_point(&mut self, rotation: Mat3, x_minus_t: Vec3, g: Vec3) -> Vec3 {
        let g_world = rotation * g;
        self.translation -= g_world;
        self.rotation += outer(x_minus_t, g);
        g_world
    }

    /// Scales both parts.
    pub fn scaled(self, s: f32) -> PoseGrad {
        PoseGrad {
            translation: self.translation * s,
            rotation: self.rotation * s,
        }
    }

    /// Adds `other`.
    pub fn add(&mut self, other: &PoseGrad) {
        self.translation += other.translation;
        self.rotation += other.rotation;
    }

    /// The gradient with respect to `object`'s 6D rotation.
    pub fn rotation6d(&self, object: &SceneObject) -> [f32; 6] {
        rotation_from_6d_backward_f32(object.rotation6d, self.rotation)
    }
}

/// Zeroes every gradient of `grads`, resized to `n` objects.
pub fn reset(grads: &mut Vec<PoseGrad>, n: usize) {
    grads.clear();
    grads.resize(n, PoseGrad::ZERO);
}

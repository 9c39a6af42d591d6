//! Gravity loss: an upright object (a bed, a table) keeps its z axis along world z,
//! `L = Σ_upright (1 − R₃ · ẑ) = Σ (1 − R[2][2])`.

use crate::pose_grad::PoseGrad;
use neuroom_render::SceneObject;

/// The loss over the objects flagged `upright`; adds `weight · ∂L/∂R` into `grads`.
pub fn gravity_loss(
    objects: &[SceneObject],
    upright: &[bool],
    weight: f32,
    grads: &mut [PoseGrad],
) -> f32 {
    let mut loss = 0.0;
    for ((o, &up), g) in objects.iter().zip(upright).zip(grads) {
        if up {
            loss += 1.0 - o.rotation().z_axis.z;
            g.rotation.z_axis.z -= weight;
        }
    }
    weight * loss
}

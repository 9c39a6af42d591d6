//! Observation loss: each object keeps the direction it is seen in from the camera. The initial poses
//! come from detections in the panorama, whose directions are reliable while their depth is not, so the
//! fit may slide an object along its viewing ray but not across it:
//! `L = Σₖ (1 − uₖ · u⁰ₖ)`, `uₖ = (Tₖ − c) / |Tₖ − c|`.

use crate::pose_grad::PoseGrad;
use glam::Vec3;
use neuroom_render::SceneObject;

/// Unit direction from `camera` to each object's centre.
pub fn view_directions(objects: &[SceneObject], camera: Vec3) -> Vec<Vec3> {
    objects
        .iter()
        .map(|o| (o.translation - camera).normalize_or_zero())
        .collect()
}

/// The loss of `objects` against `initial` directions with tolerance `tolerance` (radians); adds
/// `weight · ∂L/∂T` into `grads`.
pub fn observation_loss(
    objects: &[SceneObject],
    camera: Vec3,
    initial: &[Vec3],
    tolerance: f32,
    weight: f32,
    grads: &mut [PoseGrad],
) -> f32 {
    let free = 1.0 - tolerance.cos();
    let mut loss = 0.0;
    for ((o, &u0), g) in objects.iter().zip(initial).zip(grads) {
        let d = o.translation - camera;
        let len = d.length();
        if len <= 1e-6 {
            continue;
        }
        let u = d / len;
        let c = u.dot(u0);
        if 1.0 - c <= free {
            continue;
        }
        loss += 1.0 - c - free;
        // ∂(1 − u·u0)/∂d = −(u0 − (u·u0) u) / |d|.
        g.translation -= weight * (u0 - c * u) / len;
    }
    weight * loss
}

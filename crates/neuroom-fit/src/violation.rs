//! Violation loss: surface points of each object must stay outside its neighbours and inside the room by
//! a margin ε, `L = Σᵢ Σ_{targets} (1/nᵢ) Σₖ max(ε − sdf(xₖ), 0)²`. Every neighbour whose bounding sphere
//! comes within ε of the object's is checked — the ones that can collide are exactly the ones that must
//! not be skipped (the paper's code skips them). The quadratic hinge keeps the push gentle near contact,
//! where the magnetic loss pulls the other way. A face that a relation joins to a target touches it by
//! design: its points get no margin against that target (penetration is still penalised), or the margin
//! would lift every object ε off the floor and fight the magnetic loss (measured: 2–3 cm APE on an object
//! standing on another).

use crate::pose_grad::PoseGrad;
use crate::probe::{Probe, Target};
use crate::relations::Relation;
use crate::surface::{Face, SurfacePoints};
use neuroom_field::Field;
use neuroom_render::Scene;

/// The targets object `i` is checked against: the room, then every object whose bounding sphere is
/// within `epsilon` of object `i`'s.
pub fn neighbours<F>(scene: &Scene<F>, i: usize, epsilon: f32) -> Vec<Target> {
    let o = &scene.objects[i];
    let mut targets = vec![Target::Room];
    targets.extend(
        scene
            .objects
            .iter()
            .enumerate()
            .filter(|&(j, t)| {
                j != i
                    && t.translation.distance(o.translation)
                        < t.half_extents.length() + o.half_extents.length() + epsilon
            })
            .map(|(j, _)| Target::Object(j)),
    );
    targets
}

/// The margin of a point on `face` of object `i` against `target`: 0 where a relation joins them.
fn margin(relations: &[Relation], i: usize, face: Face, target: Target, epsilon: f32) -> f32 {
    let joined = relations
        .iter()
        .any(|r| r.object == i && r.face == face && r.target == target);
    if joined { 0.0 } else { epsilon }
}

/// The loss over all objects (surface points `surfaces[i]` of object `i`, contact faces of `relations`
/// without margin); adds `weight · ∂L/∂pose` into `grads`.
#[allow(clippy::too_many_arguments)]
pub fn violation_loss<F: Field>(
    scene: &Scene<F>,
    surfaces: &[SurfacePoints],
    relations: &[Relation],
    epsilon: f32,
    weight: f32,
    probe: &mut Probe,
    d_sdf: &mut Vec<f32>,
    grads: &mut [PoseGrad],
) -> f32 {
    let mut loss = 0.0;
    for (i, surface) in surfaces.iter().enumerate() {
        if surface.points.is_empty() {
            continue;
        }
        let scale = 1.0 / surface.points.len() as f32;
        for target in neighbours(scene, i, epsilon) {
            probe.evaluate(scene, i, surface.points.iter().copied(), target);
            d_sdf.clear();
            d_sdf.extend(probe.sdf.iter().zip(&surface.faces).map(|(&s, &face)| {
                let h = (margin(relations, i, face, target, epsilon) - s).max(0.0);
                loss += scale * h * h;
                -2.0 * weight * scale * h
            }));
            probe.backward(scene, i, target, d_sdf, grads);
        }
    }
    weight * loss
}

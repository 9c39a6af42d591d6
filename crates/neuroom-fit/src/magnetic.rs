//! Magnetic loss: a relation joins a face of an object (its bottom, its back) to a target surface (the
//! room's floor or wall, another object's top). The face's surface points probe the target's SDF — the
//! distance a probing ray along the contact normal travels to the target — and the closest point is pulled
//! onto it when the two are apart and pushed out when they penetrate: `L = Σ_relations (min_k sdf(x_k))²`.

use crate::pose_grad::PoseGrad;
use crate::probe::Probe;
use crate::relations::Relation;
use crate::surface::SurfacePoints;
use neuroom_field::Field;
use neuroom_render::Scene;

/// The loss over `relations`; adds `weight · ∂L/∂pose` into `grads`.
pub fn magnetic_loss<F: Field>(
    scene: &Scene<F>,
    surfaces: &[SurfacePoints],
    relations: &[Relation],
    weight: f32,
    probe: &mut Probe,
    d_sdf: &mut Vec<f32>,
    grads: &mut [PoseGrad],
) -> f32 {
    let mut loss = 0.0;
    for rel in relations {
        let points = surfaces[rel.object].on(rel.face);
        probe.evaluate(scene, rel.object, points, rel.target);
        let Some((k, &gap)) = probe
            .sdf
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
        else {
            continue;
        };
        loss += gap * gap;
        d_sdf.clear();
        d_sdf.resize(probe.sdf.len(), 0.0);
        d_sdf[k] = 2.0 * weight * gap;
        probe.backward(scene, rel.object, rel.target, d_sdf, grads);
    }
    weight * loss
}

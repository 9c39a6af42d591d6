//! Magnetic loss: a relation joins a face of an object (its bottom, its back) to a target surface (the
//! room's floor or wall, another object's top). The face's surface points probe the target's SDF — the
//! distance a probing ray along the contact normal travels to the target — and the closest point is pulled
//! onto it when the two are apart and pushed out when they penetrate: `L = Σ_relations (min_k sdf(x_k))²`.
//! Against the room, only points whose nearest room surface is the relation's (the floor for a bottom,
//! a wall for a back) count, since the room's SDF reads whichever surface is nearest.
//!
//! Furniture "against a wall" stands a little off it (baseboards, skirting, a picture's hanger), so a back
//! joined to the room's wall is pulled only from beyond a tolerance `wall_gap`: within it the photometric
//! loss places the object, and penetration is still pushed out.

use crate::pose_grad::PoseGrad;
use crate::probe::{Probe, Target};
use crate::relations::{Relation, RoomBox};
use crate::surface::{Face, SurfacePoints};
use glam::Vec3;
use neuroom_field::Field;
use neuroom_render::Scene;

/// The loss over `relations` in `room` (backs on the room's walls free within `wall_gap` metres of
/// them); adds `weight · ∂L/∂pose` into `grads`.
#[allow(clippy::too_many_arguments)]
pub fn magnetic_loss<F: Field>(
    scene: &Scene<F>,
    room: &RoomBox,
    surfaces: &[SurfacePoints],
    relations: &[Relation],
    weight: f32,
    wall_gap: f32,
    probe: &mut Probe,
    d_sdf: &mut Vec<f32>,
    grads: &mut [PoseGrad],
) -> f32 {
    let mut loss = 0.0;
    for rel in relations {
        let points = surfaces[rel.object].on(rel.face);
        probe.evaluate(scene, rel.object, points, rel.target);
        let counts =
            |x: &Vec3| rel.target != Target::Room || room.nearest_is_contact_of(rel.face, *x);
        let Some((k, &gap)) = probe
            .sdf
            .iter()
            .enumerate()
            .filter(|(k, _)| counts(&probe.world()[*k]))
            .min_by(|a, b| a.1.total_cmp(b.1))
        else {
            continue;
        };
        let gap = if rel.face == Face::Back && rel.target == Target::Room && gap > 0.0 {
            (gap - wall_gap).max(0.0)
        } else {
            gap
        };
        if gap == 0.0 {
            continue;
        }
        loss += gap * gap;
        d_sdf.clear();
        d_sdf.resize(probe.sdf.len(), 0.0);
        d_sdf[k] = 2.0 * weight * gap;
        probe.backward(scene, rel.object, rel.target, d_sdf, grads);
    }
    weight * loss
}

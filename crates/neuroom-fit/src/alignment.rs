//! Wall alignment loss: a back joined to a wall lies flat against it. The magnetic loss pulls a back's
//! closest point onto its wall and leaves the object free to turn about that point, so a small object
//! whose front the photometric loss cannot tell from its sides (a cube-like nightstand) settles at
//! whatever heading its start had. Furniture stands square to the wall it is put against:
//! `L = Σ_{back–wall relations} (1 − b · n)`, with `b` the back's outward normal (−x) and `n` the outward
//! normal of the room wall it faces most.

use crate::pose_grad::PoseGrad;
use crate::probe::Target;
use crate::relations::Relation;
use crate::surface::Face;
use glam::Vec3;
use neuroom_render::SceneObject;

/// Outward normals of an axis-aligned room's four walls.
const WALL_NORMALS: [Vec3; 4] = [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y];

/// The loss over the back–room `relations` of `objects`; adds `weight · ∂L/∂R` into `grads`.
pub fn alignment_loss(
    objects: &[SceneObject],
    relations: &[Relation],
    weight: f32,
    grads: &mut [PoseGrad],
) -> f32 {
    let mut loss = 0.0;
    for rel in relations {
        if rel.face != Face::Back || rel.target != Target::Room {
            continue;
        }
        let x_axis = objects[rel.object].rotation().x_axis;
        let wall = WALL_NORMALS
            .into_iter()
            .max_by(|a, b| (-x_axis).dot(*a).total_cmp(&(-x_axis).dot(*b)))
            .expect("four walls");
        // 1 − b · n with b = −x: ∂/∂x_axis = n.
        loss += 1.0 + x_axis.dot(wall);
        grads[rel.object].rotation.x_axis += wall * weight;
    }
    weight * loss
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat3, DVec3};
    use neuroom_core::Pose;

    fn turned(yaw_deg: f64) -> SceneObject {
        let pose = Pose::new(
            DMat3::from_rotation_z(yaw_deg.to_radians()),
            DVec3::new(0.0, 0.0, 0.3),
        );
        SceneObject::new(1, 0, &pose, Vec3::splat(0.2))
    }

    #[test]
    fn a_square_back_costs_nothing_and_a_turned_one_is_turned_back() {
        let on_wall = [Relation {
            object: 0,
            face: Face::Back,
            target: Target::Room,
        }];
        for yaw in [0.0, 90.0, 180.0, -90.0] {
            let mut g = [PoseGrad::ZERO];
            let loss = alignment_loss(&[turned(yaw)], &on_wall, 1.0, &mut g);
            assert!(loss.abs() < 1e-6, "yaw {yaw}: {loss}");
        }
        // Turned 30° towards +y from facing −x: the cost is 1 − cos 30°, whichever wall is nearest.
        let mut g = [PoseGrad::ZERO];
        let loss = alignment_loss(&[turned(30.0)], &on_wall, 1.0, &mut g);
        assert!((loss - (1.0 - 30f32.to_radians().cos())).abs() < 1e-5);
        // A floor relation carries no alignment.
        let on_floor = [Relation {
            face: Face::Bottom,
            ..on_wall[0]
        }];
        assert_eq!(alignment_loss(&[turned(30.0)], &on_floor, 1.0, &mut g), 0.0);
    }
}

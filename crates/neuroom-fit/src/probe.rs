//! The shared geometric step of the physical losses: a target surface's SDF (the room's, or another
//! object's through its pose) evaluated at posed surface points of a source object, and the backward pass
//! that carries `∂loss/∂sdf` to both poses (see [`crate::pose_grad`]).

use crate::pose_grad::PoseGrad;
use glam::Vec3;
use neuroom_field::Field;
use neuroom_render::Scene;

/// Whose SDF a probe reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Target {
    /// The background (room) field, in world coordinates.
    Room,
    /// Object `k` of the scene, through its pose.
    Object(usize),
}

/// Buffers and results of one probe; reused across calls.
#[derive(Clone, Debug, Default)]
pub struct Probe {
    /// Source points in its own frame.
    local: Vec<Vec3>,
    /// Source points in the world.
    world: Vec<Vec3>,
    /// Points in the target's frame.
    query: Vec<Vec3>,
    /// Target SDF at each point.
    pub sdf: Vec<f32>,
    /// `∂sdf/∂(target-frame point)`.
    gradient: Vec<Vec3>,
}

impl Probe {
    /// Evaluates `target`'s SDF at `points` (frame of object `source`) placed by the source's pose.
    pub fn evaluate<F: Field>(
        &mut self,
        scene: &Scene<F>,
        source: usize,
        points: impl Iterator<Item = Vec3>,
        target: Target,
    ) {
        let o = &scene.objects[source];
        let r = o.rotation();
        self.local.clear();
        self.local.extend(points);
        self.world.clear();
        self.world
            .extend(self.local.iter().map(|&p| r * p + o.translation));
        self.query.clear();
        let field = match target {
            Target::Room => {
                self.query.extend_from_slice(&self.world);
                &scene.models[scene.background.model].field
            }
            Target::Object(j) => {
                let t = &scene.objects[j];
                let rt = t.rotation().transpose();
                self.query
                    .extend(self.world.iter().map(|&x| rt * (x - t.translation)));
                &scene.models[t.model].field
            }
        };
        let n = self.query.len();
        self.sdf.resize(n, 0.0);
        self.gradient.resize(n, Vec3::ZERO);
        field.sdf_gradient(&self.query, &mut self.sdf, &mut self.gradient);
    }

    /// The source points of the last [`Probe::evaluate`] in the world.
    pub fn world(&self) -> &[Vec3] {
        &self.world
    }

    /// Carries `d_sdf[k] = ∂loss/∂sdf[k]` of the last [`Probe::evaluate`] to the pose gradients of the
    /// source and (for an object target) the target.
    pub fn backward<F: Field>(
        &self,
        scene: &Scene<F>,
        source: usize,
        target: Target,
        d_sdf: &[f32],
        grads: &mut [PoseGrad],
    ) {
        let mut g_source = PoseGrad::ZERO;
        let mut g_target = PoseGrad::ZERO;
        let posed = match target {
            Target::Room => None,
            Target::Object(j) => Some(&scene.objects[j]),
        };
        let r_target = posed.map(|t| t.rotation());
        for (k, &d) in d_sdf.iter().enumerate().take(self.sdf.len()) {
            if d == 0.0 {
                continue;
            }
            let g = self.gradient[k] * d;
            let g_world = match (posed, r_target) {
                (Some(t), Some(r)) => {
                    g_target.add_observed_point(r, self.world[k] - t.translation, g)
                }
                _ => g,
            };
            g_source.add_posed_point(self.local[k], g_world);
        }
        grads[source].add(&g_source);
        if let Target::Object(j) = target {
            grads[j].add(&g_target);
        }
    }
}

//! A model as the object search and the training panoramas see it: its coloured surface clouds, its box
//! and where it may stand.

use glam::Vec3;
use neuroom_core::obb::OrientedBox;
use neuroom_core::pose::Pose;
use serde::{Deserialize, Serialize};

use crate::capture_shading::CaptureShading;
use crate::cloud::Cloud;

/// Where a model may stand.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Support {
    /// Upright on the floor.
    Floor,
    /// Upright with its back (−x face) against a wall.
    Wall,
    /// Upright on top of an instance of another model (index into the model list).
    On(usize),
}

/// One searchable model.
#[derive(Clone, Debug)]
pub struct ObjectModel {
    /// Instance ids (several for identical objects).
    pub ids: Vec<u16>,
    /// Half extents of its box (metres).
    pub half: Vec3,
    /// Coarse surface cloud, for the search.
    pub coarse: Cloud,
    /// Finer surface cloud, for refinement.
    pub fine: Cloud,
    /// Where it may stand.
    pub support: Support,
    /// Whether its back (−x face) stands against a wall: hypotheses are discounted by the back's
    /// distance from the room's surface.
    pub against_wall: bool,
}

impl ObjectModel {
    /// Its box at `pose`.
    pub fn box_at(&self, pose: &Pose) -> OrientedBox {
        OrientedBox::new(*pose, 2.0 * self.half.as_dvec3())
    }
}

/// `models` with the light they were captured under taken out of their clouds' colours: one
/// [`CaptureShading`] per capture light, fitted over the fine clouds of every model that
/// `lights[k]` (the name of model `k`'s capture light) says was captured under it.
pub fn without_capture_shading(models: Vec<ObjectModel>, lights: &[String]) -> Vec<ObjectModel> {
    let mut fitted: Vec<(&String, CaptureShading)> = Vec::new();
    for light in lights {
        if fitted.iter().all(|(l, _)| *l != light) {
            let group: Vec<&Cloud> = models
                .iter()
                .zip(lights)
                .filter(|(_, l)| *l == light)
                .map(|(m, _)| &m.fine)
                .collect();
            fitted.push((light, CaptureShading::fit_shared(&group)));
        }
    }
    let shading_of = |light: &String| fitted.iter().find(|(l, _)| *l == light).map(|(_, s)| *s);
    let shading: Vec<CaptureShading> = lights.iter().filter_map(shading_of).collect();
    models
        .into_iter()
        .zip(shading)
        .map(|(model, shading)| ObjectModel {
            coarse: shading.remove(&model.coarse),
            fine: shading.remove(&model.fine),
            ..model
        })
        .collect()
}

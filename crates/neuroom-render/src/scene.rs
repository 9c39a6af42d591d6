//! What the compositional renderer draws: a background field and posed object instances of shared models.
//!
//! Several instances may name one [`Model`] (identical chairs render from one field, as the paper proposes
//! for rooms with many similar objects). Each instance has its own pose, culling box, codes and tone
//! adjuster. Code rows are indexed per instance: an instance that needs its own light (or appearance) code
//! points at its own row of the model's code table, so the gradient of that row, accumulated into the model's
//! gradient `Params` by [`neuroom_field::Field::backward`], is exactly that instance's gradient; instances
//! that share a row share its gradient.

use glam::{Mat3, Vec3};
use neuroom_core::Pose;
use neuroom_core::rotation6d::{rotation_from_6d_f32, rotation_to_6d_f32};
use neuroom_field::{CodeSet, Codes, NeusField};
use serde::{Deserialize, Serialize};

/// A field with the NeuS sharpness it is rendered with.
#[derive(Clone, Debug)]
pub struct Model<F> {
    /// The SDF + radiance field, queried in its own frame.
    pub field: F,
    /// NeuS sharpness `s` of `Φ_s(f) = σ(s f)`: larger is a thinner surface.
    pub inv_s: f32,
}

impl Model<NeusField> {
    /// A trained NeuS field, rendered with its learnt sharpness.
    pub fn neus(field: NeusField) -> Self {
        let inv_s = field.inv_s();
        Self { field, inv_s }
    }
}

/// Per-channel colour transform `c' = (c − shift) / scale` (the paper's tone adjuster), applied to a
/// field's colour before compositing; as a gradient, the same struct holds `∂loss/∂shift` and `∂loss/∂scale`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tone {
    /// Colour shift `t`.
    pub shift: Vec3,
    /// Colour scale `s` (non-zero).
    pub scale: Vec3,
}

impl Default for Tone {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Tone {
    /// No change.
    pub const IDENTITY: Tone = Tone {
        shift: Vec3::ZERO,
        scale: Vec3::ONE,
    };

    /// All-zero gradient.
    pub const ZERO_GRAD: Tone = Tone {
        shift: Vec3::ZERO,
        scale: Vec3::ZERO,
    };

    /// `(c − shift) / scale`.
    #[inline]
    pub fn apply(&self, c: Vec3) -> Vec3 {
        (c - self.shift) / self.scale
    }

    /// Adds `∂loss/∂shift` and `∂loss/∂scale` for one toned colour `toned = apply(c)` with gradient `d` into
    /// `grad`, and returns `∂loss/∂c`.
    #[inline]
    pub fn backward(&self, toned: Vec3, d: Vec3, grad: &mut Tone) -> Vec3 {
        let dc = d / self.scale;
        grad.shift -= dc;
        grad.scale -= dc * toned;
        dc
    }

    /// Component-wise sum (of gradients).
    pub fn add(&mut self, other: &Tone) {
        self.shift += other.shift;
        self.scale += other.scale;
    }
}

/// The code rows an instance queries its model with.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct InstanceCodes {
    /// Appearance code row.
    pub appearance: u32,
    /// Light code row.
    pub light: u32,
    /// Object code row (for models holding several objects; ignored otherwise).
    pub object: u32,
}

impl InstanceCodes {
    /// The same rows for every point of a query.
    pub fn code_set(&self) -> CodeSet<'static> {
        CodeSet {
            appearance: Codes::Fixed(self.appearance),
            light: Codes::Fixed(self.light),
            object: Codes::Fixed(self.object),
        }
    }
}

/// The room without movable objects: a field in world coordinates, never posed.
#[derive(Clone, Debug, PartialEq)]
pub struct Background {
    /// Index into [`Scene::models`].
    pub model: usize,
    /// Lower corner of the box the background is sampled in (world, metres).
    pub bounds_min: Vec3,
    /// Upper corner of that box.
    pub bounds_max: Vec3,
    /// Code rows.
    pub codes: InstanceCodes,
    /// Tone adjuster.
    pub tone: Tone,
}

/// One posed instance of a model.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneObject {
    /// Index into [`Scene::models`]; several objects may share one model.
    pub model: usize,
    /// Id written to instance images (non-zero; 0 means "no object").
    pub instance_id: u16,
    /// Translation of `object_to_world` (metres).
    pub translation: Vec3,
    /// 6D rotation of `object_to_world` (two columns before Gram–Schmidt).
    pub rotation6d: [f32; 6],
    /// Half extents of the object's box in its own frame, centred at its origin (culling).
    pub half_extents: Vec3,
    /// Code rows.
    pub codes: InstanceCodes,
    /// Tone adjuster.
    pub tone: Tone,
}

impl SceneObject {
    /// An object at `object_to_world`, identity tone and code row 0.
    pub fn new(model: usize, instance_id: u16, object_to_world: &Pose, half_extents: Vec3) -> Self {
        let mut object = Self {
            model,
            instance_id,
            translation: Vec3::ZERO,
            rotation6d: rotation_to_6d_f32(Mat3::IDENTITY),
            half_extents,
            codes: InstanceCodes::default(),
            tone: Tone::IDENTITY,
        };
        object.set_pose(object_to_world);
        object
    }

    /// The rotation of `object_to_world`.
    pub fn rotation(&self) -> Mat3 {
        rotation_from_6d_f32(self.rotation6d)
    }

    /// `object_to_world` as a double-precision pose.
    pub fn pose(&self) -> Pose {
        Pose::new(self.rotation().as_dmat3(), self.translation.as_dvec3())
    }

    /// Sets translation and rotation from a pose.
    pub fn set_pose(&mut self, object_to_world: &Pose) {
        self.translation = object_to_world.translation_f32();
        self.rotation6d = rotation_to_6d_f32(object_to_world.rotation_f32());
    }
}

/// A background and its objects, over a shared list of models.
#[derive(Clone, Debug)]
pub struct Scene<F> {
    /// The fields; objects and the background index into this list.
    pub models: Vec<Model<F>>,
    /// The room.
    pub background: Background,
    /// The movable objects.
    pub objects: Vec<SceneObject>,
}

/// One field along the rays, in the renderer's order: layer 0 is the background, layer `k` object `k − 1`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layer {
    pub model: usize,
    /// Rotation of `layer_to_world`.
    pub rotation: Mat3,
    /// Translation of `layer_to_world`.
    pub translation: Vec3,
    /// Culling box in the layer frame (padded).
    pub lo: Vec3,
    pub hi: Vec3,
    pub codes: InstanceCodes,
    pub tone: Tone,
    /// Id for instance images (0 for the background).
    pub instance_id: u16,
}

impl Layer {
    /// A world point in the layer frame.
    #[inline]
    pub fn world_to_layer(&self, x: Vec3) -> Vec3 {
        self.rotation.transpose() * (x - self.translation)
    }
}

impl<F> Scene<F> {
    /// Number of layers (background + objects).
    pub fn num_layers(&self) -> usize {
        1 + self.objects.len()
    }

    /// The layers with boxes padded by `padding` metres, written into `out`.
    pub(crate) fn layers(&self, padding: f32, out: &mut Vec<Layer>) {
        out.clear();
        let bg = &self.background;
        out.push(Layer {
            model: bg.model,
            rotation: Mat3::IDENTITY,
            translation: Vec3::ZERO,
            lo: bg.bounds_min,
            hi: bg.bounds_max,
            codes: bg.codes,
            tone: bg.tone,
            instance_id: 0,
        });
        out.extend(self.objects.iter().map(|o| {
            let h = o.half_extents + Vec3::splat(padding);
            Layer {
                model: o.model,
                rotation: o.rotation(),
                translation: o.translation,
                lo: -h,
                hi: h,
                codes: o.codes,
                tone: o.tone,
                instance_id: o.instance_id,
            }
        }));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    #[test]
    fn tone_backward_matches_finite_differences() {
        let tone = Tone {
            shift: Vec3::new(0.1, -0.2, 0.05),
            scale: Vec3::new(0.9, 1.2, 1.1),
        };
        let (c, d) = (Vec3::new(0.3, 0.6, 0.8), Vec3::new(0.7, -0.4, 0.2));
        let loss = |t: &Tone, c: Vec3| t.apply(c).dot(d) as f64;
        let mut g = Tone::ZERO_GRAD;
        let dc = tone.backward(tone.apply(c), d, &mut g);
        let h = 1e-3;
        for a in 0..3 {
            let mut e = Vec3::ZERO;
            e[a] = h;
            let num_c = (loss(&tone, c + e) - loss(&tone, c - e)) / (2.0 * h as f64);
            let shifted = |s: f32| Tone {
                shift: tone.shift + e * s,
                ..tone
            };
            let scaled = |s: f32| Tone {
                scale: tone.scale + e * s,
                ..tone
            };
            let num_t = (loss(&shifted(1.0), c) - loss(&shifted(-1.0), c)) / (2.0 * h as f64);
            let num_s = (loss(&scaled(1.0), c) - loss(&scaled(-1.0), c)) / (2.0 * h as f64);
            assert!((num_c - dc[a] as f64).abs() < 1e-3);
            assert!((num_t - g.shift[a] as f64).abs() < 1e-3);
            assert!((num_s - g.scale[a] as f64).abs() < 1e-3);
        }
    }

    #[test]
    fn pose_round_trips_through_6d() {
        let pose = Pose::from_yaw_translation(0.7, DVec3::new(1.0, -2.0, 0.5));
        let o = SceneObject::new(0, 1, &pose, Vec3::ONE);
        let back = o.pose();
        assert!(back.rotation.abs_diff_eq(pose.rotation, 1e-6));
        assert!(back.translation.abs_diff_eq(pose.translation, 1e-6));
    }
}

//! The compositional renderer: a background and posed objects rendered together along world rays,
//! forward and backward, with reusable buffers.
//!
//! One pass over a batch of rays:
//! 1. [`Renderer::plan`] (no gradient, see [`crate::plan`]): cull, sphere-trace and place samples.
//! 2. [`Renderer::forward`]: per field, the sample points `p = Rᵀ(o + t·d − T)` and directions `Rᵀd` in its
//!    frame from the current pose, one batched [`Field::forward`] per field, then per ray the composite of
//!    all fields (see [`crate::composite`]), in rayon tasks of `RAYS_PER_TASK` rays.
//! 3. [`Renderer::backward`]: per ray the composite's backward (tone gradients kept per task, summed at the
//!    end), per field [`Field::backward`] (parameter gradients — codes included — into the caller's
//!    per-model `Params`, and `∂loss/∂p`), then per object the pose gradient
//!    `∂loss/∂T = −R Σ g`, `∂loss/∂R = Σ (x − T) gᵀ` (`g = ∂loss/∂p`) and through the 6D map.
//!
//! Not differentiated, by design: the sample distances (the traced surface distance is a constant, as in
//! the paper), the view direction's dependence on an object's rotation, and the normal fed to the colour
//! network (the field excludes that path). The background is never posed.

use crate::composite::{LayerGrad, LayerView, RayScratch};
use crate::config::{RenderConfig, RenderStats};
use crate::plan::PlanScratch;
use crate::scene::{Layer, Scene, Tone};
use crate::volume::RayOutput;
use glam::{DMat3, DVec3, Vec3};
use neuroom_core::Ray;
use neuroom_core::rotation6d::rotation_from_6d_backward_f32;
use neuroom_field::{Field, FieldOutput, Params, Query};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Rays per rayon task in culling and compositing.
pub(crate) const RAYS_PER_TASK: usize = 64;

/// The samples of one field for a batch: segment-major, `n` samples per segment.
#[derive(Clone, Debug, Default)]
pub(crate) struct LayerSamples<T> {
    /// Ray of each segment, ascending.
    pub rays: Vec<u32>,
    /// Sample distances along the world ray.
    pub t: Vec<f32>,
    points: Vec<Vec3>,
    dirs: Vec<Vec3>,
    out: FieldOutput,
    tape: T,
}

impl<T> LayerSamples<T> {
    fn bytes(&self) -> usize {
        4 * (self.rays.capacity() + self.t.capacity() + self.out.sdf.capacity())
            + 12 * (self.points.capacity()
                + self.dirs.capacity()
                + self.out.rgb.capacity()
                + self.out.gradient.capacity())
    }
}

/// Per-sample gradients of one field for a batch (same layout as [`LayerSamples`]).
#[derive(Clone, Debug, Default)]
struct LayerGrads {
    d_sdf: Vec<f32>,
    d_rgb: Vec<Vec3>,
    d_points: Vec<Vec3>,
}

impl LayerGrads {
    fn bytes(&self) -> usize {
        4 * self.d_sdf.capacity() + 12 * (self.d_rgb.capacity() + self.d_points.capacity())
    }
}

/// Gradient of a loss with respect to one object's parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ObjectGrad {
    /// `∂loss/∂translation`.
    pub translation: Vec3,
    /// `∂loss/∂rotation6d`.
    pub rotation6d: [f32; 6],
    /// `∂loss/∂tone` (shift and scale).
    pub tone: Tone,
}

/// Gradient of a loss with respect to the scene's poses and tone adjusters (code gradients go to the
/// per-model `Params` passed to [`Renderer::backward`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneGrad {
    /// `∂loss/∂tone` of the background.
    pub background_tone: Tone,
    /// One per object, in scene order.
    pub objects: Vec<ObjectGrad>,
}

/// Renders batches of world rays through a [`Scene`], forward and backward; holds every buffer so that
/// repeated passes allocate nothing once grown.
pub struct Renderer<F: Field> {
    pub(crate) config: RenderConfig,
    pub(crate) layers: Vec<Layer>,
    pub(crate) rays: Vec<Ray>,
    pub(crate) ranges: Vec<[f32; 2]>,
    pub(crate) seg_of_ray: Vec<u32>,
    pub(crate) samples: Vec<LayerSamples<F::Tape>>,
    grads: Vec<LayerGrads>,
    pub(crate) scratch: PlanScratch,
    pub(crate) stats: RenderStats,
    tasks: Vec<RayScratch>,
    outputs: Vec<RayOutput<f32>>,
    instances: Vec<u16>,
}

impl<F: Field> Renderer<F> {
    /// A renderer with empty buffers.
    pub fn new(config: RenderConfig) -> Self {
        Self {
            config,
            layers: Vec::new(),
            rays: Vec::new(),
            ranges: Vec::new(),
            seg_of_ray: Vec::new(),
            samples: Vec::new(),
            grads: Vec::new(),
            scratch: PlanScratch::default(),
            stats: RenderStats::default(),
            tasks: Vec::new(),
            outputs: Vec::new(),
            instances: Vec::new(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &RenderConfig {
        &self.config
    }

    /// The settings, to change between passes (e.g. the jitter seed per iteration).
    pub fn config_mut(&mut self) -> &mut RenderConfig {
        &mut self.config
    }

    /// Cost of the last planned batch; `buffer_bytes` is the peak over this renderer's life.
    pub fn stats(&self) -> RenderStats {
        let layers: usize = self.samples.iter().map(LayerSamples::bytes).sum::<usize>()
            + self.grads.iter().map(LayerGrads::bytes).sum::<usize>();
        let tasks: usize = self.tasks.iter().map(RayScratch::bytes).sum();
        let rays = 24 * self.rays.capacity()
            + 8 * self.ranges.capacity()
            + 4 * self.seg_of_ray.capacity()
            + 20 * self.outputs.capacity()
            + 2 * self.instances.capacity();
        RenderStats {
            buffer_bytes: (layers + tasks + rays + self.scratch.bytes()) as u64,
            ..self.stats
        }
    }

    /// Plans and renders a batch: [`Renderer::plan`] then [`Renderer::forward`].
    pub fn render(&mut self, scene: &Scene<F>, rays: &[Ray]) -> &[RayOutput<f32>] {
        self.plan(scene, rays);
        self.forward(scene)
    }

    /// Per-ray outputs of the last forward pass: `rgb = Σ wᵢ c'ᵢ`, `depth = Σ wᵢ tᵢ` (divide by the
    /// opacity for the expected ray distance), `opacity = Σ wᵢ`.
    pub fn outputs(&self) -> &[RayOutput<f32>] {
        &self.outputs
    }

    /// Per-ray instance id of the field with the largest weight in the last forward pass (0: background or
    /// nothing).
    pub fn instances(&self) -> &[u16] {
        &self.instances
    }

    /// Renders the planned rays with the scene's current poses, tones and fields (the scene must have the
    /// objects it was planned with). Returns the per-ray outputs (see [`Renderer::outputs`]).
    pub fn forward(&mut self, scene: &Scene<F>) -> &[RayOutput<f32>] {
        let n_layers = self.layers.len();
        assert_eq!(scene.num_layers(), n_layers, "scene changed since plan()");
        scene.layers(self.config.box_padding, &mut self.layers);
        for l in 0..n_layers {
            self.evaluate_layer(scene, l);
        }
        self.composite_all(scene);
        &self.outputs
    }

    /// Sample points and directions of layer `l` in its frame, then one full field query.
    fn evaluate_layer(&mut self, scene: &Scene<F>, l: usize) {
        let layer = self.layers[l];
        let n = self.config.sampling.per_segment();
        let s = &mut self.samples[l];
        let count = s.t.len();
        s.points.resize(count, Vec3::ZERO);
        s.dirs.resize(count, Vec3::ZERO);
        if count == 0 {
            return;
        }
        let rt = layer.rotation.transpose();
        let rays = &self.rays;
        s.points
            .par_chunks_mut(n)
            .zip(s.dirs.par_chunks_mut(n))
            .zip(s.t.par_chunks(n).zip(s.rays.par_iter()))
            .for_each(|((p, d), (t, &r))| {
                let ray = &rays[r as usize];
                let dir = rt * ray.direction;
                for ((p, d), t) in p.iter_mut().zip(d.iter_mut()).zip(t) {
                    *p = layer.world_to_layer(ray.at(*t));
                    *d = dir;
                }
            });
        let query = Query {
            points: &s.points,
            dirs: &s.dirs,
            codes: layer.codes.code_set(),
        };
        scene.models[layer.model]
            .field
            .forward(&query, &mut s.tape, &mut s.out);
        self.stats.full_queries += count as u64;
    }

    /// The read-only views of every layer's samples for compositing.
    fn views<'a>(
        layers: &[Layer],
        samples: &'a [LayerSamples<F::Tape>],
        scene: &Scene<F>,
    ) -> Vec<LayerView<'a>> {
        layers
            .iter()
            .zip(samples)
            .map(|(layer, s)| LayerView {
                t: &s.t,
                sdf: &s.out.sdf,
                rgb: &s.out.rgb,
                inv_s: scene.models[layer.model].inv_s,
                tone: layer.tone,
            })
            .collect()
    }

    /// Composites every ray, in tasks of [`RAYS_PER_TASK`] rays.
    fn composite_all(&mut self, scene: &Scene<F>) {
        let (n_rays, n_layers) = (self.rays.len(), self.layers.len());
        let n = self.config.sampling.per_segment();
        let tasks = n_rays.div_ceil(RAYS_PER_TASK);
        if self.tasks.len() < tasks {
            self.tasks.resize_with(tasks, Default::default);
        }
        self.outputs.resize(n_rays, RayOutput::default());
        self.instances.resize(n_rays, 0);
        let views = Self::views(&self.layers, &self.samples, scene);
        let (layers, seg_of_ray) = (&self.layers, &self.seg_of_ray);
        self.outputs
            .par_chunks_mut(RAYS_PER_TASK)
            .zip(self.instances.par_chunks_mut(RAYS_PER_TASK))
            .zip(seg_of_ray.par_chunks(RAYS_PER_TASK * n_layers))
            .zip(self.tasks[..tasks].par_iter_mut())
            .for_each(|(((out, ids), rows), scratch)| {
                for ((o, id), row) in out.iter_mut().zip(ids).zip(rows.chunks(n_layers)) {
                    *o = scratch.forward(row, &views, n);
                    *id = scratch.dominant().map_or(0, |l| layers[l].instance_id);
                }
            });
    }

    /// Backward pass of the last [`Renderer::forward`] given `d_out[r]`, the gradient of the loss with
    /// respect to ray `r`'s outputs. Adds every field's parameter gradients (appearance, light and object
    /// code rows of each instance included) to `model_grads[model]` (one `Params` per model, of the
    /// field's parameter shape; analytic fields take empty ones), and returns the pose and tone gradients.
    pub fn backward(
        &mut self,
        scene: &Scene<F>,
        d_out: &[RayOutput<f32>],
        model_grads: &mut [Params<f32>],
    ) -> SceneGrad {
        assert_eq!(d_out.len(), self.rays.len(), "one gradient per ray");
        assert_eq!(
            model_grads.len(),
            scene.models.len(),
            "one Params per model"
        );
        let tones = self.composite_backward_all(scene, d_out);
        let mut grad = SceneGrad {
            background_tone: tones[0],
            objects: Vec::with_capacity(scene.objects.len()),
        };
        for l in 0..self.layers.len() {
            self.field_backward(scene, l, &mut model_grads[self.layers[l].model]);
            if l > 0 {
                grad.objects.push(self.pose_grad(scene, l, tones[l]));
            }
        }
        grad
    }

    /// Per ray, the composite's backward into the per-sample `d_sdf` / `d_rgb`; returns the tone gradient
    /// of every layer.
    fn composite_backward_all(&mut self, scene: &Scene<F>, d_out: &[RayOutput<f32>]) -> Vec<Tone> {
        let (n_rays, n_layers) = (self.rays.len(), self.layers.len());
        let n = self.config.sampling.per_segment();
        let tasks = n_rays.div_ceil(RAYS_PER_TASK);
        self.grads.resize_with(n_layers, Default::default);
        for (g, s) in self.grads.iter_mut().zip(&self.samples) {
            g.d_sdf.clear();
            g.d_sdf.resize(s.t.len(), 0.0);
            g.d_rgb.clear();
            g.d_rgb.resize(s.t.len(), Vec3::ZERO);
        }
        let grads = split_by_task(&self.samples, &mut self.grads, n, tasks);
        let views = Self::views(&self.layers, &self.samples, scene);
        let seg_of_ray = &self.seg_of_ray;
        self.tasks[..tasks]
            .par_iter_mut()
            .zip(grads)
            .zip(d_out.par_chunks(RAYS_PER_TASK))
            .zip(seg_of_ray.par_chunks(RAYS_PER_TASK * n_layers))
            .for_each(|(((scratch, mut g), d), rows)| {
                scratch.tone_grad.clear();
                scratch.tone_grad.resize(n_layers, Tone::ZERO_GRAD);
                for (d, row) in d.iter().zip(rows.chunks(n_layers)) {
                    scratch.backward(row, &views, n, d, &mut g);
                }
            });
        let mut tones = vec![Tone::ZERO_GRAD; n_layers];
        for scratch in &self.tasks[..tasks] {
            for (t, g) in tones.iter_mut().zip(&scratch.tone_grad) {
                t.add(g);
            }
        }
        tones
    }

    /// [`Field::backward`] of layer `l`; objects also get `∂loss/∂p` per sample.
    fn field_backward(&mut self, scene: &Scene<F>, l: usize, grads: &mut Params<f32>) {
        let layer = self.layers[l];
        let (s, g) = (&mut self.samples[l], &mut self.grads[l]);
        if s.points.is_empty() {
            return;
        }
        let query = Query {
            points: &s.points,
            dirs: &s.dirs,
            codes: layer.codes.code_set(),
        };
        let d_points = if l > 0 {
            g.d_points.resize(s.points.len(), Vec3::ZERO);
            Some(&mut g.d_points[..])
        } else {
            None
        };
        scene.models[layer.model].field.backward(
            &query,
            &mut s.tape,
            &g.d_sdf,
            &g.d_rgb,
            grads,
            d_points,
        );
    }

    /// Translation and 6D-rotation gradient of object layer `l` from its per-sample `∂loss/∂p`.
    fn pose_grad(&self, scene: &Scene<F>, l: usize, tone: Tone) -> ObjectGrad {
        let layer = &self.layers[l];
        let s = &self.samples[l];
        let n = self.config.sampling.per_segment();
        let rays = &self.rays;
        let (d_x, d_r) = self.grads[l]
            .d_points
            .par_chunks(n)
            .zip(s.t.par_chunks(n).zip(s.rays.par_iter()))
            .fold(
                || (DVec3::ZERO, DMat3::ZERO),
                |(mut d_x, mut d_r), (g, (t, &r))| {
                    let ray = &rays[r as usize];
                    for (g, t) in g.iter().zip(t) {
                        let v = (ray.at(*t) - layer.translation).as_dvec3();
                        let g = g.as_dvec3();
                        d_x += g;
                        d_r += DMat3::from_cols(v * g.x, v * g.y, v * g.z);
                    }
                    (d_x, d_r)
                },
            )
            .reduce(|| (DVec3::ZERO, DMat3::ZERO), |a, b| (a.0 + b.0, a.1 + b.1));
        let object = &scene.objects[l - 1];
        ObjectGrad {
            translation: -(layer.rotation * d_x.as_vec3()),
            rotation6d: rotation_from_6d_backward_f32(object.rotation6d, d_r.as_mat3()),
            tone,
        }
    }
}

/// Splits every layer's `d_sdf` / `d_rgb` into the disjoint ranges of the tasks' rays: task `k` owns the
/// segments of rays `k · RAYS_PER_TASK ..`, contiguous because segments are in ray order.
fn split_by_task<'a, T>(
    samples: &[LayerSamples<T>],
    grads: &'a mut [LayerGrads],
    n: usize,
    tasks: usize,
) -> Vec<Vec<LayerGrad<'a>>> {
    let mut out: Vec<Vec<LayerGrad>> = (0..tasks)
        .map(|_| Vec::with_capacity(samples.len()))
        .collect();
    for (s, g) in samples.iter().zip(grads.iter_mut()) {
        let (mut d_sdf, mut d_rgb) = (&mut g.d_sdf[..], &mut g.d_rgb[..]);
        let mut first = 0;
        for (k, task) in out.iter_mut().enumerate() {
            let end_ray = ((k + 1) * RAYS_PER_TASK) as u32;
            let end = s.rays.partition_point(|&r| r < end_ray) * n;
            let (a, rest) = std::mem::take(&mut d_sdf).split_at_mut(end - first);
            let (b, rest_rgb) = std::mem::take(&mut d_rgb).split_at_mut(end - first);
            task.push(LayerGrad {
                first,
                d_sdf: a,
                d_rgb: b,
            });
            (d_sdf, d_rgb, first) = (rest, rest_rgb, end);
        }
    }
    out
}

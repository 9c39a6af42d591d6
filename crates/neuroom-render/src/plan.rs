//! Planning a batch (no gradient): culling every ray against every layer's box, sphere tracing, and placing
//! the samples of each (ray, layer) segment. The plan holds sample *distances* along the world rays only, so
//! a forward pass re-derives the sample points from the current poses: the samples stay fixed while the
//! poses move (the paper's treatment of the traced distance as a constant, and what makes finite-difference
//! checks of the pose gradient exact).

use crate::config::Sampling;
use crate::cull::slab;
use crate::renderer::{RAYS_PER_TASK, Renderer};
use crate::sampling::{importance_with, merge_sorted};
use crate::scene::{Layer, Scene};
use crate::trace::Tracer;
use crate::volume::neus_alphas;
use glam::Vec3;
use neuroom_core::Ray;
use neuroom_field::Field;
use neuroom_field::rng::SplitMix;
use rayon::prelude::*;

/// A (ray, layer) pair the ray misses.
const MISS: [f32; 2] = [f32::INFINITY, f32::NEG_INFINITY];

/// Segments per rayon task when placing samples.
const SEGMENTS_PER_TASK: usize = 64;

/// Reusable buffers of planning.
#[derive(Clone, Debug, Default)]
pub(crate) struct PlanScratch {
    tracer: Tracer,
    candidates: Vec<u32>,
    hits: Vec<Option<f32>>,
    windows: Vec<[f32; 2]>,
    coarse_t: Vec<f32>,
    coarse_points: Vec<Vec3>,
    coarse_sdf: Vec<f32>,
    tasks: Vec<SegmentScratch>,
}

/// Per-task buffers of fine sample placement.
#[derive(Clone, Debug, Default)]
struct SegmentScratch {
    alpha: Vec<f32>,
    weights: Vec<f32>,
    cdf: Vec<f32>,
    fine: Vec<f32>,
    merged: Vec<f32>,
}

impl PlanScratch {
    /// Bytes held (capacity).
    pub(crate) fn bytes(&self) -> usize {
        let tasks: usize = self
            .tasks
            .iter()
            .map(|s| {
                4 * (s.alpha.capacity()
                    + s.weights.capacity()
                    + s.cdf.capacity()
                    + s.fine.capacity()
                    + s.merged.capacity())
            })
            .sum();
        tasks
            + self.tracer.bytes()
            + 4 * self.candidates.capacity()
            + 8 * (self.hits.capacity() + self.windows.capacity())
            + 4 * (self.coarse_t.capacity() + self.coarse_sdf.capacity())
            + 12 * self.coarse_points.capacity()
    }
}

/// A deterministic generator of uniform numbers per (seed, ray, layer), or the bin centres without jitter.
fn jitter_rng(jitter: bool, seed: u64, ray: u32, layer: usize) -> impl FnMut() -> f32 {
    let mut rng =
        SplitMix::new(seed ^ ((ray as u64) << 20 | layer as u64).wrapping_mul(0x2545_F491));
    move || {
        if jitter { rng.next_f64() as f32 } else { 0.5 }
    }
}

impl<F: Field> Renderer<F> {
    /// Plans a batch of world rays for `scene`: culling, sphere tracing (safe region) and sample
    /// placement, all without gradient. Resets the statistics. Follow with [`Renderer::forward`].
    pub fn plan(&mut self, scene: &Scene<F>, rays: &[Ray]) {
        scene.layers(self.config.box_padding, &mut self.layers);
        self.rays.clear();
        self.rays.extend_from_slice(rays);
        self.stats = Default::default();
        self.stats.rays = rays.len() as u64;
        self.cull();
        let n_layers = self.layers.len();
        if self.samples.len() < n_layers {
            self.samples.resize_with(n_layers, Default::default);
        }
        for l in 0..n_layers {
            self.plan_layer(scene, l);
        }
        self.index_segments();
    }

    /// `ranges[r · L + l]`: the distances of ray `r` inside layer `l`'s box, or [`MISS`].
    fn cull(&mut self) {
        let (layers, near) = (&self.layers, self.config.near);
        let n_layers = layers.len();
        self.ranges.resize(self.rays.len() * n_layers, MISS);
        self.ranges
            .par_chunks_mut(n_layers * RAYS_PER_TASK)
            .zip(self.rays.par_chunks(RAYS_PER_TASK))
            .for_each(|(ranges, rays)| {
                for (row, ray) in ranges.chunks_mut(n_layers).zip(rays) {
                    for (range, layer) in row.iter_mut().zip(layers) {
                        let (o, d) = local_ray(layer, ray);
                        *range = slab(o, d, layer.lo, layer.hi, near).unwrap_or(MISS);
                    }
                }
            });
    }

    /// Chooses the segments of layer `l` and places their samples.
    fn plan_layer(&mut self, scene: &Scene<F>, l: usize) {
        let layer = self.layers[l];
        let n_layers = self.layers.len();
        let field = &scene.models[layer.model].field;
        let s = &mut self.scratch;
        s.candidates.clear();
        s.candidates.extend(
            (0..self.rays.len() as u32)
                .filter(|&r| self.ranges[r as usize * n_layers + l][0] < f32::INFINITY),
        );
        let seg = &mut self.samples[l];
        seg.rays.clear();
        s.windows.clear();
        match self.config.sampling {
            Sampling::Classical { .. } => {
                seg.rays.extend_from_slice(&s.candidates);
                s.windows.extend(
                    s.candidates
                        .iter()
                        .map(|&r| self.ranges[r as usize * n_layers + l]),
                );
            }
            Sampling::SafeRegion { before, after, .. } => {
                let (rays, ranges) = (&self.rays, &self.ranges);
                let starts = s.candidates.iter().map(|&r| {
                    let (o, d) = local_ray(&layer, &rays[r as usize]);
                    (o, d, ranges[r as usize * n_layers + l])
                });
                self.stats.trace_queries +=
                    s.tracer
                        .trace(field, starts, &self.config.trace, &mut s.hits);
                for (&r, hit) in s.candidates.iter().zip(&s.hits) {
                    if let Some(d) = hit {
                        let [t0, t1] = self.ranges[r as usize * n_layers + l];
                        seg.rays.push(r);
                        s.windows.push([(d - before).max(t0), (d + after).min(t1)]);
                    }
                }
            }
        }
        self.place_samples(scene, l);
    }

    /// Coarse samples in each segment's window, their SDF, then fine samples from the coarse NeuS weights;
    /// writes the merged sorted distances of every segment.
    fn place_samples(&mut self, scene: &Scene<F>, l: usize) {
        let layer = self.layers[l];
        let model = &scene.models[layer.model];
        let (nc, nf) = self.config.sampling.counts();
        assert!(nc >= 2, "at least two coarse samples per field are needed");
        let n = self.config.sampling.per_segment();
        let (jitter, seed) = (self.config.jitter, self.config.seed);
        let s = &mut self.scratch;
        let seg = &mut self.samples[l];
        let count = seg.rays.len();
        seg.t.clear();
        if count == 0 {
            return;
        }
        s.coarse_t.resize(count * nc, 0.0);
        s.coarse_points.resize(count * nc, Vec3::ZERO);
        s.coarse_sdf.resize(count * nc, 0.0);
        let rays = &self.rays;
        s.coarse_t
            .par_chunks_mut(nc)
            .zip(s.coarse_points.par_chunks_mut(nc))
            .zip(seg.rays.par_iter().zip(&s.windows))
            .for_each(|((ct, cp), (&r, &[a, b]))| {
                let mut rng = jitter_rng(jitter, seed, r, l);
                let step = (b - a) / nc as f32;
                let ray = &rays[r as usize];
                for (k, (t, p)) in ct.iter_mut().zip(cp.iter_mut()).enumerate() {
                    *t = a + (k as f32 + rng()) * step;
                    *p = layer.world_to_layer(ray.at(*t));
                }
            });
        model.field.sdf(&s.coarse_points, &mut s.coarse_sdf);
        self.stats.coarse_queries += (count * nc) as u64;
        seg.t.resize(count * n, 0.0);
        let tasks = count.div_ceil(SEGMENTS_PER_TASK);
        if s.tasks.len() < tasks {
            s.tasks.resize_with(tasks, Default::default);
        }
        let inv_s = model.inv_s;
        seg.t
            .par_chunks_mut(n * SEGMENTS_PER_TASK)
            .zip(s.coarse_t.par_chunks(nc * SEGMENTS_PER_TASK))
            .zip(s.coarse_sdf.par_chunks(nc * SEGMENTS_PER_TASK))
            .zip(seg.rays.par_chunks(SEGMENTS_PER_TASK))
            .zip(s.tasks[..tasks].par_iter_mut())
            .for_each(|((((out, ct), cs), rs), task)| {
                for (k, &r) in rs.iter().enumerate() {
                    let range = k * nc..(k + 1) * nc;
                    let mut rng = jitter_rng(jitter, seed ^ 0xF1E, r, l);
                    task.fine_samples(&ct[range.clone()], &cs[range], inv_s, nf, &mut rng);
                    out[k * n..(k + 1) * n].copy_from_slice(&task.merged[..n]);
                }
            });
        self.stats.segments += count as u64;
    }

    /// `seg_of_ray[r · L + l]`: the segment index of ray `r` in layer `l`, or `u32::MAX`.
    fn index_segments(&mut self) {
        let n_layers = self.layers.len();
        self.seg_of_ray.clear();
        self.seg_of_ray.resize(self.rays.len() * n_layers, u32::MAX);
        for (l, seg) in self.samples[..n_layers].iter().enumerate() {
            for (s, &r) in seg.rays.iter().enumerate() {
                self.seg_of_ray[r as usize * n_layers + l] = s as u32;
            }
        }
    }
}

impl SegmentScratch {
    /// Merges the coarse samples with `nf` importance samples drawn from their NeuS weights into `merged`.
    fn fine_samples(
        &mut self,
        coarse_t: &[f32],
        coarse_sdf: &[f32],
        inv_s: f32,
        nf: usize,
        rng: &mut impl FnMut() -> f32,
    ) {
        self.alpha.resize(coarse_t.len() - 1, 0.0);
        neus_alphas(coarse_sdf, inv_s, &mut self.alpha);
        self.weights.clear();
        let mut trans = 1.0f32;
        for a in &self.alpha {
            self.weights.push(trans * a);
            trans *= 1.0 - a;
        }
        importance_with(
            coarse_t,
            &self.weights,
            nf,
            rng,
            &mut self.cdf,
            &mut self.fine,
        );
        merge_sorted(coarse_t, &self.fine, &mut self.merged);
    }
}

/// A world ray in a layer's frame: origin and direction.
#[inline]
pub(crate) fn local_ray(layer: &Layer, ray: &Ray) -> (Vec3, Vec3) {
    let rt = layer.rotation.transpose();
    (rt * (ray.origin - layer.translation), rt * ray.direction)
}

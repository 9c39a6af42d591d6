//! Compositing of every field's samples along one ray, forward and backward.
//!
//! Compositing rule: each field's segment of `n` sorted samples gives `n − 1` intervals whose NeuS opacity
//! comes from that field's own consecutive SDF samples (as NeuS composites several objects), whose colour
//! is the toned mean of its two end colours, `c' = (c − t) / s` with the field's tone adjuster, and whose
//! depth is its midpoint. The intervals of all fields are sorted by midpoint and composited front to back
//! with [`crate::volume::composite`]. Overlapping intervals of different fields are thereby ordered by their
//! centres, which is exact when the fields' surfaces are apart by more than an interval.
//!
//! The backward pass recomputes the forward pass of the ray (no field query: the SDF and colours are kept
//! by the renderer) instead of storing per-ray tapes, so memory stays at the per-sample buffers.

use crate::scene::Tone;
use crate::volume::{
    CompositeTape, RayOutput, composite, composite_backward, neus_alphas, neus_alphas_backward,
};
use glam::Vec3;

/// One field's samples of a whole batch, as compositing reads them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LayerView<'a> {
    pub t: &'a [f32],
    pub sdf: &'a [f32],
    pub rgb: &'a [Vec3],
    pub inv_s: f32,
    pub tone: Tone,
}

/// Where a rayon task writes the per-sample gradients of one field: the samples from `first` on.
#[derive(Debug)]
pub(crate) struct LayerGrad<'a> {
    pub first: usize,
    pub d_sdf: &'a mut [f32],
    pub d_rgb: &'a mut [Vec3],
}

/// One interval of one field along the ray.
#[derive(Clone, Copy, Debug)]
struct Item {
    t: f32,
    /// Toned colour.
    rgb: Vec3,
    /// Index into the ray's per-segment opacities.
    slot: u32,
    layer: u32,
    /// Index of the interval's first sample in the field's batch.
    sample: u32,
}

/// One field's segment along the ray.
#[derive(Clone, Copy, Debug)]
struct SegRef {
    layer: usize,
    base: usize,
    slot: usize,
}

/// Reusable buffers of one rayon task's rays (no allocation once grown).
#[derive(Clone, Debug, Default)]
pub(crate) struct RayScratch {
    items: Vec<Item>,
    segs: Vec<SegRef>,
    seg_alpha: Vec<f32>,
    alpha: Vec<f32>,
    rgb: Vec<[f32; 3]>,
    t: Vec<f32>,
    tape: CompositeTape<f32>,
    layer_weight: Vec<f32>,
    d_alpha: Vec<f32>,
    d_rgb: Vec<[f32; 3]>,
    seg_d_alpha: Vec<f32>,
    /// Tone-adjuster gradient per layer, accumulated over the task's rays.
    pub tone_grad: Vec<Tone>,
}

impl RayScratch {
    /// Composites one ray whose segment in layer `l` is `seg_row[l]` (`u32::MAX`: none), `n` samples per
    /// segment.
    pub fn forward(&mut self, seg_row: &[u32], views: &[LayerView], n: usize) -> RayOutput<f32> {
        self.gather(seg_row, views, n);
        self.items.sort_unstable_by(|a, b| a.t.total_cmp(&b.t));
        self.alpha.clear();
        self.rgb.clear();
        self.t.clear();
        for it in &self.items {
            self.alpha.push(self.seg_alpha[it.slot as usize]);
            self.rgb.push(it.rgb.to_array());
            self.t.push(it.t);
        }
        let out = composite(&self.alpha, &self.rgb, &self.t, &mut self.tape);
        self.layer_weight.clear();
        self.layer_weight.resize(views.len(), 0.0);
        for (it, w) in self.items.iter().zip(&self.tape.weights) {
            self.layer_weight[it.layer as usize] += w;
        }
        out
    }

    /// The layer with the largest composited weight in the last forward pass, if any has weight.
    pub fn dominant(&self) -> Option<usize> {
        let (l, w) = self
            .layer_weight
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))?;
        (*w > 1e-3).then_some(l)
    }

    /// Every segment's interval opacities and the unsorted intervals.
    fn gather(&mut self, seg_row: &[u32], views: &[LayerView], n: usize) {
        self.items.clear();
        self.segs.clear();
        self.seg_alpha.clear();
        for (l, (&s, v)) in seg_row.iter().zip(views).enumerate() {
            if s == u32::MAX {
                continue;
            }
            let base = s as usize * n;
            let slot = self.seg_alpha.len();
            self.seg_alpha.resize(slot + n - 1, 0.0);
            neus_alphas(&v.sdf[base..base + n], v.inv_s, &mut self.seg_alpha[slot..]);
            self.segs.push(SegRef {
                layer: l,
                base,
                slot,
            });
            self.items.extend((0..n - 1).map(|i| {
                let j = base + i;
                Item {
                    t: 0.5 * (v.t[j] + v.t[j + 1]),
                    rgb: v.tone.apply(0.5 * (v.rgb[j] + v.rgb[j + 1])),
                    slot: (slot + i) as u32,
                    layer: l as u32,
                    sample: j as u32,
                }
            }));
        }
    }

    /// Backward of [`RayScratch::forward`] for one ray: adds `∂loss/∂f` and `∂loss/∂c` (raw field colour)
    /// of its samples to `grads`, and the tone gradients to [`RayScratch::tone_grad`].
    pub fn backward(
        &mut self,
        seg_row: &[u32],
        views: &[LayerView],
        n: usize,
        d_out: &RayOutput<f32>,
        grads: &mut [LayerGrad],
    ) {
        self.forward(seg_row, views, n);
        let m = self.items.len();
        self.d_alpha.resize(m, 0.0);
        self.d_rgb.clear();
        self.d_rgb.resize(m, [0.0; 3]);
        composite_backward(
            &self.alpha,
            &self.rgb,
            &self.t,
            &self.tape,
            d_out,
            &mut self.d_alpha,
            &mut self.d_rgb,
        );
        self.seg_d_alpha.clear();
        self.seg_d_alpha.resize(self.seg_alpha.len(), 0.0);
        for (k, it) in self.items.iter().enumerate() {
            self.seg_d_alpha[it.slot as usize] = self.d_alpha[k];
            let l = it.layer as usize;
            let dc = 0.5
                * views[l]
                    .tone
                    .backward(it.rgb, Vec3::from(self.d_rgb[k]), &mut self.tone_grad[l]);
            let g = &mut grads[l];
            let i = it.sample as usize - g.first;
            g.d_rgb[i] += dc;
            g.d_rgb[i + 1] += dc;
        }
        for seg in &self.segs {
            let (v, g) = (&views[seg.layer], &mut grads[seg.layer]);
            let i = seg.base - g.first;
            neus_alphas_backward(
                &v.sdf[seg.base..seg.base + n],
                v.inv_s,
                &self.seg_d_alpha[seg.slot..seg.slot + n - 1],
                &mut g.d_sdf[i..i + n],
            );
        }
    }

    /// Bytes held (capacity).
    pub fn bytes(&self) -> usize {
        std::mem::size_of::<Item>() * self.items.capacity()
            + std::mem::size_of::<SegRef>() * self.segs.capacity()
            + 4 * (self.seg_alpha.capacity()
                + self.alpha.capacity()
                + self.t.capacity()
                + self.tape.weights.capacity()
                + self.tape.transmittance.capacity()
                + self.layer_weight.capacity()
                + self.d_alpha.capacity()
                + self.seg_d_alpha.capacity())
            + 12 * (self.rgb.capacity() + self.d_rgb.capacity())
    }
}

//! How the compositional renderer samples rays, and what one pass cost.

use crate::trace::TraceConfig;
use serde::{Deserialize, Serialize};

/// Where samples go along a ray, per field the ray meets.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Sampling {
    /// The paper's safe region: sphere-trace to the field's first surface at `d` (no gradient), then
    /// `coarse` samples in `[d − before, d + after]` and `fine` more drawn from the coarse NeuS weights.
    /// Fields the ray does not hit get no samples.
    SafeRegion {
        /// Coarse samples per field.
        coarse: usize,
        /// Fine (importance) samples per field.
        fine: usize,
        /// Extent of the region in front of the surface (metres).
        before: f32,
        /// Extent of the region behind the surface (metres).
        after: f32,
    },
    /// Classical volume rendering: `uniform` samples over the ray's whole range inside the field's box,
    /// then `importance` more from their weights.
    Classical {
        /// Coarse samples per field.
        uniform: usize,
        /// Fine (importance) samples per field.
        importance: usize,
    },
}

impl Sampling {
    /// The paper's safe region: 8 coarse + 16 fine in `[d − 0.05, d + 0.1]` m.
    pub const SAFE_REGION: Sampling = Sampling::SafeRegion {
        coarse: 8,
        fine: 16,
        before: 0.05,
        after: 0.1,
    };

    /// Classical 64 uniform + 64 importance samples.
    pub const CLASSICAL: Sampling = Sampling::Classical {
        uniform: 64,
        importance: 64,
    };

    /// Coarse and fine sample counts per field along a ray.
    pub fn counts(&self) -> (usize, usize) {
        match *self {
            Sampling::SafeRegion { coarse, fine, .. } => (coarse, fine),
            Sampling::Classical {
                uniform,
                importance,
            } => (uniform, importance),
        }
    }

    /// Samples per field along a ray.
    pub fn per_segment(&self) -> usize {
        let (c, f) = self.counts();
        c + f
    }
}

/// Renderer settings.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct RenderConfig {
    /// Sample placement.
    pub sampling: Sampling,
    /// Sphere tracing (safe region only).
    pub trace: TraceConfig,
    /// Nearest distance sampled along a ray (metres).
    pub near: f32,
    /// Padding added to every object box for culling (metres).
    pub box_padding: f32,
    /// Jitter sample positions (stratified), for training-style fits; off renders deterministically.
    pub jitter: bool,
    /// Seed of the jitter (change it per iteration).
    pub seed: u64,
}

impl Default for RenderConfig {
    fn default() -> Self {
        Self {
            sampling: Sampling::SAFE_REGION,
            trace: TraceConfig::default(),
            near: 0.05,
            box_padding: 0.05,
            jitter: false,
            seed: 0,
        }
    }
}

/// What the last planned and rendered batch cost.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct RenderStats {
    /// Rays.
    pub rays: u64,
    /// (ray, field) pairs that got samples.
    pub segments: u64,
    /// Field queries made by sphere tracing (SDF only).
    pub trace_queries: u64,
    /// Field queries at coarse samples (SDF only).
    pub coarse_queries: u64,
    /// Field queries with colour and gradients (the differentiable samples).
    pub full_queries: u64,
    /// Bytes held by the renderer's per-ray and per-sample buffers at their peak (capacity), excluding
    /// the fields' own tapes, which grow with `full_queries`.
    pub buffer_bytes: u64,
}

impl RenderStats {
    /// All field queries.
    pub fn queries(&self) -> u64 {
        self.trace_queries + self.coarse_queries + self.full_queries
    }
}

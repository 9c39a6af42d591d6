//! Multiresolution hash encoding (instant-ngp), forward and backward, written by hand.
//!
//! Layout: one flat parameter vector, level-major; inside a level, entry-major (`entry · F + feature`), so
//! the `F` features of a grid vertex are adjacent. Coarse levels whose `(res + 1)³` vertices fit in the table
//! are stored densely (no collisions); finer levels are hashed with the instant-ngp primes into `T` entries.
//! Kernels loop level-outer, point-inner so one level's table stays hot in cache while a chunk streams past.
//! The table gradient is scattered by a separate pass in which every rayon task owns whole levels: no atomics
//! and no per-thread copies of the tables.

use crate::real::Real;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Shape of a hash encoding.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HashGridConfig {
    /// Number of levels `L`.
    pub levels: usize,
    /// Features per level `F`.
    pub features: usize,
    /// log2 of the table size `T` of a hashed level.
    pub log2_table: u32,
    /// Grid resolution of the coarsest level (cells per unit side).
    pub base_resolution: usize,
    /// Grid resolution of the finest level; levels in between grow geometrically.
    pub finest_resolution: usize,
}

impl HashGridConfig {
    /// Width of the encoding: `L · F`.
    pub fn output_dim(&self) -> usize {
        self.levels * self.features
    }
}

/// One level's geometry and where its entries start in the flat parameter vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Level {
    /// Cells per unit side.
    pub resolution: usize,
    /// Number of table entries (`(res+1)³` when dense, `T` when hashed).
    pub entries: usize,
    /// Offset of the level's first parameter.
    pub offset: usize,
    /// Whether vertices are indexed directly (true) or hashed (false).
    pub dense: bool,
}

/// A hash encoding: the configuration plus the derived level table. Parameters live outside (see
/// [`crate::params`]) so that the same grid serves `f32` training and `f64` tests.
#[derive(Clone, Debug)]
pub struct HashGrid {
    config: HashGridConfig,
    levels: Vec<Level>,
    num_params: usize,
}

/// Largest supported `F` (features per level).
pub const MAX_FEATURES: usize = 8;

const PRIME_Y: u32 = 2_654_435_761;
const PRIME_Z: u32 = 805_459_861;

impl HashGrid {
    /// Derives the level table of a configuration.
    pub fn new(config: HashGridConfig) -> Self {
        let table = 1usize << config.log2_table;
        let growth = if config.levels > 1 {
            ((config.finest_resolution as f64).ln() - (config.base_resolution as f64).ln())
                / (config.levels - 1) as f64
        } else {
            0.0
        };
        let mut offset = 0;
        let levels = (0..config.levels)
            .map(|l| {
                let resolution = ((config.base_resolution as f64 * (growth * l as f64).exp())
                    .round() as usize)
                    .max(1);
                let vertices = (resolution + 1).pow(3);
                let dense = vertices <= table;
                let entries = if dense { vertices } else { table };
                let level = Level {
                    resolution,
                    entries,
                    offset,
                    dense,
                };
                offset += entries * config.features;
                level
            })
            .collect();
        Self {
            config,
            levels,
            num_params: offset,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &HashGridConfig {
        &self.config
    }

    /// The levels, coarsest first.
    pub fn levels(&self) -> &[Level] {
        &self.levels
    }

    /// Total number of parameters (all levels, all features).
    pub fn num_params(&self) -> usize {
        self.num_params
    }

    /// Encodes `u.len()` points of `[0,1]³` into rows of `out` (row `p` starts at `p · stride`, columns
    /// `0..L·F`). Levels `active..` output zero (coarse-to-fine training). With `jac`, also writes
    /// `d enc / d u` as `[point][column][axis]` (length `n · L·F · 3`), which the normal and the position
    /// gradient need.
    pub fn forward<T: Real>(
        &self,
        table: &[T],
        u: &[[T; 3]],
        active: usize,
        out: &mut [T],
        stride: usize,
        mut jac: Option<&mut [T]>,
    ) {
        let f = self.config.features;
        assert!(
            f <= MAX_FEATURES,
            "at most {MAX_FEATURES} features per level"
        );
        let width = self.config.output_dim();
        for (l, level) in self.levels.iter().enumerate() {
            let res = T::from_usize(level.resolution);
            let entries = &table[level.offset..level.offset + level.entries * f];
            for (p, x) in u.iter().enumerate() {
                // Accumulate in registers, then store once.
                let mut acc = [T::ZERO; MAX_FEATURES];
                let mut dacc = [[T::ZERO; 3]; MAX_FEATURES];
                if l < active {
                    let want_jac = jac.is_some();
                    self.cell(level, x).for_corners(|idx, w, dw| {
                        let e = &entries[idx * f..idx * f + f];
                        for k in 0..f {
                            acc[k] += w * e[k];
                            if want_jac {
                                for a in 0..3 {
                                    dacc[k][a] += dw[a] * e[k];
                                }
                            }
                        }
                    });
                }
                out[p * stride + l * f..p * stride + (l + 1) * f].copy_from_slice(&acc[..f]);
                if let Some(j) = jac.as_deref_mut() {
                    let jrow = &mut j[(p * width + l * f) * 3..(p * width + (l + 1) * f) * 3];
                    for k in 0..f {
                        for a in 0..3 {
                            jrow[k * 3 + a] = dacc[k][a] * res;
                        }
                    }
                }
            }
        }
    }

    /// Adds `Σ_points d_enc · ∂enc/∂table` to `grad` (same layout as the table), for the first `active`
    /// levels. The points come in segments `(u, d_enc)`: `d_enc` holds one row per point whose first `L·F`
    /// columns are the encoding's gradient, rows `stride` apart (so a chunk's MLP input gradient serves
    /// directly). Runs in parallel, one task per level: each task owns its level's slice of `grad`.
    pub fn backward_table<T: Real>(
        &self,
        segments: &[(&[[T; 3]], &[T])],
        stride: usize,
        active: usize,
        grad: &mut [T],
    ) {
        let mut slices = Vec::with_capacity(self.levels.len());
        let mut rest = grad;
        for level in &self.levels {
            let (head, tail) = rest.split_at_mut(level.entries * self.config.features);
            slices.push(head);
            rest = tail;
        }
        slices
            .into_par_iter()
            .enumerate()
            .take(active)
            .for_each(|(l, g)| self.backward_level(l, segments, stride, g));
    }

    /// Scatter of one level's gradient into that level's slice of the table gradient.
    fn backward_level<T: Real>(
        &self,
        l: usize,
        segments: &[(&[[T; 3]], &[T])],
        stride: usize,
        grad: &mut [T],
    ) {
        let f = self.config.features;
        let level = &self.levels[l];
        for (u, d_enc) in segments {
            for (p, x) in u.iter().enumerate() {
                let d = &d_enc[p * stride + l * f..p * stride + (l + 1) * f];
                if d.iter().all(|v| *v == T::ZERO) {
                    continue;
                }
                self.cell(level, x).for_corners(|idx, w, _| {
                    for (g, dv) in grad[idx * f..idx * f + f].iter_mut().zip(d) {
                        *g += w * *dv;
                    }
                });
            }
        }
    }

    /// The cell of `x` in a level: base vertex, fractional position and how vertices are indexed.
    #[inline(always)]
    fn cell<T: Real>(&self, level: &Level, x: &[T; 3]) -> Cell<T> {
        let res = level.resolution;
        let resf = T::from_usize(res);
        let mut base = [0u32; 3];
        let mut frac = [T::ZERO; 3];
        for a in 0..3 {
            let pos = (x[a] * resf).max(T::ZERO).min(resf);
            // `pos ≥ 0`, so truncation is the floor.
            let i = pos.to_usize().min(res - 1);
            base[a] = i as u32;
            frac[a] = pos - T::from_usize(i);
        }
        Cell {
            base,
            frac,
            dense: level.dense,
            side: (res + 1) as u32,
            mask: level.entries as u32 - 1,
        }
    }
}

/// A point's cell in one level.
struct Cell<T> {
    base: [u32; 3],
    frac: [T; 3],
    dense: bool,
    side: u32,
    mask: u32,
}

impl<T: Real> Cell<T> {
    /// Calls `visit(entry, weight, d weight / d frac)` for the 8 corners.
    #[inline(always)]
    fn for_corners(&self, mut visit: impl FnMut(usize, T, [T; 3])) {
        let [fx, fy, fz] = self.frac;
        let wx = [T::ONE - fx, fx];
        let wy = [T::ONE - fy, fy];
        let wz = [T::ONE - fz, fz];
        let sign = [-T::ONE, T::ONE];
        for c in 0..8usize {
            let (i, j, k) = (c & 1, (c >> 1) & 1, (c >> 2) & 1);
            let (x, y, z) = (
                self.base[0] + i as u32,
                self.base[1] + j as u32,
                self.base[2] + k as u32,
            );
            let idx = if self.dense {
                (x + self.side * (y + self.side * z)) as usize
            } else {
                ((x ^ y.wrapping_mul(PRIME_Y) ^ z.wrapping_mul(PRIME_Z)) & self.mask) as usize
            };
            let w = wx[i] * wy[j] * wz[k];
            let dw = [
                sign[i] * wy[j] * wz[k],
                wx[i] * sign[j] * wz[k],
                wx[i] * wy[j] * sign[k],
            ];
            visit(idx, w, dw);
        }
    }
}

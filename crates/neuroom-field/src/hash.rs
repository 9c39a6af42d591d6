//! Multiresolution hash encoding (instant-ngp), forward and backward, written by hand.
//!
//! Layout: one flat parameter vector, level-major; inside a level, entry-major (`entry · F + feature`), so
//! the `F` features of a grid vertex are adjacent. Coarse levels whose `(res + 1)³` vertices fit in the table
//! are stored densely (no collisions); finer levels are hashed with the instant-ngp primes into `T` entries.
//!
//! Speed: the hash grid, not the networks, is what limits a CPU (random reads into tables of hundreds of
//! kilobytes). So the kernels work one level at a time over as many points as the caller can give
//! ([`HashGrid::forward_level`]): one level's table then stays in L2 while the points stream past, instead of
//! all levels' tables being cycled through L2 for every point. The feature count `F` is a const generic so
//! the corner loops unroll, and trilinear interpolation is done as nested lerps, which yields the value and
//! its three partial derivatives in a few dozen operations. The table gradient is scattered by a separate
//! pass in which every rayon task owns whole levels: no atomics and no per-thread copies of the tables.

use crate::real::Real;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Shape of a hash encoding.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HashGridConfig {
    /// Number of levels `L`.
    pub levels: usize,
    /// Features per level `F`: 1, 2, 4 or 8.
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

/// Where element `(point, column)` of an encoding-shaped buffer lives: `point · point_stride + column ·
/// column_stride`. Row-major buffers have `column_stride = 1`; column-major ones `point_stride = 1`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Strides {
    /// Distance between consecutive points.
    pub point: usize,
    /// Distance between consecutive columns.
    pub column: usize,
}

impl Strides {
    /// Row-major rows of `row` values.
    pub fn rows(row: usize) -> Self {
        Self {
            point: row,
            column: 1,
        }
    }

    /// Column-major columns of `column` values.
    pub fn columns(column: usize) -> Self {
        Self { point: 1, column }
    }

    #[inline(always)]
    fn at(self, point: usize, column: usize) -> usize {
        point * self.point + column * self.column
    }
}

/// A hash encoding: the configuration plus the derived level table. Parameters live outside (see
/// [`crate::params`]) so that the same grid serves `f32` training and `f64` tests.
#[derive(Clone, Debug)]
pub struct HashGrid {
    config: HashGridConfig,
    levels: Vec<Level>,
    num_params: usize,
}

const PRIME_Y: u32 = 2_654_435_761;
const PRIME_Z: u32 = 805_459_861;

/// Calls `$body` with `$f` bound to the configuration's feature count as a constant.
macro_rules! with_features {
    ($features:expr, $f:ident => $body:expr) => {
        match $features {
            1 => {
                const $f: usize = 1;
                $body
            }
            2 => {
                const $f: usize = 2;
                $body
            }
            4 => {
                const $f: usize = 4;
                $body
            }
            8 => {
                const $f: usize = 8;
                $body
            }
            other => unreachable!("checked by HashGrid::new: {other} features"),
        }
    };
}

impl HashGrid {
    /// Derives the level table of a configuration. Panics unless `F ∈ {1, 2, 4, 8}`.
    pub fn new(config: HashGridConfig) -> Self {
        assert!(
            matches!(config.features, 1 | 2 | 4 | 8),
            "hash grid: features per level must be 1, 2, 4 or 8"
        );
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

    /// Encodes `u.len()` points of `[0,1]³` into `out` (element `(p, column)` at `strides`, columns
    /// `0..L·F`). Levels `active..` output zero (coarse-to-fine training). With `jac`, also writes
    /// `d enc / d u` as `[column][axis][point]` (length `L·F · 3 · n`), which the normal and the position
    /// gradient need.
    pub fn forward<T: Real>(
        &self,
        table: &[T],
        u: &[[T; 3]],
        active: usize,
        out: &mut [T],
        strides: Strides,
        mut jac: Option<&mut [T]>,
    ) {
        let block = u.len() * self.config.features * 3;
        for l in 0..self.levels.len() {
            let j = jac
                .as_deref_mut()
                .map(|j| &mut j[l * block..(l + 1) * block]);
            self.forward_level(l, table, u, active, out, strides, j);
        }
    }

    /// Level `l` of [`HashGrid::forward`]: writes columns `l·F..(l+1)·F` of `out` and, with `jac`, this
    /// level's part of the Jacobian (`[feature][axis][point]`, length `F · 3 · n`). Callers that encode
    /// many chunks run the levels outermost so that each level's table is read from cache.
    #[allow(clippy::too_many_arguments)] // table, points, level mask, two strided outputs
    pub fn forward_level<T: Real>(
        &self,
        l: usize,
        table: &[T],
        u: &[[T; 3]],
        active: usize,
        out: &mut [T],
        strides: Strides,
        jac: Option<&mut [T]>,
    ) {
        let f = self.config.features;
        if l >= active {
            for p in 0..u.len() {
                for k in 0..f {
                    out[strides.at(p, l * f + k)] = T::ZERO;
                }
            }
            if let Some(j) = jac {
                j.fill(T::ZERO);
            }
            return;
        }
        let level = &self.levels[l];
        let entries = &table[level.offset..level.offset + level.entries * f];
        with_features!(f, F => match jac {
            Some(j) => simd::encode::<T, F, true>(level, entries, u, out, strides, l * F, j),
            None => simd::encode::<T, F, false>(level, entries, u, out, strides, l * F, &mut []),
        })
    }

    /// Adds `Σ_points d_enc · ∂enc/∂table` to `grad` (same layout as the table), for the first `active`
    /// levels. The points come in segments `(u, d_enc)`; element `(p, column)` of a segment's `d_enc` is at
    /// `strides`. Runs in parallel, one task per level: each task owns its level's slice of `grad`.
    pub fn backward_table<T: Real>(
        &self,
        segments: &[(&[[T; 3]], &[T])],
        strides: Strides,
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
            .for_each(|(l, g)| {
                let level = &self.levels[l];
                with_features!(self.config.features, F => {
                    for (u, d_enc) in segments {
                        simd::scatter::<T, F>(level, u, d_enc, strides, l * F, g);
                    }
                })
            });
    }
}

/// The level kernels compiled for the widest vector unit the CPU has (runtime detection; the crate itself
/// is built for the baseline target). They are plain loops over structure-of-arrays, so recompiling them
/// with AVX-512 or AVX2 enabled is all it takes to vectorise them 16 or 8 lanes wide.
mod simd {
    use super::{Level, Strides, encode_level, scatter_level};
    use crate::real::Real;

    /// [`encode_level`] on the best instruction set available.
    #[allow(clippy::too_many_arguments)] // as `encode_level`
    pub(super) fn encode<T: Real, const F: usize, const JAC: bool>(
        level: &Level,
        entries: &[T],
        u: &[[T; 3]],
        out: &mut [T],
        strides: Strides,
        column: usize,
        jac: &mut [T],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has the features `encode_avx512` is compiled for.
            return unsafe {
                encode_avx512::<T, F, JAC>(level, entries, u, out, strides, column, jac)
            };
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features `encode_avx2` is compiled for.
            return unsafe {
                encode_avx2::<T, F, JAC>(level, entries, u, out, strides, column, jac)
            };
        }
        encode_level::<T, F, JAC>(level, entries, u, out, strides, column, jac)
    }

    /// [`scatter_level`] on the best instruction set available.
    pub(super) fn scatter<T: Real, const F: usize>(
        level: &Level,
        u: &[[T; 3]],
        d_enc: &[T],
        strides: Strides,
        column: usize,
        grad: &mut [T],
    ) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has the features `scatter_avx512` is compiled for.
            return unsafe { scatter_avx512::<T, F>(level, u, d_enc, strides, column, grad) };
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has the features `scatter_avx2` is compiled for.
            return unsafe { scatter_avx2::<T, F>(level, u, d_enc, strides, column, grad) };
        }
        scatter_level::<T, F>(level, u, d_enc, strides, column, grad)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,bmi1,bmi2")]
    #[allow(clippy::too_many_arguments)] // as `encode_level`
    fn encode_avx512<T: Real, const F: usize, const JAC: bool>(
        level: &Level,
        entries: &[T],
        u: &[[T; 3]],
        out: &mut [T],
        strides: Strides,
        column: usize,
        jac: &mut [T],
    ) {
        encode_level::<T, F, JAC>(level, entries, u, out, strides, column, jac)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2")]
    #[allow(clippy::too_many_arguments)] // as `encode_level`
    fn encode_avx2<T: Real, const F: usize, const JAC: bool>(
        level: &Level,
        entries: &[T],
        u: &[[T; 3]],
        out: &mut [T],
        strides: Strides,
        column: usize,
        jac: &mut [T],
    ) {
        encode_level::<T, F, JAC>(level, entries, u, out, strides, column, jac)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx512bw,avx512dq,avx2,fma,bmi1,bmi2")]
    fn scatter_avx512<T: Real, const F: usize>(
        level: &Level,
        u: &[[T; 3]],
        d_enc: &[T],
        strides: Strides,
        column: usize,
        grad: &mut [T],
    ) {
        scatter_level::<T, F>(level, u, d_enc, strides, column, grad)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,bmi1,bmi2")]
    fn scatter_avx2<T: Real, const F: usize>(
        level: &Level,
        u: &[[T; 3]],
        d_enc: &[T],
        strides: Strides,
        column: usize,
        grad: &mut [T],
    ) {
        scatter_level::<T, F>(level, u, d_enc, strides, column, grad)
    }
}

/// Points per sub-block of the level kernels: their corner indices, weights and corner values live in
/// stack arrays of this length.
const SUB: usize = 64;

/// Corner entries (corner `c` is at `+(c&1, c>>1&1, c>>2&1)`) and fractional cell positions of up to
/// [`SUB`] points in one level, stored structure-of-arrays so the loops vectorise.
struct Cells<T> {
    idx: [[u32; SUB]; 8],
    frac: [[T; SUB]; 3],
}

impl<T: Real> Cells<T> {
    fn new() -> Self {
        Self {
            idx: [[0; SUB]; 8],
            frac: [[T::ZERO; SUB]; 3],
        }
    }

    /// Fills the first `u.len() ≤ SUB` slots from the points `u` of `[0,1]³`.
    #[inline(always)]
    #[allow(clippy::needless_range_loop)] // structure-of-arrays: several arrays indexed in lockstep
    fn locate(&mut self, level: &Level, u: &[[T; 3]]) {
        let res = level.resolution as u32;
        let resf = T::from_usize(level.resolution);
        let mut base = [[0u32; SUB]; 3];
        for a in 0..3 {
            for (q, x) in u.iter().enumerate() {
                let pos = (x[a] * resf).max(T::ZERO).min(resf);
                // `pos ≥ 0`, so truncation is the floor.
                let i = pos.to_u32().min(res - 1);
                base[a][q] = i;
                self.frac[a][q] = pos - T::from_u32(i);
            }
        }
        let m = u.len();
        if level.dense {
            let side = res + 1;
            let (dy, dz) = (side, side * side);
            for q in 0..m {
                let b = base[0][q] + side * (base[1][q] + side * base[2][q]);
                for c in 0..8u32 {
                    self.idx[c as usize][q] = b + (c & 1) + ((c >> 1) & 1) * dy + (c >> 2) * dz;
                }
            }
        } else {
            let mask = level.entries as u32 - 1;
            for q in 0..m {
                let x0 = base[0][q];
                let y0 = base[1][q].wrapping_mul(PRIME_Y);
                let z0 = base[2][q].wrapping_mul(PRIME_Z);
                let (y1, z1) = (y0.wrapping_add(PRIME_Y), z0.wrapping_add(PRIME_Z));
                let ys = [y0, y1];
                let zs = [z0, z1];
                for c in 0..8usize {
                    let x = x0 + (c & 1) as u32;
                    self.idx[c][q] = (x ^ ys[(c >> 1) & 1] ^ zs[c >> 2]) & mask;
                }
            }
        }
    }
}

/// One level of the forward pass over all points (see [`HashGrid::forward_level`]). With `JAC`, `jac`
/// receives `d value / d u` as `[feature][axis][point]`. Per sub-block of [`SUB`] points: locate the cells
/// (vectorised), gather the corners (a tight loop of independent loads, so many cache misses overlap),
/// interpolate (vectorised).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // structure-of-arrays: several arrays indexed in lockstep
fn encode_level<T: Real, const F: usize, const JAC: bool>(
    level: &Level,
    entries: &[T],
    u: &[[T; 3]],
    out: &mut [T],
    strides: Strides,
    column: usize,
    jac: &mut [T],
) {
    let n = u.len();
    let res = T::from_usize(level.resolution);
    let mut cells = Cells::new();
    let mut c = [[[T::ZERO; SUB]; F]; 8];
    let mut v = [T::ZERO; SUB];
    let mut d = [[T::ZERO; SUB]; 3];
    for start in (0..n).step_by(SUB) {
        let m = SUB.min(n - start);
        cells.locate(level, &u[start..start + m]);
        for (ck, ik) in c.iter_mut().zip(&cells.idx) {
            for (q, i) in ik[..m].iter().enumerate() {
                let e = &entries[*i as usize * F..*i as usize * F + F];
                for f in 0..F {
                    ck[f][q] = e[f];
                }
            }
        }
        let [fx, fy, fz] = &cells.frac;
        for f in 0..F {
            for q in 0..m {
                // Nested lerps: along x (4 edges), then y (2), then z, carrying the partial derivatives.
                let ex: [T; 4] = std::array::from_fn(|e| c[2 * e + 1][f][q] - c[2 * e][f][q]);
                let ax: [T; 4] = std::array::from_fn(|e| c[2 * e][f][q] + fx[q] * ex[e]);
                let ay = [ax[1] - ax[0], ax[3] - ax[2]];
                let by = [ax[0] + fy[q] * ay[0], ax[2] + fy[q] * ay[1]];
                v[q] = by[0] + fz[q] * (by[1] - by[0]);
                if JAC {
                    let dx = [
                        ex[0] + fy[q] * (ex[1] - ex[0]),
                        ex[2] + fy[q] * (ex[3] - ex[2]),
                    ];
                    d[0][q] = (dx[0] + fz[q] * (dx[1] - dx[0])) * res;
                    d[1][q] = (ay[0] + fz[q] * (ay[1] - ay[0])) * res;
                    d[2][q] = (by[1] - by[0]) * res;
                }
            }
            for (q, x) in v[..m].iter().enumerate() {
                out[strides.at(start + q, column + f)] = *x;
            }
            if JAC {
                for (a, da) in d.iter().enumerate() {
                    let o = (f * 3 + a) * n + start;
                    jac[o..o + m].copy_from_slice(&da[..m]);
                }
            }
        }
    }
}

/// One level of the table gradient: `grad[corner] += weight · d_enc` for every point and corner.
#[inline(always)]
#[allow(clippy::needless_range_loop)] // structure-of-arrays: several arrays indexed in lockstep
fn scatter_level<T: Real, const F: usize>(
    level: &Level,
    u: &[[T; 3]],
    d_enc: &[T],
    strides: Strides,
    column: usize,
    grad: &mut [T],
) {
    let mut cells = Cells::new();
    let mut w = [[T::ZERO; SUB]; 8];
    let mut d = [[T::ZERO; SUB]; F];
    for start in (0..u.len()).step_by(SUB) {
        let m = SUB.min(u.len() - start);
        cells.locate(level, &u[start..start + m]);
        let [fx, fy, fz] = &cells.frac;
        for q in 0..m {
            let wx = [T::ONE - fx[q], fx[q]];
            let wy = [T::ONE - fy[q], fy[q]];
            let wz = [T::ONE - fz[q], fz[q]];
            for (k, wk) in w.iter_mut().enumerate() {
                wk[q] = wx[k & 1] * wy[(k >> 1) & 1] * wz[k >> 2];
            }
        }
        for (f, df) in d.iter_mut().enumerate() {
            for (q, x) in df[..m].iter_mut().enumerate() {
                *x = d_enc[strides.at(start + q, column + f)];
            }
        }
        for q in 0..m {
            for (ik, wk) in cells.idx.iter().zip(&w) {
                let i = ik[q] as usize * F;
                let g = &mut grad[i..i + F];
                for f in 0..F {
                    g[f] += wk[q] * d[f][q];
                }
            }
        }
    }
}

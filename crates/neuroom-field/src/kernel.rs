//! The matrix product behind the networks: `C (m × n) = A (m × k) · B (k × n)`, register-blocked for the
//! small shapes of per-chunk MLPs, with runtime CPU-feature dispatch.
//!
//! A tile keeps `MR` rows × `NC` columns of `C` in registers while it walks `k`: per step it loads one row
//! of `B` (whole vectors) and broadcasts `MR` values of `A`. There are three sets of tiles: AVX-512 (16
//! `f32` per register, 32 registers; tiles chosen by the columns left, 64, 32, then 16 at a time, so that
//! 16- and 32-wide layers do not waste lanes), AVX2 + FMA (6 rows × 16 columns, as 16 registers of 8
//! allow), and the portable generic code, which the `f64` gradient tests run. The two vector sets sum
//! every entry as the same chain of fused multiply–adds, so they give the same bits. [`Precision::Bf16`]
//! asks for the bf16 tiles (`kernel/bf16.rs`) where the CPU has AVX-512 BF16 (the `f32` ones elsewhere).

use crate::real::Real;
use serde::{Deserialize, Serialize};

#[cfg(target_arch = "x86_64")]
mod bf16;

/// The arithmetic of an `f32` product; `f64` products are always exact `f64`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// `f32` operands and accumulation.
    #[default]
    F32,
    /// Operands rounded to bfloat16 (8 bits of mantissa), products accumulated in `f32`: twice the
    /// multiply–adds per instruction where the CPU has AVX-512 BF16, plain `f32` where it has not.
    Bf16,
}

impl Precision {
    /// Whether this is the default, `f32` (serde skips the default so that configurations written
    /// before the option keep their form).
    pub fn is_f32(&self) -> bool {
        *self == Precision::F32
    }

    /// The arithmetic products asked in this precision run in on this CPU: `"bf16"` or `"f32"`.
    pub fn arithmetic(self) -> &'static str {
        if self.runs_bf16() { "bf16" } else { "f32" }
    }

    /// Whether products asked in this precision run in bf16 on this CPU.
    pub fn runs_bf16(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self == Precision::Bf16 {
            return bf16::available();
        }
        false
    }
}

/// Row padding of every right-hand operand (and of the activation buffers that become one): `B` is read
/// in whole blocks of `LANES` columns, so rows must hold `padded(n)` readable values.
pub const LANES: usize = 16;

/// `w` rounded up to a multiple of [`LANES`].
pub fn padded(w: usize) -> usize {
    w.next_multiple_of(LANES)
}

/// What `C` starts from.
#[derive(Clone, Copy, Debug)]
pub enum Init<'a, T> {
    /// Zero: `C = A · B`.
    Zero,
    /// `C`'s current values: `C += A · B`.
    Accumulate,
    /// A row broadcast to every row of `C` (a bias, `padded(n)` values): `C = bias + A · B`.
    Bias(&'a [T]),
}

/// `C = init + A · B` where `A[r][s] = a[r · a_rs + s · a_cs]`, `B[s][j] = b[s · ldb + j]` and
/// `C[r][j] = c[r · ldc + j]` for `r < m`, `j < n`, `s < k`. `B`'s rows must hold `padded(n)` readable
/// values (those past `n` only reach discarded lanes); only `C[r][..n]` is written. `precision` applies
/// to `f32` operands.
#[allow(clippy::too_many_arguments)] // three strided operands
pub fn matmul<T: Real>(
    precision: Precision,
    m: usize,
    n: usize,
    k: usize,
    a: &[T],
    a_rs: usize,
    a_cs: usize,
    b: &[T],
    ldb: usize,
    c: &mut [T],
    ldc: usize,
    init: Init<T>,
) {
    if m == 0 || n == 0 {
        return;
    }
    // These bounds make every access of the unchecked kernel below valid.
    assert!(
        k == 0 || (m - 1) * a_rs + (k - 1) * a_cs < a.len(),
        "matmul: A too small"
    );
    assert!(
        k == 0 || (k - 1) * ldb + padded(n) <= b.len(),
        "matmul: B rows must hold padded(n) values"
    );
    assert!((m - 1) * ldc + n <= c.len(), "matmul: C too small");
    if let Init::Bias(bias) = init {
        assert!(
            bias.len() >= padded(n),
            "matmul: bias must hold padded(n) values"
        );
    }
    let args = Args {
        m,
        n,
        k,
        a: a.as_ptr(),
        a_rs,
        a_cs,
        b: b.as_ptr(),
        ldb,
        c: c.as_mut_ptr(),
        ldc,
        init,
    };
    #[cfg(target_arch = "x86_64")]
    if let Some(args) = args.as_f32() {
        if precision.runs_bf16() {
            // SAFETY: the CPU has AVX-512 BF16; `args` satisfies the bounds asserted above.
            unsafe { bf16::run(&args) };
            return;
        }
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F; `args` satisfies the bounds asserted above.
            unsafe { avx512::run(&args) };
            return;
        }
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has AVX2 and FMA; `args` satisfies the bounds asserted above.
            unsafe { avx2::run(&args) };
            return;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = precision; // only the x86-64 kernels have a bf16 form
    // SAFETY: `args` satisfies the bounds asserted above.
    unsafe { run::<T>(&args) };
}

/// The operands of [`matmul`] after its bounds checks.
struct Args<'a, T> {
    m: usize,
    n: usize,
    k: usize,
    a: *const T,
    a_rs: usize,
    a_cs: usize,
    b: *const T,
    ldb: usize,
    c: *mut T,
    ldc: usize,
    init: Init<'a, T>,
}

impl<'a, T: Real> Args<'a, T> {
    /// The product cut into passes over at most `kc` of the sums' terms each, in order: the first
    /// starts `C` as `init` says, the others add to it. Every sum is the same chain of operations as
    /// in one pass (a partial sum stored in `C` and read back is the same value), so the cut leaves
    /// the bits as they are.
    fn k_blocks(&self, kc: usize) -> impl Iterator<Item = Args<'a, T>> + '_ {
        let blocks = self.k.div_ceil(kc).max(1);
        (0..blocks).map(move |i| {
            let s = i * kc;
            Args {
                m: self.m,
                n: self.n,
                k: (self.k - s).min(kc),
                // Offsets within the operands when a block's terms exist (`s < k`); the empty product
                // of `k = 0` keeps the operands' starts.
                a: self.a.wrapping_add(s * self.a_cs),
                a_rs: self.a_rs,
                a_cs: self.a_cs,
                b: self.b.wrapping_add(s * self.ldb),
                ldb: self.ldb,
                c: self.c,
                ldc: self.ldc,
                init: if i == 0 { self.init } else { Init::Accumulate },
            }
        })
    }

    /// The same operands typed as `f32`, when `T` is `f32`.
    fn as_f32(&self) -> Option<Args<'a, f32>> {
        let init = match self.init {
            Init::Zero => Init::Zero,
            Init::Accumulate => Init::Accumulate,
            Init::Bias(b) => Init::Bias(T::as_f32(b)?),
        };
        T::as_f32(&[]).map(|_: &[f32]| Args {
            m: self.m,
            n: self.n,
            k: self.k,
            a: self.a.cast(),
            a_rs: self.a_rs,
            a_cs: self.a_cs,
            b: self.b.cast(),
            ldb: self.ldb,
            c: self.c.cast(),
            ldc: self.ldc,
            init,
        })
    }
}

/// Walks `C` in column blocks of 64, 32 or 16 and row blocks of the tile height for that width.
///
/// # Safety
/// `args` satisfies [`matmul`]'s bounds.
#[inline]
unsafe fn run<T: Real>(args: &Args<T>) {
    let mut j = 0;
    while j < args.n {
        let left = args.n - j;
        // SAFETY: every block starts at a column `j < n` and reads `B` up to `j + NC ≤ padded(n)`.
        unsafe {
            if left >= 64 {
                rows::<T, 4, 64>(args, j);
                j += 64;
            } else if left >= 32 {
                rows::<T, 6, 32>(args, j);
                j += 32;
            } else {
                rows::<T, 8, 16>(args, j);
                j += 16;
            }
        }
    }
}

/// All rows of the column block starting at `j`: tiles of `MR` rows, then single rows.
///
/// # Safety
/// As [`run`], and `j + NC ≤ padded(n)`.
#[inline(always)]
unsafe fn rows<T: Real, const MR: usize, const NC: usize>(args: &Args<T>, j: usize) {
    let cols = (args.n - j).min(NC);
    let mut r = 0;
    // SAFETY: rows `r..r + MR ≤ m` and columns `j..j + NC` are inside the operands (see `matmul`).
    unsafe {
        while r + MR <= args.m {
            tile::<T, MR, NC>(args, r, j, cols);
            r += MR;
        }
        while r < args.m {
            tile::<T, 1, NC>(args, r, j, cols);
            r += 1;
        }
    }
}

/// One `MR × NC` tile of `C` at row `r`, column `j`; writes its first `cols` columns.
///
/// # Safety
/// Rows `r..r + MR` are below `m`, `j + NC ≤ padded(n)`, `cols ≤ min(NC, n - j)`, and `args` satisfies
/// [`matmul`]'s bounds.
#[inline(always)]
unsafe fn tile<T: Real, const MR: usize, const NC: usize>(
    args: &Args<T>,
    r: usize,
    j: usize,
    cols: usize,
) {
    let mut acc = [[T::ZERO; NC]; MR];
    // SAFETY (whole body): every pointer offset below stays within the bounds checked by `matmul`, given
    // the row and column ranges promised by the caller.
    unsafe {
        match args.init {
            Init::Zero => {}
            Init::Accumulate => {
                for (q, row) in acc.iter_mut().enumerate() {
                    let c = args.c.add((r + q) * args.ldc + j);
                    for (t, v) in row[..cols].iter_mut().enumerate() {
                        *v = *c.add(t);
                    }
                }
            }
            Init::Bias(bias) => {
                let b: &[T; NC] = bias[j..j + NC].try_into().expect("bias block");
                for row in acc.iter_mut() {
                    *row = *b;
                }
            }
        }
        let a = args.a.add(r * args.a_rs);
        for s in 0..args.k {
            let brow = &*(args.b.add(s * args.ldb + j) as *const [T; NC]);
            let arow = a.add(s * args.a_cs);
            for (q, row) in acc.iter_mut().enumerate() {
                let av = *arow.add(q * args.a_rs);
                for t in 0..NC {
                    row[t] += av * brow[t];
                }
            }
        }
        for (q, row) in acc.iter().enumerate() {
            let c = args.c.add((r + q) * args.ldc + j);
            for (t, v) in row[..cols].iter().enumerate() {
                *c.add(t) = *v;
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx512 {
    //! The `f32` AVX-512 tiles: `MR` rows × `NV` registers of 16 columns.

    use super::{Args, Init};
    use std::arch::x86_64::*;

    /// As [`super::run`], for `f32` with AVX-512.
    ///
    /// # Safety
    /// The CPU has AVX-512F; `args` satisfies [`super::matmul`]'s bounds.
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn run(args: &Args<f32>) {
        let mut j = 0;
        while j < args.n {
            let left = args.n - j;
            // SAFETY: every block starts at a column `j < n` and reads `B` up to `j + 16·NV ≤ padded(n)`.
            unsafe {
                if left >= 64 {
                    rows::<4, 4>(args, j);
                    j += 64;
                } else if left >= 32 {
                    rows::<6, 2>(args, j);
                    j += 32;
                } else {
                    rows::<8, 1>(args, j);
                    j += 16;
                }
            }
        }
    }

    /// # Safety
    /// As [`run`], and `j + 16·NV ≤ padded(n)`.
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn rows<const MR: usize, const NV: usize>(args: &Args<f32>, j: usize) {
        let cols = (args.n - j).min(16 * NV);
        let mut r = 0;
        // SAFETY: rows `r..r + MR ≤ m`, columns as promised by the caller.
        unsafe {
            while r + MR <= args.m {
                tile::<MR, NV>(args, r, j, cols);
                r += MR;
            }
            while r < args.m {
                tile::<1, NV>(args, r, j, cols);
                r += 1;
            }
        }
    }

    /// Mask of the first `live ≤ 16` lanes.
    #[inline(always)]
    pub(super) fn prefix(live: usize) -> __mmask16 {
        ((1u32 << live) - 1) as __mmask16
    }

    /// Lane mask of the first `cols - 16·v` lanes of register `v` (all, none or a prefix).
    #[inline(always)]
    fn mask(cols: usize, v: usize) -> __mmask16 {
        prefix(cols.saturating_sub(16 * v).min(16))
    }

    /// The sums of an `MR × 16·NV` tile of `C` at row `r`, column `j` as `args.init` starts them: zero,
    /// `C`'s first `cols` columns (masked), or the bias. Shared by the `f32` and bf16 tiles.
    ///
    /// # Safety
    /// As [`tile`].
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(super) unsafe fn start<const MR: usize, const NV: usize>(
        args: &Args<f32>,
        r: usize,
        j: usize,
        cols: usize,
    ) -> [[__m512; NV]; MR] {
        let mut acc = [[_mm512_setzero_ps(); NV]; MR];
        // SAFETY: rows and columns as the caller promises; `C` is read through masks of its first
        // `cols` columns, the bias holds `padded(n)` values.
        unsafe {
            match args.init {
                Init::Zero => {}
                Init::Accumulate => {
                    for (q, row) in acc.iter_mut().enumerate() {
                        let c = args.c.add((r + q) * args.ldc + j);
                        for (v, x) in row.iter_mut().enumerate() {
                            *x = _mm512_maskz_loadu_ps(mask(cols, v), c.add(16 * v));
                        }
                    }
                }
                Init::Bias(bias) => {
                    for row in acc.iter_mut() {
                        for (v, x) in row.iter_mut().enumerate() {
                            *x = _mm512_loadu_ps(bias.as_ptr().add(j + 16 * v));
                        }
                    }
                }
            }
        }
        acc
    }

    /// Writes the tile's sums to `C`'s first `cols` columns (masked).
    ///
    /// # Safety
    /// As [`tile`].
    #[target_feature(enable = "avx512f")]
    #[inline]
    pub(super) unsafe fn store<const MR: usize, const NV: usize>(
        args: &Args<f32>,
        acc: &[[__m512; NV]; MR],
        r: usize,
        j: usize,
        cols: usize,
    ) {
        for (q, row) in acc.iter().enumerate() {
            // SAFETY: row `r + q < m`; the stores are masked to the first `cols` columns.
            unsafe {
                let c = args.c.add((r + q) * args.ldc + j);
                for (v, x) in row.iter().enumerate() {
                    _mm512_mask_storeu_ps(c.add(16 * v), mask(cols, v), *x);
                }
            }
        }
    }

    /// One `MR × 16·NV` tile of `C` at row `r`, column `j`; only the first `cols` columns are read from
    /// and written to `C` (masked). `B` is read in whole registers.
    ///
    /// # Safety
    /// Rows `r..r + MR` are below `m`; `j + 16·NV ≤ padded(n)`, so `B`'s rows are readable that far.
    #[target_feature(enable = "avx512f")]
    #[inline]
    unsafe fn tile<const MR: usize, const NV: usize>(
        args: &Args<f32>,
        r: usize,
        j: usize,
        cols: usize,
    ) {
        // SAFETY (whole body): offsets stay within the operands by `matmul`'s bounds and the caller's
        // promises; `C` is only touched through masks of its first `cols` columns.
        unsafe {
            let mut acc = start::<MR, NV>(args, r, j, cols);
            let mut bv = [_mm512_setzero_ps(); NV];
            for s in 0..args.k {
                let bp = args.b.add(s * args.ldb + j);
                for (v, x) in bv.iter_mut().enumerate() {
                    *x = _mm512_loadu_ps(bp.add(16 * v));
                }
                let ap = args.a.add(r * args.a_rs + s * args.a_cs);
                for (q, row) in acc.iter_mut().enumerate() {
                    let av = _mm512_set1_ps(*ap.add(q * args.a_rs));
                    for (x, b) in row.iter_mut().zip(&bv) {
                        *x = _mm512_fmadd_ps(av, *b, *x);
                    }
                }
            }
            store(args, &acc, r, j, cols);
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    //! The `f32` AVX2 + FMA tiles: 6 rows × 16 columns (two registers of 8), the widest tile whose sums,
    //! the `B` row and the broadcast fit the 16 registers. Every sum is the same chain of fused
    //! multiply–adds over `k` as in the AVX-512 tiles, so both give the same bits.

    use super::{Args, Init};
    use std::arch::x86_64::*;

    /// Rows of a tile.
    const MR: usize = 6;
    /// Registers of 8 columns across a tile.
    const NV: usize = 2;

    /// As [`super::run`], for `f32` with AVX2 and FMA.
    ///
    /// # Safety
    /// The CPU has AVX2 and FMA; `args` satisfies [`super::matmul`]'s bounds.
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn run(args: &Args<f32>) {
        for block in args.k_blocks(KC) {
            // SAFETY: each block is a part of the operands `args` bounds.
            unsafe { run_block(&block) };
        }
    }

    /// Terms of the sums taken per pass over `C`: a block of `A`'s columns and `B`'s rows this long
    /// stays in the first-level cache while every tile of `C` reads it (a weight gradient sums over
    /// a whole chunk of points, whose operands would not).
    const KC: usize = 64;

    /// [`run`] for one block of the sums' terms.
    ///
    /// # Safety
    /// As [`run`].
    #[target_feature(enable = "avx2,fma")]
    unsafe fn run_block(args: &Args<f32>) {
        let mut j = 0;
        while j < args.n {
            let cols = (args.n - j).min(8 * NV);
            let mut r = 0;
            // SAFETY: a block starts at a column `j < n` and reads `B` up to `j + 16 ≤ padded(n)`;
            // rows `r..r + rows ≤ m`.
            unsafe {
                while r + MR <= args.m {
                    tile::<MR>(args, r, j, cols);
                    r += MR;
                }
                // The last rows in one tile of their height: single rows would each wait on their
                // own chain of fused multiply–adds.
                match args.m - r {
                    5 => tile::<5>(args, r, j, cols),
                    4 => tile::<4>(args, r, j, cols),
                    3 => tile::<3>(args, r, j, cols),
                    2 => tile::<2>(args, r, j, cols),
                    1 => tile::<1>(args, r, j, cols),
                    _ => {}
                }
            }
            j += 8 * NV;
        }
    }

    /// Mask of the lanes of register `v` that hold one of the first `cols` columns.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn mask(cols: usize, v: usize) -> __m256i {
        let live = cols.saturating_sub(8 * v).min(8) as i32;
        _mm256_cmpgt_epi32(
            _mm256_set1_epi32(live),
            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
        )
    }

    /// One `ROWS × 16` tile of `C` at row `r`, column `j`; only the first `cols` columns are read from
    /// and written to `C`. `B` is read in whole registers.
    ///
    /// # Safety
    /// Rows `r..r + ROWS` are below `m`; `j + 16 ≤ padded(n)`, so `B`'s rows are readable that far.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    unsafe fn tile<const ROWS: usize>(args: &Args<f32>, r: usize, j: usize, cols: usize) {
        let masks = [mask(cols, 0), mask(cols, 1)];
        // Masked loads and stores take several micro-operations on some CPUs (AMD's): a tile of whole
        // 16 columns reads and writes `C` plainly.
        let whole = cols == 8 * NV;
        let mut acc = [[_mm256_setzero_ps(); NV]; ROWS];
        // SAFETY (whole body): offsets stay within the operands by `matmul`'s bounds and the caller's
        // promises; `C` is only touched in its first `cols` columns (masked unless all 16 are).
        unsafe {
            match args.init {
                Init::Zero => {}
                Init::Accumulate => {
                    for (q, row) in acc.iter_mut().enumerate() {
                        let c = args.c.add((r + q) * args.ldc + j);
                        for (v, x) in row.iter_mut().enumerate() {
                            *x = if whole {
                                _mm256_loadu_ps(c.add(8 * v))
                            } else {
                                _mm256_maskload_ps(c.add(8 * v), masks[v])
                            };
                        }
                    }
                }
                Init::Bias(bias) => {
                    for row in acc.iter_mut() {
                        for (v, x) in row.iter_mut().enumerate() {
                            *x = _mm256_loadu_ps(bias.as_ptr().add(j + 8 * v));
                        }
                    }
                }
            }
            for s in 0..args.k {
                let bp = args.b.add(s * args.ldb + j);
                let bv = [_mm256_loadu_ps(bp), _mm256_loadu_ps(bp.add(8))];
                let ap = args.a.add(r * args.a_rs + s * args.a_cs);
                for (q, row) in acc.iter_mut().enumerate() {
                    let av = _mm256_set1_ps(*ap.add(q * args.a_rs));
                    for (x, b) in row.iter_mut().zip(&bv) {
                        *x = _mm256_fmadd_ps(av, *b, *x);
                    }
                }
            }
            for (q, row) in acc.iter().enumerate() {
                let c = args.c.add((r + q) * args.ldc + j);
                for (v, x) in row.iter().enumerate() {
                    if whole {
                        _mm256_storeu_ps(c.add(8 * v), *x);
                    } else {
                        _mm256_maskstore_ps(c.add(8 * v), masks[v], *x);
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Products `(m, n, k)` that reach every kind of tile: whole and partial column blocks, row
    /// remainders of 1 to 5, and sums cut into passes of terms.
    const TILE_SHAPES: [(usize, usize, usize); 7] = [
        (13, 16, 9),
        (9, 35, 66),
        (37, 64, 35),
        (5, 97, 4),
        (10, 32, 7),
        (8, 17, 3),
        (7, 20, 150),
    ];

    /// The dispatched kernel (AVX-512 or AVX2 on this machine) against a plain triple loop, over widths
    /// that exercise every tile shape, row tails, odd `k`, row-major and column-major `A` and all three
    /// initialisations; in bf16 within the rounding of its operands (2⁻⁸ of each product, relative).
    #[test]
    fn matmul_matches_reference() {
        let mut seed = 1u32;
        let mut next = || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32 - 0.5
        };
        for precision in [Precision::F32, Precision::Bf16] {
            for &(m, n, k) in [(1, 1, 1), (7, 3, 5)].iter().chain(&TILE_SHAPES) {
                // Column-major A with padding, then row-major A with padding.
                for (a_rs, a_cs) in [(1, m + 2), (k + 3, 1)] {
                    let a: Vec<f32> = (0..(m + 1) * (k + 3) + (k + 1) * (m + 2))
                        .map(|_| next())
                        .collect();
                    let ldb = padded(n) + 16;
                    let b: Vec<f32> = (0..k * ldb).map(|_| next()).collect();
                    let bias: Vec<f32> = (0..padded(n)).map(|_| next()).collect();
                    let ldc = n + 3;
                    let c0: Vec<f32> = (0..m * ldc).map(|_| next()).collect();
                    for init in [Init::Zero, Init::Accumulate, Init::Bias(&bias)] {
                        let mut c = c0.clone();
                        matmul(
                            precision, m, n, k, &a, a_rs, a_cs, &b, ldb, &mut c, ldc, init,
                        );
                        for r in 0..m {
                            for j in 0..ldc {
                                let (expect, scale) = if j >= n {
                                    (c0[r * ldc + j], 0.0)
                                } else {
                                    let start = match init {
                                        Init::Zero => 0.0,
                                        Init::Accumulate => c0[r * ldc + j],
                                        Init::Bias(b) => b[j],
                                    };
                                    let terms =
                                        (0..k).map(|s| a[r * a_rs + s * a_cs] * b[s * ldb + j]);
                                    let scale: f32 = terms.clone().map(f32::abs).sum();
                                    (start + terms.sum::<f32>(), scale)
                                };
                                let tolerance = match precision {
                                    Precision::F32 => 1e-4,
                                    Precision::Bf16 => 1e-4 + scale / 128.0,
                                };
                                let got = c[r * ldc + j];
                                assert!(
                                    (got - expect).abs() < tolerance,
                                    "{precision:?} ({m},{n},{k}) A ({a_rs},{a_cs}) [{r}][{j}]: {got} vs {expect}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// The AVX-512 and the AVX2 tiles give the same bits: each sum is the chain of fused multiply–adds
    /// over `k` from its start value, whatever the tile shape, so a model trains alike on either CPU.
    #[test]
    fn vector_tiles_sum_as_one_chain_of_fused_multiply_adds() {
        #[cfg(target_arch = "x86_64")]
        let vector = std::arch::is_x86_feature_detected!("avx512f")
            || (std::arch::is_x86_feature_detected!("avx2")
                && std::arch::is_x86_feature_detected!("fma"));
        #[cfg(not(target_arch = "x86_64"))]
        let vector = false;
        if !vector {
            eprintln!("no AVX-512 or AVX2 + FMA on this CPU: the portable kernel does not fuse");
            return;
        }
        let value = |i: usize| ((i * 7919 % 1000) as f32 - 500.0) / 317.0;
        for &(m, n, k) in &TILE_SHAPES {
            let a: Vec<f32> = (0..m * k).map(value).collect();
            let ldb = padded(n);
            let b: Vec<f32> = (0..k * ldb).map(|i| value(i + 31)).collect();
            let bias: Vec<f32> = (0..ldb).map(|i| value(i + 7)).collect();
            let mut c = vec![0.0f32; m * n];
            matmul(
                Precision::F32,
                m,
                n,
                k,
                &a,
                k,
                1,
                &b,
                ldb,
                &mut c,
                n,
                Init::Bias(&bias),
            );
            for r in 0..m {
                for j in 0..n {
                    let chain =
                        (0..k).fold(bias[j], |acc, s| a[r * k + s].mul_add(b[s * ldb + j], acc));
                    assert_eq!(
                        c[r * n + j].to_bits(),
                        chain.to_bits(),
                        "({m},{n},{k}) [{r}][{j}]"
                    );
                }
            }
        }
    }

    /// On a CPU with AVX-512 BF16 the bf16 kernel really rounds: a product that `f32` keeps exactly
    /// differs in bf16. (Elsewhere `Bf16` runs the `f32` kernel and this test has nothing to check.)
    #[test]
    fn bf16_rounds_its_operands() {
        if !Precision::Bf16.runs_bf16() {
            eprintln!("no AVX-512 BF16 on this CPU: the bf16 kernel is not run");
            return;
        }
        let a = [1.0 + 1.0 / 1024.0];
        let b = vec![1.0f32; LANES];
        let mut c = [0.0f32];
        matmul(
            Precision::Bf16,
            1,
            1,
            1,
            &a,
            1,
            1,
            &b,
            LANES,
            &mut c,
            1,
            Init::Zero,
        );
        assert_eq!(c[0], 1.0);
        matmul(
            Precision::F32,
            1,
            1,
            1,
            &a,
            1,
            1,
            &b,
            LANES,
            &mut c,
            1,
            Init::Zero,
        );
        assert_eq!(c[0], a[0]);
    }
}

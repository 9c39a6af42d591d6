//! The `bf16` AVX-512 tiles: operands rounded to bfloat16, products accumulated in `f32`.
//!
//! `vdpbf16ps` multiplies 16 pairs of bf16 values per register and adds both products of a pair to one
//! `f32` lane, so it walks `k` two steps at a time: both operands are first copied into *pair* layouts,
//! one `u32` per (row, pair of `k` steps) holding the two bf16 values, low half first. `B` becomes
//! `⌈k/2⌉` rows of `padded(n)` pairs (a register reads 16 columns' pairs); `A` becomes pairs addressed
//! by `row · row_stride + pair · pair_stride`, in whichever order its source is contiguous. An odd `k`
//! pads its last pair with zero. Rounding is to nearest even (`vcvtne2ps2bf16`).

use super::avx512::{prefix, start, store};
use super::{Args, padded};
use std::arch::x86_64::*;
use std::cell::RefCell;

/// Whether this CPU runs the kernel: AVX-512F, BW (the pair interleave) and BF16.
pub(super) fn available() -> bool {
    std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512bw")
        && std::arch::is_x86_feature_detected!("avx512bf16")
}

/// A pair layout of one operand: `data[row · row_stride + pair · pair_stride]`.
#[derive(Default)]
struct Pairs {
    data: Vec<u32>,
    row_stride: usize,
    pair_stride: usize,
}

thread_local! {
    /// The pair layouts of `A` and `B`, reused by every product on this thread.
    static SCRATCH: RefCell<(Pairs, Pairs)> = RefCell::default();
}

/// As [`super::run`], in bf16 with `f32` accumulation.
///
/// # Safety
/// [`available`] holds; `args` satisfies [`super::matmul`]'s bounds.
pub(super) unsafe fn run(args: &Args<f32>) {
    SCRATCH.with_borrow_mut(|(a, b)| {
        // SAFETY: as this function's contract.
        unsafe {
            pack_a(args, a);
            pack_b(args, b);
            products(args, a, b);
        }
    });
}

/// `A`'s pairs: along each row when `A` is contiguous along `k` (rows of activations), else across pairs
/// of its `k` steps (a transposed operand, contiguous along the rows).
///
/// # Safety
/// As [`run`].
#[target_feature(enable = "avx512f,avx512bw,avx512bf16")]
unsafe fn pack_a(args: &Args<f32>, out: &mut Pairs) {
    let pairs = args.k.div_ceil(2);
    // SAFETY: the source offsets are those `matmul`'s bounds check; the output is sized here.
    unsafe {
        if args.a_cs == 1 {
            let stride = padded(args.k) / 2;
            out.data.resize(args.m * stride, 0);
            for r in 0..args.m {
                let row = args.a.add(r * args.a_rs);
                let dst = out.data.as_mut_ptr().add(r * stride);
                for s0 in (0..args.k).step_by(16) {
                    let live = (args.k - s0).min(16);
                    let v = _mm512_maskz_loadu_ps(prefix(live), row.add(s0));
                    let h = _mm512_cvtneps_pbh(v);
                    let h = std::mem::transmute::<__m256bh, __m256i>(h);
                    _mm256_storeu_si256(dst.add(s0 / 2).cast(), h);
                }
            }
            out.row_stride = stride;
            out.pair_stride = 1;
        } else {
            let width = padded(args.m);
            out.data.resize(pairs * width, 0);
            interleave(
                args.a,
                args.m,
                args.k,
                args.a_cs,
                args.a_rs,
                &mut out.data,
                width,
            );
            out.row_stride = 1;
            out.pair_stride = width;
        }
    }
}

/// `B`'s pairs: `⌈k/2⌉` rows of `padded(n)` pairs.
///
/// # Safety
/// As [`run`].
#[target_feature(enable = "avx512f,avx512bw,avx512bf16")]
unsafe fn pack_b(args: &Args<f32>, out: &mut Pairs) {
    let width = padded(args.n);
    out.data.resize(args.k.div_ceil(2) * width, 0);
    // SAFETY: `B`'s rows hold `padded(n)` readable values (`matmul`'s bounds).
    unsafe { interleave(args.b, width, args.k, args.ldb, 1, &mut out.data, width) };
    out.row_stride = 1;
    out.pair_stride = width;
}

/// Writes `dst[s · width + x] = (src[2s · step + x · lane], src[(2s+1) · step + x · lane])` as bf16 for
/// `x < columns`, `s < ⌈steps/2⌉`: two source lines per output line, interleaved.
///
/// # Safety
/// Every `src` offset named above for `2s, 2s+1 < steps` is readable; `dst` holds `⌈steps/2⌉ · width`
/// values and `columns ≤ width`, `width` a multiple of 16.
#[target_feature(enable = "avx512f,avx512bw,avx512bf16")]
unsafe fn interleave(
    src: *const f32,
    columns: usize,
    steps: usize,
    step: usize,
    lane: usize,
    dst: &mut [u32],
    width: usize,
) {
    // Output lane 2i takes bf16 i (the first line), lane 2i+1 takes bf16 16+i (the second line).
    let order = _mm512_set_epi16(
        31, 15, 30, 14, 29, 13, 28, 12, 27, 11, 26, 10, 25, 9, 24, 8, 23, 7, 22, 6, 21, 5, 20, 4,
        19, 3, 18, 2, 17, 1, 16, 0,
    );
    // SAFETY: reads as promised by the caller, masked to `columns`; writes inside `dst`.
    unsafe {
        for s in 0..steps.div_ceil(2) {
            let first = src.add(2 * s * step);
            let second = (2 * s + 1 < steps).then(|| src.add((2 * s + 1) * step));
            for x0 in (0..width).step_by(16) {
                let live = columns.saturating_sub(x0).min(16);
                let lo = load(first, x0, lane, live);
                let hi = second.map_or(_mm512_setzero_ps(), |p| load(p, x0, lane, live));
                let both: __m512i = std::mem::transmute(_mm512_cvtne2ps_pbh(hi, lo));
                let pairs = _mm512_permutexvar_epi16(order, both);
                _mm512_storeu_si512(dst.as_mut_ptr().add(s * width + x0).cast(), pairs);
            }
        }
    }
}

/// 16 values `line[(x0 + t) · lane]`, `t < live`, zero beyond.
///
/// # Safety
/// Those offsets are readable.
#[target_feature(enable = "avx512f")]
#[inline]
unsafe fn load(line: *const f32, x0: usize, lane: usize, live: usize) -> __m512 {
    // SAFETY: as the caller promises.
    unsafe {
        if lane == 1 {
            _mm512_maskz_loadu_ps(prefix(live), line.add(x0))
        } else {
            let mut v = [0.0f32; 16];
            for (t, x) in v[..live].iter_mut().enumerate() {
                *x = *line.add((x0 + t) * lane);
            }
            _mm512_loadu_ps(v.as_ptr())
        }
    }
}

/// Walks `C` in column blocks of 64, 32 or 16 as the `f32` kernel does, with taller tiles for the
/// narrower blocks (8 and 16 rows): a bf16 step has half the instructions of an `f32` one, so more
/// independent sums are needed to keep `vdpbf16ps` busy.
///
/// # Safety
/// As [`run`], with `a` and `b` packed from `args`.
#[target_feature(enable = "avx512f,avx512bf16")]
unsafe fn products(args: &Args<f32>, a: &Pairs, b: &Pairs) {
    let mut j = 0;
    while j < args.n {
        let left = args.n - j;
        // SAFETY: blocks stay inside `padded(n)` columns of the packed `B`.
        unsafe {
            if left >= 64 {
                rows::<4, 4>(args, a, b, j);
                j += 64;
            } else if left >= 32 {
                rows::<8, 2>(args, a, b, j);
                j += 32;
            } else {
                rows::<16, 1>(args, a, b, j);
                j += 16;
            }
        }
    }
}

/// # Safety
/// As [`products`], and `j + 16·NV ≤ padded(n)`.
#[target_feature(enable = "avx512f,avx512bf16")]
#[inline]
unsafe fn rows<const MR: usize, const NV: usize>(args: &Args<f32>, a: &Pairs, b: &Pairs, j: usize) {
    let cols = (args.n - j).min(16 * NV);
    let mut r = 0;
    // SAFETY: rows `r..r + MR ≤ m`, columns as promised by the caller.
    unsafe {
        while r + MR <= args.m {
            tile::<MR, NV>(args, a, b, r, j, cols);
            r += MR;
        }
        while r < args.m {
            tile::<1, NV>(args, a, b, r, j, cols);
            r += 1;
        }
    }
}

/// One `MR × 16·NV` tile of `C` at row `r`, column `j`, two `k` steps per instruction.
///
/// # Safety
/// As [`rows`], and rows `r..r + MR` are below `m`.
#[target_feature(enable = "avx512f,avx512bf16")]
#[inline]
unsafe fn tile<const MR: usize, const NV: usize>(
    args: &Args<f32>,
    a: &Pairs,
    b: &Pairs,
    r: usize,
    j: usize,
    cols: usize,
) {
    // SAFETY (whole body): the packed operands hold every pair read; `C` and the bias are touched by
    // the `f32` kernel's `start` and `store`, under the same promises.
    unsafe {
        let mut acc = start::<MR, NV>(args, r, j, cols);
        let (ap, bp) = (a.data.as_ptr(), b.data.as_ptr());
        let mut bv = [_mm512_setzero_si512(); NV];
        for s in 0..args.k.div_ceil(2) {
            let brow = bp.add(s * b.pair_stride + j);
            for (v, x) in bv.iter_mut().enumerate() {
                *x = _mm512_loadu_si512(brow.add(16 * v).cast());
            }
            let arow = ap.add(r * a.row_stride + s * a.pair_stride);
            for (q, row) in acc.iter_mut().enumerate() {
                let av: __m512bh =
                    std::mem::transmute(_mm512_set1_epi32(*arow.add(q * a.row_stride) as i32));
                for (x, bw) in row.iter_mut().zip(&bv) {
                    *x = _mm512_dpbf16_ps(*x, av, std::mem::transmute::<__m512i, __m512bh>(*bw));
                }
            }
        }
        store(args, &acc, r, j, cols);
    }
}

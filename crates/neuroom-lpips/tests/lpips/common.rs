//! Helpers shared by the integration tests: the deterministic test images of `tools/setup_lpips.py` and
//! weight files of random values.

use std::collections::HashMap;
use std::f64::consts::PI;
use std::path::Path;

use neuroom_core::image::RgbImage;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use safetensors::{Dtype, tensor::TensorView};

/// Integer hash "lowbias32" (C. Wellons), as `hash_u32` in the setup script.
fn hash_u32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7FEB_352D);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846C_A68B);
    x ^ (x >> 16)
}

/// The setup script's `test_image`: from `[contrast, shift, noise amplitude, noise seed]`,
/// clamp(0.5 + contrast (scene − 0.5) + amplitude (2 noise − 1), 0, 1) of a smooth, checkered scene.
pub fn test_image(width: u32, height: u32, spec: [f64; 4]) -> RgbImage {
    let [contrast, shift, amplitude, seed] = spec;
    let (w, h) = (f64::from(width), f64::from(height));
    let mut image = RgbImage::filled(width, height, [0.0; 3]);
    for v in 0..height {
        let y = f64::from(v) + 0.5;
        for u in 0..width {
            let x = f64::from(u) + 0.5 + shift;
            let checker = if ((x / 16.0).floor() + (y / 16.0).floor()).rem_euclid(2.0) == 0.0 {
                1.0
            } else {
                -1.0
            };
            let pixel = std::array::from_fn(|c| {
                let cf = c as f64;
                let scene = 0.5
                    + 0.3
                        * (2.0 * PI * (3.0 * x / w + cf / 4.0)).sin()
                        * (2.0 * PI * (2.0 * y / h - 0.15 * cf)).cos()
                    + 0.15 * (0.21 * x + 0.13 * y + cf).sin()
                    + 0.1 * checker;
                let index = (3 * (v * width + u) + c as u32)
                    .wrapping_add((seed as u32).wrapping_mul(0x9E37_79B9));
                let noise = f64::from(hash_u32(index)) / 2f64.powi(32);
                (0.5 + contrast * (scene - 0.5) + amplitude * (2.0 * noise - 1.0)).clamp(0.0, 1.0)
                    as f32
            });
            image.set(u, v, pixel);
        }
    }
    image
}

/// Name and shape of every tensor in a weight file.
pub const TENSORS: [(&str, &[usize]); 15] = [
    ("conv1.weight", &[64, 3, 11, 11]),
    ("conv1.bias", &[64]),
    ("conv2.weight", &[192, 64, 5, 5]),
    ("conv2.bias", &[192]),
    ("conv3.weight", &[384, 192, 3, 3]),
    ("conv3.bias", &[384]),
    ("conv4.weight", &[256, 384, 3, 3]),
    ("conv4.bias", &[256]),
    ("conv5.weight", &[256, 256, 3, 3]),
    ("conv5.bias", &[256]),
    ("lin1.weight", &[1, 64, 1, 1]),
    ("lin2.weight", &[1, 192, 1, 1]),
    ("lin3.weight", &[1, 384, 1, 1]),
    ("lin4.weight", &[1, 256, 1, 1]),
    ("lin5.weight", &[1, 256, 1, 1]),
];

/// Random float32 tensors for `shapes`: conv weights uniform with variance 2 / fan-in (He), biases small,
/// linear weights in [0, 1) (LPIPS keeps them non-negative).
pub fn random_tensors(
    shapes: &[(&str, &[usize])],
    seed: u64,
) -> Vec<(String, Vec<usize>, Vec<f32>)> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let tensors = shapes.iter().map(|(name, shape)| {
        let n: usize = shape.iter().product();
        let fan_in: usize = shape.iter().skip(1).product();
        let bound = if name.starts_with("lin") {
            1.0
        } else {
            (6.0 / fan_in.max(1) as f32).sqrt()
        };
        let values = (0..n).map(|_| match *name {
            n if n.starts_with("lin") => rng.random_range(0.0..bound),
            n if n.ends_with("bias") => rng.random_range(-0.1..0.1),
            _ => rng.random_range(-bound..bound),
        });
        (name.to_string(), shape.to_vec(), values.collect())
    });
    tensors.collect()
}

/// Writes `tensors` as a float32 safetensors file.
pub fn write_tensors(path: &Path, tensors: &[(String, Vec<usize>, Vec<f32>)]) {
    let bytes: Vec<Vec<u8>> = tensors
        .iter()
        .map(|(_, _, v)| v.iter().flat_map(|x| x.to_le_bytes()).collect())
        .collect();
    let views: HashMap<String, TensorView> = tensors
        .iter()
        .zip(&bytes)
        .map(|((name, shape, _), b)| {
            (
                name.clone(),
                TensorView::new(Dtype::F32, shape.clone(), b).unwrap(),
            )
        })
        .collect();
    safetensors::serialize_to_file(views, None, path).unwrap();
}

/// A complete weight file of random values.
pub fn write_random_weights(path: &Path, seed: u64) {
    write_tensors(path, &random_tensors(&TENSORS, seed));
}

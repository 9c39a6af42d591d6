//! The identification network: a small fully convolutional encoder–decoder over the panorama and the
//! empty room at the same camera (6 channels: the room is known, so what differs from it matters),
//! with circular padding across the panorama's seam, whose output is per-pixel logits over the
//! background and one class per object model.
//!
//! Two 3×3 convolutions at full resolution, a stride-2 convolution and one more at half, a stride-2
//! convolution and two dilated ones (dilation 2 and 4) at a quarter, then nearest upsampling with skip
//! connections back to full resolution and a 1×1 convolution to the logits. The weights live on the
//! host ([`Weights`]): burn builds tensors from them for each pass, which keeps the optimiser, storage
//! and checkpoints plain and exact.

use burn::tensor::activation::relu;
use burn::tensor::module::{conv2d, interpolate};
use burn::tensor::ops::{ConvOptions, InterpolateMode, InterpolateOptions};
use burn::tensor::{Device, Tensor, TensorData};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

/// Input channels: the panorama's and the empty room's sRGB.
pub const INPUT_CHANNELS: usize = 6;

/// Shape of the network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct NetConfig {
    /// Classes: background + one per object model.
    pub classes: usize,
    /// Working width (height is half); a multiple of 4.
    pub width: usize,
    /// Channels at full, half and quarter resolution.
    pub channels: [usize; 3],
}

impl NetConfig {
    /// The default network for `models` object models at 128 × 64.
    pub fn new(models: usize) -> Self {
        Self {
            classes: models + 1,
            width: 128,
            channels: [16, 32, 48],
        }
    }

    /// Working height.
    pub fn height(&self) -> usize {
        self.width / 2
    }

    /// The convolutions, in the order of the forward pass.
    pub fn layers(&self) -> Vec<LayerSpec> {
        let [c1, c2, c3] = self.channels;
        let conv = |name: &str, inputs, outputs, stride, dilation| LayerSpec {
            name: name.to_string(),
            inputs,
            outputs,
            kernel: 3,
            stride,
            dilation,
        };
        vec![
            conv("enc1a", INPUT_CHANNELS, c1, 1, 1),
            conv("enc1b", c1, c1, 1, 1),
            conv("enc2a", c1, c2, 2, 1),
            conv("enc2b", c2, c2, 1, 1),
            conv("enc3a", c2, c3, 2, 1),
            conv("enc3b", c3, c3, 1, 2),
            conv("enc3c", c3, c3, 1, 4),
            conv("dec2", c3 + c2, c2, 1, 1),
            conv("dec1", c2 + c1, c1, 1, 1),
            LayerSpec {
                name: "logits".to_string(),
                inputs: c1,
                outputs: self.classes,
                kernel: 1,
                stride: 1,
                dilation: 1,
            },
        ]
    }

    /// Whether the shape is one the forward pass supports.
    pub fn check(&self) -> Result<(), String> {
        if self.classes < 2 || self.classes > 255 {
            return Err(format!("classes must be 2 to 255, found {}", self.classes));
        }
        // A quarter of the width must hold the dilated layers' circular padding (4 columns).
        if self.width < 32 || !self.width.is_multiple_of(8) {
            return Err(format!(
                "width must be a multiple of 8 of at least 32, found {}",
                self.width
            ));
        }
        if self.channels.contains(&0) {
            return Err("channel counts must be positive".to_string());
        }
        Ok(())
    }
}

/// One convolution: `outputs × inputs × kernel × kernel` weights and `outputs` biases.
#[derive(Clone, Debug, PartialEq)]
pub struct LayerSpec {
    /// Name (tensor names in files are `<name>.weight` and `<name>.bias`).
    pub name: String,
    /// Input channels.
    pub inputs: usize,
    /// Output channels.
    pub outputs: usize,
    /// Kernel size (square).
    pub kernel: usize,
    /// Stride.
    pub stride: usize,
    /// Dilation.
    pub dilation: usize,
}

impl LayerSpec {
    /// Shape of the weight tensor.
    pub fn weight_shape(&self) -> [usize; 4] {
        [self.outputs, self.inputs, self.kernel, self.kernel]
    }

    /// Number of weights.
    pub fn weight_len(&self) -> usize {
        self.weight_shape().iter().product()
    }
}

/// Host copy of every layer's parameters, in [`NetConfig::layers`] order: weights then bias.
#[derive(Clone, Debug, PartialEq)]
pub struct Weights {
    /// Per layer: (weights, biases).
    pub layers: Vec<(Vec<f32>, Vec<f32>)>,
}

impl Weights {
    /// He-initialised weights and zero biases (deterministic in `seed`).
    pub fn init(config: &NetConfig, seed: u64) -> Self {
        let mut rng = Pcg64::seed_from_u64(seed);
        let layers = config
            .layers()
            .iter()
            .map(|l| {
                let fan_in = (l.inputs * l.kernel * l.kernel) as f32;
                let scale = (6.0 / fan_in).sqrt();
                let w = (0..l.weight_len())
                    .map(|_| scale * rng.random_range(-1.0f32..=1.0))
                    .collect();
                (w, vec![0.0; l.outputs])
            })
            .collect();
        Self { layers }
    }

    /// Zeros of the same shapes (optimiser moments).
    pub fn zeros_like(&self) -> Self {
        Self {
            layers: self
                .layers
                .iter()
                .map(|(w, b)| (vec![0.0; w.len()], vec![0.0; b.len()]))
                .collect(),
        }
    }

    /// Whether every value is finite.
    pub fn is_finite(&self) -> bool {
        self.layers
            .iter()
            .all(|(w, b)| w.iter().chain(b).all(|v| v.is_finite()))
    }
}

/// The parameters as tensors on a device (with gradients tracked where the device has autodiff).
pub struct NetworkParams {
    /// Per layer: weight `[out, in, k, k]` and bias `[out]`.
    pub layers: Vec<(Tensor<4>, Tensor<1>)>,
}

impl NetworkParams {
    /// Tensors of `weights` on `device`; with `track`, they require gradients.
    pub fn new(config: &NetConfig, weights: &Weights, device: &Device, track: bool) -> Self {
        let layers = config
            .layers()
            .iter()
            .zip(&weights.layers)
            .map(|(spec, (w, b))| {
                let w =
                    Tensor::<4>::from_data(TensorData::new(w.clone(), spec.weight_shape()), device);
                let b = Tensor::<1>::from_data(TensorData::new(b.clone(), [spec.outputs]), device);
                if track {
                    (w.require_grad(), b.require_grad())
                } else {
                    (w, b)
                }
            })
            .collect();
        Self { layers }
    }
}

/// Logits `[batch, classes, height, width]` of `input` `[batch, 6, height, width]`.
pub fn forward(config: &NetConfig, params: &NetworkParams, input: Tensor<4>) -> Tensor<4> {
    let specs = config.layers();
    let layer = |k: usize, x: Tensor<4>| conv(&specs[k], &params.layers[k], x);
    let e1 = relu(layer(1, relu(layer(0, input))));
    let e2 = relu(layer(3, relu(layer(2, e1.clone()))));
    let e3 = relu(layer(4, e2.clone()));
    let e3 = relu(layer(6, relu(layer(5, e3))));
    let d2 = relu(layer(7, Tensor::cat(vec![upsample(e3), e2], 1)));
    let d1 = relu(layer(8, Tensor::cat(vec![upsample(d2), e1], 1)));
    layer(9, d1)
}

/// A convolution with circular padding across columns (the panorama wraps around) and zero padding
/// across rows.
fn conv(spec: &LayerSpec, (weight, bias): &(Tensor<4>, Tensor<1>), x: Tensor<4>) -> Tensor<4> {
    let pad = spec.dilation * (spec.kernel - 1) / 2;
    let x = wrap_columns(x, pad);
    let options = ConvOptions {
        stride: [spec.stride; 2],
        padding: [(pad, pad), (0, 0)],
        dilation: [spec.dilation; 2],
        groups: 1,
    };
    conv2d(x, weight.clone(), Some(bias.clone()), options)
}

/// `x` with its last `pad` columns put before the first and its first `pad` after the last.
fn wrap_columns(x: Tensor<4>, pad: usize) -> Tensor<4> {
    if pad == 0 {
        return x;
    }
    let w = x.dims()[3];
    let left = x.clone().narrow(3, w - pad, pad);
    let right = x.clone().narrow(3, 0, pad);
    Tensor::cat(vec![left, x, right], 3)
}

/// Nearest-neighbour upsampling by 2.
fn upsample(x: Tensor<4>) -> Tensor<4> {
    let [_, _, h, w] = x.dims();
    let options = InterpolateOptions::new(InterpolateMode::Nearest)
        .with_align_corners(false)
        .with_output_size([2 * h, 2 * w]);
    interpolate(x, options)
}

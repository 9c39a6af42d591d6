//! Running the network: input tensors from panorama pairs, per-pixel labels and their confidence.

use burn::tensor::activation::softmax;
use burn::tensor::{Device, Tensor, TensorData};
use neuroom_core::image::RgbImage;

use crate::net::{INPUT_CHANNELS, NetConfig, NetworkParams, Weights, forward};

/// The network input of one panorama and its empty room (same size): channels first, sRGB centred
/// on 0.
pub fn input_channels(query: &RgbImage, empty: &RgbImage) -> Vec<f32> {
    let n = query.data.len();
    let mut out = vec![0.0; INPUT_CHANNELS * n];
    for (image, first) in [(query, 0), (empty, 3)] {
        for (i, c) in image.data.iter().enumerate() {
            for k in 0..3 {
                out[(first + k) * n + i] = c[k] - 0.5;
            }
        }
    }
    out
}

/// A batch tensor `[batch, 6, height, width]` of panorama pairs at the network's size.
pub fn input_tensor(
    config: &NetConfig,
    pairs: &[(&RgbImage, &RgbImage)],
    device: &Device,
) -> Tensor<4> {
    let data: Vec<f32> = pairs
        .iter()
        .flat_map(|(q, e)| input_channels(q, e))
        .collect();
    let shape = [pairs.len(), INPUT_CHANNELS, config.height(), config.width];
    Tensor::<4>::from_data(TensorData::new(data, shape), device)
}

/// What the network says of one panorama at its working size.
#[derive(Clone, Debug, PartialEq)]
pub struct Prediction {
    /// Most probable class per pixel (0 = background, 1 + model index).
    pub labels: Vec<u8>,
    /// Its probability.
    pub confidence: Vec<f32>,
}

/// Labels of panorama pairs already at the network's size.
pub fn predict(
    config: &NetConfig,
    weights: &Weights,
    pairs: &[(&RgbImage, &RgbImage)],
) -> Vec<Prediction> {
    if pairs.is_empty() {
        return Vec::new();
    }
    let device = Device::flex();
    let params = NetworkParams::new(config, weights, &device, false);
    let probabilities = softmax(
        forward(config, &params, input_tensor(config, pairs, &device)),
        1,
    );
    let values: Vec<f32> = probabilities.into_data().try_to_vec().unwrap_or_default();
    let n = config.width * config.height();
    let classes = config.classes;
    (0..pairs.len())
        .map(|b| {
            let image = values
                .get(b * classes * n..(b + 1) * classes * n)
                .unwrap_or(&[]);
            let (labels, confidence) = (0..n)
                .map(|i| {
                    (0..classes)
                        .map(|c| (c as u8, image.get(c * n + i).copied().unwrap_or(0.0)))
                        .fold((0u8, f32::NEG_INFINITY), |best, x| {
                            if x.1 > best.1 { x } else { best }
                        })
                })
                .unzip();
            Prediction { labels, confidence }
        })
        .collect()
}

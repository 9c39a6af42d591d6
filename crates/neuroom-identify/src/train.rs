//! Training the network on composed panoramas: pixel-wise cross-entropy with object pixels weighted up
//! (they are rare), Adam on the host copy of the weights, a cosine learning-rate decay over the time
//! budget, resumable from a checkpoint written atomically every few seconds.

use std::path::Path;
use std::time::Instant;

use burn::tensor::activation::log_softmax;
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use crate::IdentifyError;
use crate::compose::{BACKGROUND, Sample};
use crate::infer::{input_tensor, predict};
use crate::net::{NetConfig, NetworkParams, Weights, forward};
use crate::store::{Checkpoint, Network, read_checkpoint, write_checkpoint};

/// How long and how the network trains.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainSettings {
    /// Wall-clock budget (seconds, summed over resumed runs). On the bedroom's 7 models, 120 s
    /// (about 200 steps on a busy 2-core machine) left the network finding a sixth of the objects of
    /// the test panoramas, 600 s (about 900 steps) two thirds.
    pub seconds: f64,
    /// Most steps (`None`: the budget alone).
    pub max_steps: Option<u64>,
    /// Panoramas per step.
    pub batch: usize,
    /// Adam step size at the start (decays to 5 % by the end of the budget).
    pub learning_rate: f32,
    /// Weight of an object pixel in the loss relative to a background pixel.
    pub object_weight: f32,
    /// Seed of the initial weights and of the training panoramas.
    pub seed: u64,
    /// Seconds between checkpoints.
    pub checkpoint_seconds: f64,
    /// Held-out panoramas the accuracy is measured on.
    pub held_out: usize,
}

impl Default for TrainSettings {
    fn default() -> Self {
        Self {
            seconds: 600.0,
            max_steps: None,
            batch: 4,
            learning_rate: 3e-3,
            object_weight: 4.0,
            seed: 0,
            checkpoint_seconds: 15.0,
            held_out: 12,
        }
    }
}

/// Adam's moments and step count.
#[derive(Clone, Debug, PartialEq)]
pub struct NetworkAdam {
    /// First moments.
    pub m: Weights,
    /// Second moments.
    pub v: Weights,
    /// Steps taken.
    pub steps: u64,
}

const BETA1: f32 = 0.9;
const BETA2: f32 = 0.999;
const EPSILON: f32 = 1e-8;

impl NetworkAdam {
    /// Zero moments for `weights`.
    pub fn new(weights: &Weights) -> Self {
        Self {
            m: weights.zeros_like(),
            v: weights.zeros_like(),
            steps: 0,
        }
    }

    /// One step of size `rate` along `grads`.
    pub fn step(&mut self, weights: &mut Weights, grads: &Weights, rate: f32) {
        self.steps += 1;
        let c1 = 1.0 - BETA1.powi(self.steps as i32);
        let c2 = 1.0 - BETA2.powi(self.steps as i32);
        let update = |p: &mut [f32], g: &[f32], m: &mut [f32], v: &mut [f32]| {
            for i in 0..p.len() {
                m[i] = BETA1 * m[i] + (1.0 - BETA1) * g[i];
                v[i] = BETA2 * v[i] + (1.0 - BETA2) * g[i] * g[i];
                p[i] -= rate * (m[i] / c1) / ((v[i] / c2).sqrt() + EPSILON);
            }
        };
        for (k, (w, b)) in weights.layers.iter_mut().enumerate() {
            let (gw, gb) = &grads.layers[k];
            let (mw, mb) = &mut self.m.layers[k];
            let (vw, vb) = &mut self.v.layers[k];
            update(w, gw, mw, vw);
            update(b, gb, mb, vb);
        }
    }
}

/// Where training stands (also what a checkpoint holds besides the weights).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainLog {
    /// Steps taken.
    pub steps: u64,
    /// Seconds spent training (all runs).
    pub seconds: f64,
    /// (step, mean loss of the steps since the previous entry).
    pub losses: Vec<(u64, f32)>,
}

/// What training reports when done.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainReport {
    /// Steps, seconds and the loss curve.
    pub log: TrainLog,
    /// Held-out accuracy.
    pub accuracy: Accuracy,
}

/// Per-pixel agreement with the labels of held-out panoramas.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Accuracy {
    /// Panoramas.
    pub panoramas: usize,
    /// Fraction of all pixels labelled right.
    pub pixel: f64,
    /// Fraction of object pixels labelled with their model.
    pub object_recall: f64,
    /// Fraction of pixels labelled as an object that show that object.
    pub object_precision: f64,
}

/// Progress of a training run.
#[derive(Clone, Copy, Debug)]
pub struct Tick {
    /// Steps taken.
    pub steps: u64,
    /// Seconds spent (all runs).
    pub seconds: f64,
    /// The budget.
    pub budget: f64,
    /// Loss of the last step.
    pub loss: f32,
}

/// Trains a network of shape `config` on the panoramas `sample` composes from a seed, resuming from
/// `checkpoint` when it exists and writing it as it goes; returns the trained network (the checkpoint
/// is left for the caller to remove once the network is stored). `models` names the object models.
pub fn train(
    config: &NetConfig,
    models: &[String],
    sample: &(dyn Fn(u64) -> Sample + Sync),
    settings: &TrainSettings,
    checkpoint: &Path,
    progress: &mut dyn FnMut(&Tick),
) -> Result<Network, IdentifyError> {
    config
        .check()
        .map_err(|m| IdentifyError::Config(format!("network: {m}")))?;
    let Checkpoint {
        mut weights,
        mut adam,
        mut log,
    } = if checkpoint.exists() {
        read_checkpoint(checkpoint, config)?
    } else {
        let weights = Weights::init(config, settings.seed);
        Checkpoint {
            adam: NetworkAdam::new(&weights),
            weights,
            log: TrainLog::default(),
        }
    };
    let device = Device::flex().autodiff();
    let start = Instant::now();
    let already = log.seconds;
    let mut last_save = Instant::now();
    let mut window = Vec::new();
    while !finished(&log, settings) {
        let first = log.steps * settings.batch as u64;
        let batch: Vec<Sample> = (0..settings.batch as u64)
            .map(|i| sample(training_seed(settings.seed, first + i)))
            .collect();
        let frac = (log.seconds / settings.seconds.max(1e-9)).clamp(0.0, 1.0);
        let rate = settings.learning_rate
            * (0.05 + 0.95 * 0.5 * (1.0 + (std::f64::consts::PI * frac).cos()) as f32);
        let (loss, grads) = loss_and_gradients(config, &weights, &batch, settings, &device);
        // A step whose loss or gradient is not finite is skipped: the weights stay as they were.
        if loss.is_finite() && grads.is_finite() {
            adam.step(&mut weights, &grads, rate);
            window.push(loss);
        }
        log.steps += 1;
        log.seconds = already + start.elapsed().as_secs_f64();
        if (log.steps.is_multiple_of(10) || finished(&log, settings)) && !window.is_empty() {
            log.losses
                .push((log.steps, window.iter().sum::<f32>() / window.len() as f32));
            window.clear();
        }
        progress(&Tick {
            steps: log.steps,
            seconds: log.seconds,
            budget: settings.seconds,
            loss,
        });
        if last_save.elapsed().as_secs_f64() >= settings.checkpoint_seconds {
            write_checkpoint(checkpoint, config, &weights, &adam, &log)?;
            last_save = Instant::now();
        }
    }
    let held_out: Vec<Sample> = (0..settings.held_out as u64)
        .map(|i| sample(held_out_seed(settings.seed, i)))
        .collect();
    let accuracy = accuracy(config, &weights, &held_out);
    Ok(Network {
        config: config.clone(),
        models: models.to_vec(),
        weights,
        report: Some(TrainReport { log, accuracy }),
    })
}

fn finished(log: &TrainLog, settings: &TrainSettings) -> bool {
    log.seconds >= settings.seconds || settings.max_steps.is_some_and(|m| log.steps >= m)
}

/// Seed of the `index`-th training panorama.
pub fn training_seed(seed: u64, index: u64) -> u64 {
    mix(seed ^ 0x5851_f42d_4c95_7f2d, index)
}

/// Seed of the `index`-th held-out panorama (a stream apart from the training panoramas).
pub fn held_out_seed(seed: u64, index: u64) -> u64 {
    mix(seed ^ 0x14057b7ef767814f, index)
}

/// SplitMix64 of `a` and `b`.
fn mix(a: u64, b: u64) -> u64 {
    let mut z = a.wrapping_add(b.wrapping_mul(0x9e37_79b9_7f4a_7c15));
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// The weighted cross-entropy of a batch and its gradient with respect to every weight.
pub fn loss_and_gradients(
    config: &NetConfig,
    weights: &Weights,
    batch: &[Sample],
    settings: &TrainSettings,
    device: &Device,
) -> (f32, Weights) {
    let params = NetworkParams::new(config, weights, device, true);
    let pairs: Vec<_> = batch.iter().map(|s| (&s.query, &s.empty)).collect();
    let logits = forward(config, &params, input_tensor(config, &pairs, device));
    let (target, pixel_weights, total) = targets(config, batch, settings.object_weight, device);
    let per_pixel = (log_softmax(logits, 1) * target).sum_dim(1);
    let loss = (per_pixel * pixel_weights).sum().neg().div_scalar(total);
    let value = loss
        .clone()
        .into_data()
        .try_to_vec::<f32>()
        .ok()
        .and_then(|v| v.first().copied())
        .unwrap_or(f32::NAN);
    let gradients = loss.backward();
    let host =
        |t: Option<Vec<f32>>, len: usize| t.filter(|v| v.len() == len).unwrap_or(vec![0.0; len]);
    let layers = params
        .layers
        .iter()
        .zip(&weights.layers)
        .map(|((w, b), (hw, hb))| {
            let gw = w
                .grad(&gradients)
                .and_then(|g| g.into_data().try_to_vec().ok());
            let gb = b
                .grad(&gradients)
                .and_then(|g| g.into_data().try_to_vec().ok());
            (host(gw, hw.len()), host(gb, hb.len()))
        })
        .collect();
    (value, Weights { layers })
}

/// One-hot targets `[batch, classes, h, w]`, pixel weights `[batch, 1, h, w]` and their sum.
fn targets(
    config: &NetConfig,
    batch: &[Sample],
    object_weight: f32,
    device: &Device,
) -> (Tensor<4>, Tensor<4>, f32) {
    let n = config.width * config.height();
    let classes = config.classes;
    let mut one_hot = vec![0.0f32; batch.len() * classes * n];
    let mut weights = vec![0.0f32; batch.len() * n];
    for (b, sample) in batch.iter().enumerate() {
        for (i, &label) in sample.labels.iter().enumerate().take(n) {
            let class = (label as usize).min(classes - 1);
            one_hot[(b * classes + class) * n + i] = 1.0;
            weights[b * n + i] = if label == BACKGROUND {
                1.0
            } else {
                object_weight
            };
        }
    }
    let total = weights.iter().sum::<f32>().max(1.0);
    let (h, w) = (config.height(), config.width);
    (
        Tensor::from_data(
            TensorData::new(one_hot, [batch.len(), classes, h, w]),
            device,
        ),
        Tensor::from_data(TensorData::new(weights, [batch.len(), 1, h, w]), device),
        total,
    )
}

/// How well `weights` label `samples`.
pub fn accuracy(config: &NetConfig, weights: &Weights, samples: &[Sample]) -> Accuracy {
    let (mut right, mut all) = (0usize, 0usize);
    let (mut found, mut objects, mut claimed) = (0usize, 0usize, 0usize);
    for sample in samples {
        let predicted = predict(config, weights, &[(&sample.query, &sample.empty)]);
        let Some(p) = predicted.first() else {
            continue;
        };
        for (&truth, &label) in sample.labels.iter().zip(&p.labels) {
            all += 1;
            right += usize::from(truth == label);
            objects += usize::from(truth != BACKGROUND);
            claimed += usize::from(label != BACKGROUND);
            found += usize::from(truth != BACKGROUND && truth == label);
        }
    }
    let ratio = |a: usize, b: usize| if b == 0 { 0.0 } else { a as f64 / b as f64 };
    Accuracy {
        panoramas: samples.len(),
        pixel: ratio(right, all),
        object_recall: ratio(found, objects),
        object_precision: ratio(found, claimed),
    }
}

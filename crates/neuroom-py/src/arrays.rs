//! numpy arrays in and out: poses as 4×4 float64, images as `H×W×3`, depth and instance maps as `H×W`.

use neuroom::Pose;
use neuroom::formats::json::POSE_TOLERANCE;
use neuroom::image::{DepthImage, Image, MaskImage, RgbImage};
use numpy::ndarray::{Array2, Array3, ArrayView3};
use numpy::{Element, IntoPyArray, PyArray2, PyArray3, PyArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// A pose as its 4×4 homogeneous matrix.
pub fn pose_to_numpy<'py>(py: Python<'py>, pose: &Pose) -> Bound<'py, PyArray2<f64>> {
    let rows = pose.to_rows();
    Array2::from_shape_fn((4, 4), |(i, j)| rows[i][j]).into_pyarray(py)
}

/// A rigid pose from a 4×4 matrix (any array-like of numbers); `ValueError` naming `what` otherwise.
pub fn pose_from_python(value: &Bound<'_, PyAny>, what: &str) -> PyResult<Pose> {
    let rows: Vec<Vec<f64>> = value
        .extract()
        .map_err(|_| PyTypeError::new_err(format!("{what}: expected a 4×4 matrix of numbers")))?;
    if rows.len() != 4 || rows.iter().any(|r| r.len() != 4) {
        return Err(PyValueError::new_err(format!(
            "{what}: expected a 4×4 matrix, found {} rows",
            rows.len()
        )));
    }
    let m: [[f64; 4]; 4] = std::array::from_fn(|i| std::array::from_fn(|j| rows[i][j]));
    Pose::check_rows(&m, POSE_TOLERANCE)
        .map(|p| p.orthonormalized())
        .map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

/// An sRGB image from an `H×W×3` numpy array: `uint8` (0–255) or `float32` / `float64` in [0, 1].
pub fn rgb_from_numpy(value: &Bound<'_, PyAny>) -> PyResult<RgbImage> {
    if let Ok(a) = value.cast::<PyArray3<u8>>() {
        return rgb_from_view(a.readonly().as_array(), |v| f32::from(v) / 255.0);
    }
    if let Ok(a) = value.cast::<PyArray3<f32>>() {
        return checked_unit(rgb_from_view(a.readonly().as_array(), |v| v)?);
    }
    if let Ok(a) = value.cast::<PyArray3<f64>>() {
        return checked_unit(rgb_from_view(a.readonly().as_array(), |v| v as f32)?);
    }
    Err(PyTypeError::new_err(
        "image: expected a path or an H×W×3 numpy array of uint8, float32 or float64",
    ))
}

fn rgb_from_view<T: Element + Copy>(
    view: ArrayView3<'_, T>,
    to_unit: impl Fn(T) -> f32,
) -> PyResult<RgbImage> {
    let (h, w, c) = view.dim();
    if c != 3 || h == 0 || w == 0 {
        return Err(PyValueError::new_err(format!(
            "image: expected H×W×3 (RGB), found shape ({h}, {w}, {c})"
        )));
    }
    let data = (0..h)
        .flat_map(|y| (0..w).map(move |x| (y, x)))
        .map(|(y, x)| std::array::from_fn(|k| to_unit(view[[y, x, k]])))
        .collect();
    Ok(Image {
        width: u32::try_from(w).map_err(|_| PyValueError::new_err("image: too wide"))?,
        height: u32::try_from(h).map_err(|_| PyValueError::new_err("image: too high"))?,
        data,
    })
}

/// Float images must hold sRGB values in [0, 1].
fn checked_unit(image: RgbImage) -> PyResult<RgbImage> {
    match image
        .data
        .iter()
        .flatten()
        .find(|v| !(0.0..=1.0).contains(*v))
    {
        None => Ok(image),
        Some(v) => Err(PyValueError::new_err(format!(
            "image: float images hold sRGB values in [0, 1], found {v}"
        ))),
    }
}

/// Reads an image file (PNG, JPEG, EXR, HDR; docs/formats.md) as an `H×W×3` float32 array of sRGB
/// values in [0, 1], as the pipelines see it.
#[pyfunction]
pub fn read_image(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Bound<'_, PyArray3<f32>>> {
    let image = neuroom::formats::read_rgb(&path)
        .map_err(|e| crate::error::to_py(e.into()))?
        .image;
    Ok(rgb_to_numpy(py, &image))
}

/// An sRGB image as an `H×W×3` float32 array.
pub fn rgb_to_numpy<'py>(py: Python<'py>, image: &RgbImage) -> Bound<'py, PyArray3<f32>> {
    let (h, w) = (image.height as usize, image.width as usize);
    Array3::from_shape_fn((h, w, 3), |(y, x, k)| image.data[y * w + x][k]).into_pyarray(py)
}

/// A depth map as an `H×W` float32 array (metres, 0 where nothing was hit).
pub fn depth_to_numpy<'py>(py: Python<'py>, image: &DepthImage) -> Bound<'py, PyArray2<f32>> {
    plane_to_numpy(py, image)
}

/// An instance map as an `H×W` uint16 array (object ids, 0 for the room).
pub fn mask_to_numpy<'py>(py: Python<'py>, image: &MaskImage) -> Bound<'py, PyArray2<u16>> {
    plane_to_numpy(py, image)
}

fn plane_to_numpy<'py, T: Element + Copy>(
    py: Python<'py>,
    image: &Image<T>,
) -> Bound<'py, PyArray2<T>> {
    let (h, w) = (image.height as usize, image.width as usize);
    Array2::from_shape_fn((h, w), |(y, x)| image.data[y * w + x]).into_pyarray(py)
}

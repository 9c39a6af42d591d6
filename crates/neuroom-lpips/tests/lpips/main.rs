//! LPIPS with random weights (the distance's properties, the loader's errors) and against the numpy
//! reference of `tools/setup_lpips.py` with the real weights.

mod common;
mod reference;

use std::path::PathBuf;

use neuroom_core::image::RgbImage;
use neuroom_lpips::{Lpips, LpipsError};
use tempfile::TempDir;

use common::{TENSORS, random_tensors, test_image, write_random_weights, write_tensors};

/// A network with random weights, loaded from a temporary safetensors file.
fn random_lpips(seed: u64) -> Lpips {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("random.safetensors");
    write_random_weights(&path, seed);
    Lpips::load(&path).unwrap()
}

/// `image` plus `amplitude` times a fixed noise pattern, clamped to [0, 1].
fn noisy(image: &RgbImage, amplitude: f32) -> RgbImage {
    let noise = test_image(image.width, image.height, [0.0, 0.0, 0.5, 11.0]);
    let mut out = image.clone();
    for (p, n) in out.data.iter_mut().zip(&noise.data) {
        *p = std::array::from_fn(|c| (p[c] + amplitude * 2.0 * (n[c] - 0.5)).clamp(0.0, 1.0));
    }
    out
}

#[test]
fn distance_to_itself_is_zero() {
    let lpips = random_lpips(1);
    let image = test_image(64, 48, [1.0, 0.0, 0.05, 1.0]);
    assert_eq!(lpips.distance(&image, &image).unwrap(), 0.0);
}

#[test]
fn distance_is_symmetric_and_positive() {
    let lpips = random_lpips(2);
    let a = test_image(72, 40, [1.0, 0.0, 0.0, 0.0]);
    let b = test_image(72, 40, [0.8, 3.0, 0.1, 2.0]);
    let (ab, ba) = (
        lpips.distance(&a, &b).unwrap(),
        lpips.distance(&b, &a).unwrap(),
    );
    assert!(ab > 0.0, "{ab}");
    assert!((ab - ba).abs() <= 1e-9 * ab, "{ab} vs {ba}");
}

#[test]
fn distance_grows_with_noise() {
    let lpips = random_lpips(3);
    let image = test_image(96, 64, [1.0, 0.0, 0.0, 0.0]);
    let distances: Vec<f64> = [0.01, 0.03, 0.1, 0.3]
        .iter()
        .map(|a| lpips.distance(&image, &noisy(&image, *a)).unwrap())
        .collect();
    assert!(distances.windows(2).all(|d| d[0] < d[1]), "{distances:?}");
}

#[test]
fn images_of_different_sizes_are_refused() {
    let lpips = random_lpips(4);
    let err = lpips
        .distance(&test_image(64, 48, [1.0; 4]), &test_image(48, 64, [1.0; 4]))
        .unwrap_err();
    assert!(
        matches!(
            err,
            LpipsError::SizeMismatch {
                a: (64, 48),
                b: (48, 64)
            }
        ),
        "{err}"
    );
}

#[test]
fn the_smallest_accepted_side_is_31() {
    let lpips = random_lpips(5);
    let (a, b) = (
        test_image(31, 31, [1.0, 0.0, 0.0, 0.0]),
        test_image(31, 31, [1.0, 1.0, 0.0, 0.0]),
    );
    assert!(lpips.distance(&a, &b).unwrap() > 0.0);
    let (a, b) = (test_image(31, 30, [1.0; 4]), test_image(31, 30, [1.0; 4]));
    let err = lpips.distance(&a, &b).unwrap_err();
    assert!(
        matches!(
            err,
            LpipsError::TooSmall {
                width: 31,
                height: 30
            }
        ),
        "{err}"
    );
}

/// Writes the random tensors changed by `edit` and returns the load error, with the file's path.
fn load_error(
    edit: impl FnOnce(&mut Vec<(String, Vec<usize>, Vec<f32>)>),
) -> (LpipsError, PathBuf, TempDir) {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("edited.safetensors");
    let mut tensors = random_tensors(&TENSORS, 6);
    edit(&mut tensors);
    write_tensors(&path, &tensors);
    (Lpips::load(&path).unwrap_err(), path, dir)
}

#[test]
fn a_missing_tensor_is_named() {
    let (err, path, _dir) = load_error(|t| t.retain(|(name, _, _)| name != "lin3.weight"));
    assert!(
        matches!(&err, LpipsError::MissingTensor { name, .. } if name == "lin3.weight"),
        "{err}"
    );
    assert!(
        err.to_string().contains(&path.display().to_string()),
        "{err}"
    );
}

#[test]
fn a_wrong_shape_is_named() {
    let (err, path, _dir) = load_error(|t| {
        assert_eq!(t[2].0, "conv2.weight");
        t[2].1 = vec![192, 64, 3, 3];
        t[2].2.truncate(192 * 64 * 9);
    });
    let expected = vec![192, 64, 5, 5];
    assert!(
        matches!(&err, LpipsError::Shape { name, expected: e, found, .. }
        if name == "conv2.weight" && *e == expected && *found == vec![192, 64, 3, 3]),
        "{err}"
    );
    assert!(
        err.to_string().contains(&path.display().to_string()),
        "{err}"
    );
}

#[test]
fn a_file_that_is_not_safetensors_is_refused() {
    let dir = TempDir::new().unwrap();
    let path = dir.path().join("garbage.safetensors");
    std::fs::write(&path, b"not a safetensors file").unwrap();
    let err = Lpips::load(&path).unwrap_err();
    assert!(matches!(err, LpipsError::Format { .. }), "{err}");
    let err = Lpips::load(dir.path().join("absent.safetensors")).unwrap_err();
    assert!(
        matches!(err, LpipsError::Io { .. }) && err.to_string().contains("absent.safetensors"),
        "{err}"
    );
}

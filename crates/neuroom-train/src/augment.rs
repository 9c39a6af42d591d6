//! Lighting augmentation: each chosen HDR environment map becomes a diffuse irradiance (9 SH coefficients
//! per channel, [`ShIrradiance`]) that re-shades a training pixel by its surface normal; the model learns one
//! light code per map. The normal is the ground-truth normal from depth ([`crate::normals`]), in the model
//! frame (z up for objects and for the room, as the maps are). Re-lighting happens in linear light:
//! `srgb(relight(linear(c), n))`.

use crate::lighting::ShIrradiance;
use glam::Vec3;
use neuroom_core::FormatError;
use neuroom_core::formats::read_envmap;
use neuroom_core::image::{linear_to_srgb, srgb_to_linear};
use std::path::{Path, PathBuf};

/// The augmentation lightings: names (file stems) and irradiances.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Augmentation {
    /// One name per map, e.g. `apartment`.
    pub names: Vec<String>,
    /// One irradiance per map.
    pub lights: Vec<ShIrradiance>,
}

impl Augmentation {
    /// Reads the environment maps at `paths` and projects each onto spherical harmonics.
    pub fn load(paths: &[PathBuf]) -> Result<Self, FormatError> {
        let mut aug = Self::default();
        for p in paths {
            let map = read_envmap(p)?;
            aug.names.push(stem(p));
            aug.lights.push(ShIrradiance::from_envmap(&map));
        }
        Ok(aug)
    }

    /// Number of maps.
    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// The sRGB colour `srgb` of a surface with unit normal `n`, re-lit by map `k`.
    pub fn relight_srgb(&self, k: usize, srgb: [f32; 3], n: Vec3) -> [f32; 3] {
        let lin = self.lights[k].relight(srgb.map(srgb_to_linear), n);
        lin.map(linear_to_srgb)
    }
}

/// The vendored environment maps of the repository (`assets/hdri/*.exr`), sorted by name; empty when the
/// folder is not there (an installed binary without the sources).
pub fn vendored_env_maps() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/hdri");
    let mut maps: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|rd| {
            rd.filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "exr" || x == "hdr"))
                .collect()
        })
        .unwrap_or_default();
    maps.sort();
    maps
}

fn stem(p: &Path) -> String {
    let name = p
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    name.split('.').next().unwrap_or_default().to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vendored_maps_load_and_tint_differently() {
        let paths = vendored_env_maps();
        assert!(
            !paths.is_empty(),
            "the vendored maps of assets/hdri are missing"
        );
        let aug = Augmentation::load(&paths).unwrap();
        assert_eq!(aug.len(), paths.len());
        let grey = [0.5; 3];
        let up: Vec<[f32; 3]> = (0..aug.len())
            .map(|k| aug.relight_srgb(k, grey, Vec3::Z))
            .collect();
        let side: Vec<[f32; 3]> = (0..aug.len())
            .map(|k| aug.relight_srgb(k, grey, Vec3::X))
            .collect();
        assert!(
            up.iter()
                .chain(&side)
                .all(|c| c.iter().all(|v| v.is_finite() && *v >= 0.0))
        );
        assert!(
            up.iter()
                .zip(&side)
                .any(|(a, b)| (a[0] - b[0]).abs() > 0.01),
            "{up:?} {side:?}"
        );
    }
}

//! The illuminations of a room: the capture lighting (neutral 5500 K ceiling panels for the
//! background, the first HDRI for lone objects) and test lightings that differ from it in colour
//! temperature, intensity, panel layout, a local lamp and the HDRI used as ambient.

use std::path::{Path, PathBuf};

use glam::{DVec3, Vec3};
use neuroom_core::FormatResult;
use neuroom_core::formats::read_envmap;
use rand::Rng;
use rand_pcg::Pcg64;

use crate::lighting::{Environment, EnvironmentLight, Light, Lighting};

/// Colour temperature of the capture lighting.
pub const CAPTURE_KELVIN: f32 = 5500.0;
/// Power of one ceiling panel under the capture lighting (W).
const PANEL_W: f32 = 16.0;
/// Panel side (m).
const PANEL_SIDE: f32 = 0.6;

/// An environment map by name, reduced to its irradiance.
#[derive(Clone, Debug)]
pub struct Hdri {
    /// File name (or `studio`).
    pub name: String,
    /// Its irradiance.
    pub environment: Environment,
}

/// Loads HDR environment maps; with none given, the built-in analytic `studio` environment.
pub fn load_hdris(paths: &[PathBuf]) -> FormatResult<Vec<Hdri>> {
    if paths.is_empty() {
        return Ok(vec![Hdri {
            name: "studio".into(),
            environment: Environment::studio(),
        }]);
    }
    paths
        .iter()
        .map(|p| {
            let map = read_envmap(p)?;
            let name = p.file_name().map_or_else(
                || p.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            );
            Ok(Hdri {
                name,
                environment: Environment::from_envmap(&map),
            })
        })
        .collect()
}

/// The neutral lighting of the background capture: two ceiling panels and a faint HDRI ambient.
pub fn background_lighting(room: DVec3, hdri: &str) -> Lighting {
    let r = room.as_vec3();
    let z = r.z - 0.02;
    let lights = [1.0 / 3.0, 2.0 / 3.0]
        .iter()
        .map(|f| {
            Light::ceiling_panel(
                Vec3::new(r.x * f, r.y * 0.5, z),
                [PANEL_SIDE; 2],
                PANEL_W,
                CAPTURE_KELVIN,
            )
        })
        .collect();
    Lighting {
        name: "capture_ceiling_5500K".into(),
        description: "two ceiling panels, neutral white, faint environment ambient".into(),
        lights,
        environment: Some(EnvironmentLight {
            hdri: hdri.into(),
            strength: 0.15,
        }),
        ambient: 0.0,
        exposure_ev: 0.0,
    }
}

/// The lighting of lone-object captures: the environment map alone.
pub fn object_lighting(hdri: &str) -> Lighting {
    Lighting {
        name: format!("capture_hdri_{}", stem(hdri)),
        description: "object alone under the environment map".into(),
        lights: Vec::new(),
        environment: Some(EnvironmentLight {
            hdri: hdri.into(),
            strength: 1.0,
        }),
        ambient: 0.0,
        exposure_ev: 0.0,
    }
}

fn stem(name: &str) -> &str {
    Path::new(name)
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or(name)
        .split('.')
        .next()
        .unwrap_or(name)
}

/// Test lighting number `index`: warm or cold panels at a new layout and power, often a local
/// lamp, and an HDRI ambient that cycles through the available maps.
pub fn test_lighting(index: u32, room: DVec3, hdris: &[Hdri], rng: &mut Pcg64) -> Lighting {
    const KELVINS: [f32; 5] = [2700.0, 3200.0, 4000.0, 6500.0, 7500.0];
    let r = room.as_vec3();
    let kelvin = KELVINS[(index as usize + rng.random_range(0..KELVINS.len())) % KELVINS.len()];
    let scale = rng.random_range(0.45..1.6f32);
    let panels = rng.random_range(1..=2u32);
    let mut lights: Vec<Light> = (0..panels)
        .map(|_| {
            let p = Vec3::new(
                r.x * rng.random_range(0.25..0.75),
                r.y * rng.random_range(0.25..0.75),
                r.z - 0.02,
            );
            Light::ceiling_panel(
                p,
                [PANEL_SIDE; 2],
                PANEL_W * 2.0 / panels as f32 * scale,
                kelvin,
            )
        })
        .collect();
    let lamp = rng.random_bool(0.7);
    if lamp {
        let corner = Vec3::new(
            if rng.random_bool(0.5) {
                0.35
            } else {
                r.x - 0.35
            },
            if rng.random_bool(0.5) {
                0.35
            } else {
                r.y - 0.35
            },
            rng.random_range(0.6..1.9),
        );
        lights.push(Light::point(
            corner,
            rng.random_range(5.0..14.0),
            KELVINS[rng.random_range(0..KELVINS.len())],
        ));
    }
    let hdri = &hdris[(index as usize + 1) % hdris.len()].name;
    let description = format!(
        "{panels} ceiling panel(s) at {kelvin} K, {:.0} % of capture power{}, ambient from {hdri}",
        scale * 100.0,
        if lamp { ", a lamp near a corner" } else { "" }
    );
    Lighting {
        name: format!(
            "l{index}_{}K{}",
            kelvin as u32,
            if lamp { "_lamp" } else { "" }
        ),
        description,
        lights,
        environment: Some(EnvironmentLight {
            hdri: hdri.clone(),
            strength: rng.random_range(0.05..0.35),
        }),
        ambient: rng.random_range(0.0..0.15),
        exposure_ev: 0.0,
    }
}

//! Lights and illuminations: rectangular area lights (soft shadows), point lights (hard shadows), an
//! HDR environment used as directional ambient through its order-2 spherical-harmonic irradiance, a
//! one-bounce ambient estimate for closed rooms, and a constant ambient term. Colours come from a
//! colour temperature in Kelvin. [`Lighting`] is the serialisable description written next to
//! every capture and panorama; [`Environment`] holds the environment's irradiance.

use glam::{DVec2, Vec3};
use neuroom_core::camera::{CameraModel, Equirect};
use neuroom_core::formats::EnvMap;
use neuroom_core::image::srgb_to_linear;
use neuroom_core::sh;
use serde::{Deserialize, Serialize};

/// Linear RGB of a black body at `kelvin`, normalised so its largest channel is 1 (Tanner Helland's
/// fit of the Planckian locus in sRGB, decoded to linear).
pub fn kelvin_to_rgb(kelvin: f32) -> Vec3 {
    let t = kelvin.clamp(1000.0, 40000.0) / 100.0;
    let r = if t <= 66.0 {
        255.0
    } else {
        329.698_73 * (t - 60.0).powf(-0.133_204_76)
    };
    let g = if t <= 66.0 {
        99.470_8 * t.ln() - 161.119_57
    } else {
        288.122_16 * (t - 60.0).powf(-0.075_514_85)
    };
    let b = if t >= 66.0 {
        255.0
    } else if t <= 19.0 {
        0.0
    } else {
        138.517_73 * (t - 10.0).ln() - 305.044_8
    };
    let c = Vec3::new(r, g, b).clamp(Vec3::ZERO, Vec3::splat(255.0)) / 255.0;
    let lin = Vec3::new(
        srgb_to_linear(c.x),
        srgb_to_linear(c.y),
        srgb_to_linear(c.z),
    );
    lin / lin.max_element()
}

/// One light source, as written to the `lighting` description.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type")]
pub enum Light {
    /// A one-sided Lambertian rectangle emitting along `normal`.
    #[serde(rename = "AREA")]
    Area {
        /// Centre (world, metres).
        position: [f32; 3],
        /// Full extents along `axis_u` and `normal × axis_u`.
        size: [f32; 2],
        /// Emission direction (unit).
        normal: [f32; 3],
        /// First edge direction (unit, orthogonal to `normal`).
        axis_u: [f32; 3],
        /// Emitted power in watts.
        power_w: f32,
        /// Colour temperature.
        kelvin: f32,
        /// Linear RGB of that temperature (max channel 1).
        color_rgb_linear: [f32; 3],
    },
    /// An isotropic point.
    #[serde(rename = "POINT")]
    Point {
        /// Position (world, metres).
        position: [f32; 3],
        /// Emitted power in watts.
        power_w: f32,
        /// Colour temperature.
        kelvin: f32,
        /// Linear RGB of that temperature (max channel 1).
        color_rgb_linear: [f32; 3],
    },
}

impl Light {
    /// A downward-facing ceiling panel.
    pub fn ceiling_panel(position: Vec3, size: [f32; 2], power_w: f32, kelvin: f32) -> Self {
        Self::Area {
            position: position.into(),
            size,
            normal: [0.0, 0.0, -1.0],
            axis_u: [1.0, 0.0, 0.0],
            power_w,
            kelvin,
            color_rgb_linear: kelvin_to_rgb(kelvin).into(),
        }
    }

    /// A point light.
    pub fn point(position: Vec3, power_w: f32, kelvin: f32) -> Self {
        Self::Point {
            position: position.into(),
            power_w,
            kelvin,
            color_rgb_linear: kelvin_to_rgb(kelvin).into(),
        }
    }

    /// Total emitted flux per channel (W).
    pub fn flux(&self) -> Vec3 {
        match self {
            Self::Area {
                power_w,
                color_rgb_linear,
                ..
            }
            | Self::Point {
                power_w,
                color_rgb_linear,
                ..
            } => Vec3::from(*color_rgb_linear) * *power_w,
        }
    }
}

/// The environment map used for ambient light, by name and strength.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct EnvironmentLight {
    /// File name of the HDRI (or `studio` for the built-in analytic one).
    pub hdri: String,
    /// Multiplier on its radiance.
    pub strength: f32,
}

/// A complete illumination, serialised as the free-form `lighting` field of transforms.json and
/// arrangement files.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Lighting {
    /// Short identifier, e.g. `warm_dim_2700K`.
    pub name: String,
    /// One line in words.
    pub description: String,
    /// Local lights.
    pub lights: Vec<Light>,
    /// Environment ambient, if any.
    pub environment: Option<EnvironmentLight>,
    /// Constant ambient irradiance (W/m², grey).
    pub ambient: f32,
    /// Exposure in stops applied before sRGB encoding.
    pub exposure_ev: f32,
}

/// Order-2 spherical-harmonic irradiance of an environment: `E(n)` for any normal, so diffuse
/// environment light costs nine multiply-adds per shading point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Environment {
    radiance: [Vec3; 9],
}

impl Environment {
    /// Projects an environment map (docs/formats.md panorama layout in the world frame, see
    /// [`EnvMap`]) onto the first nine spherical harmonics.
    pub fn from_envmap(map: &EnvMap) -> Self {
        Self {
            radiance: sh::project_radiance(map),
        }
    }

    /// A built-in analytic studio environment: a bright soft sky above, a dim floor below, and a
    /// key direction, for when no HDRI is given.
    pub fn studio() -> Self {
        let (w, h) = (64u32, 32u32);
        let key = Vec3::new(0.5, 0.3, 0.8).normalize();
        let grid = Equirect::new(w, h).expect("2:1 grid");
        let texels: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let d = grid
                    .direction(DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5))
                    .as_vec3();
                let sky = 0.35 + 0.45 * d.z.max(0.0) + 2.5 * d.dot(key).max(0.0).powf(8.0);
                let ground = 0.18;
                let l = if d.z >= 0.0 { sky } else { ground };
                [l, l * 0.98, l * 0.95]
            })
            .collect();
        Self::from_envmap(&EnvMap::new(w, h, texels).expect("sized to the grid"))
    }

    /// Irradiance (W/m²) on a surface with unit normal `n`, before any occlusion.
    #[inline]
    pub fn irradiance(&self, n: Vec3) -> Vec3 {
        sh::irradiance(&self.radiance, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    /// Reference values: the `color_rgb_linear` Blender wrote for 2700 K and 5500 K in blender-lite.
    fn kelvin_matches_blender_blackbody() {
        let warm = kelvin_to_rgb(2700.0);
        assert!(
            (warm - Vec3::new(1.0, 0.39, 0.094_8)).abs().max_element() < 0.02,
            "{warm}"
        );
        let neutral = kelvin_to_rgb(5500.0);
        assert!(
            (neutral - Vec3::new(1.0, 0.8552, 0.739))
                .abs()
                .max_element()
                < 0.03,
            "{neutral}"
        );
        let cold = kelvin_to_rgb(9000.0);
        assert!(cold.z == 1.0 && cold.x < 0.9);
    }

    #[test]
    fn constant_environment_gives_pi_irradiance() {
        let env = Environment::from_envmap(
            &EnvMap::new(64, 32, vec![[1.0, 0.5, 0.25]; 64 * 32]).unwrap(),
        );
        for n in [
            Vec3::X,
            Vec3::Z,
            -Vec3::Y,
            Vec3::new(1.0, 1.0, 1.0).normalize(),
        ] {
            let e = env.irradiance(n);
            assert!(
                (e - Vec3::new(1.0, 0.5, 0.25) * std::f32::consts::PI)
                    .abs()
                    .max_element()
                    < 0.02,
                "{e}"
            );
        }
    }

    #[test]
    fn sky_lights_upward_faces_more() {
        let env = Environment::studio();
        assert!(env.irradiance(Vec3::Z).x > 2.0 * env.irradiance(-Vec3::Z).x);
    }
}

//! Lighting augmentation: diffuse irradiance of real HDR environment maps as 9 spherical-harmonic
//! coefficients per colour channel, and re-lighting of captured pixels by their surface normal.
//!
//! The augmentation treats a captured colour as the surface's albedo seen under roughly even light and
//! re-shades it with the irradiance of another environment: `relit = linear(c) · E(n) / π`, with the map
//! normalised to mean radiance 1, so a uniform white environment leaves colours unchanged and only the
//! map's colour and directionality change the image. Each map gets its own learned light code.

use glam::Vec3;
use neuroom_core::formats::EnvMap;
use neuroom_core::sh;

/// Diffuse irradiance of an environment, as SH coefficients of its radiance (per colour channel).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShIrradiance {
    /// Radiance coefficients L_lm (linear RGB) of the map scaled to mean radiance 1.
    pub coefficients: [Vec3; 9],
}

impl ShIrradiance {
    /// Projects an environment map onto bands 0–2, after scaling it to mean luminance 1 over the sphere.
    pub fn from_envmap(map: &EnvMap) -> Self {
        let radiance = sh::project_radiance(map);
        // L_00 = Y_00 · ∫ L dω, so the mean over the sphere is L_00 / (Y_00 · 4π).
        let mean = radiance[0] / (sh::sh9(Vec3::Z)[0] * 4.0 * std::f32::consts::PI);
        let scale = 1.0 / luminance(mean).max(1e-12);
        Self {
            coefficients: radiance.map(|c| c * scale),
        }
    }

    /// Irradiance E(n) arriving at a surface with unit normal `n` (linear RGB, non-negative).
    pub fn irradiance(&self, n: Vec3) -> [f32; 3] {
        sh::irradiance(&self.coefficients, n).to_array()
    }

    /// Re-lights a linear colour seen on a surface with normal `n`: `c · E(n) / π`.
    pub fn relight(&self, linear_color: [f32; 3], n: Vec3) -> [f32; 3] {
        let e = self.irradiance(n);
        std::array::from_fn(|c| linear_color[c] * e[c] / std::f32::consts::PI)
    }
}

/// Rec. 709 luminance of a linear colour.
fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(width: u32, height: u32, f: impl Fn(Vec3) -> [f32; 3]) -> EnvMap {
        let mut out = Vec::new();
        for v in 0..height {
            let lat = std::f32::consts::PI * (0.5 - (v as f32 + 0.5) / height as f32);
            for u in 0..width {
                let lon = std::f32::consts::PI * (1.0 - 2.0 * (u as f32 + 0.5) / width as f32);
                out.push(f(Vec3::new(
                    lat.cos() * lon.cos(),
                    lat.cos() * lon.sin(),
                    lat.sin(),
                )));
            }
        }
        EnvMap::new(width, height, out).unwrap()
    }

    #[test]
    fn uniform_white_environment_leaves_colours_unchanged() {
        let sh = ShIrradiance::from_envmap(&map(128, 64, |_| [3.0; 3]));
        for n in [
            Vec3::Z,
            Vec3::X,
            -Vec3::Y,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
        ] {
            let c = sh.relight([0.2, 0.5, 0.8], n);
            for (a, b) in c.iter().zip([0.2, 0.5, 0.8]) {
                assert!((a - b).abs() < 2e-3, "{c:?} at {n}");
            }
        }
    }

    #[test]
    fn light_from_above_matches_the_clamped_cosine() {
        // Radiance 1 on the upper hemisphere only: exact irradiance is π (1 + cos θ) / 2 at normal tilt θ,
        // before normalisation to mean radiance 1 (the map's mean is 1/2, so it doubles).
        let sh =
            ShIrradiance::from_envmap(&map(
                256,
                128,
                |d| if d.z > 0.0 { [1.0; 3] } else { [0.0; 3] },
            ));
        let up = sh.irradiance(Vec3::Z)[0];
        let side = sh.irradiance(Vec3::X)[0];
        let down = sh.irradiance(-Vec3::Z)[0];
        let pi = std::f32::consts::PI;
        // Order-2 SH reproduces these within a few percent of π·2 (normalised scale).
        assert!((up - 2.0 * pi).abs() < 0.1 * pi, "{up}");
        assert!((side - pi).abs() < 0.05 * pi, "{side}");
        assert!(down < 0.1 * pi, "{down}");
    }

    #[test]
    fn coloured_light_tints_the_side_it_comes_from() {
        let sh = ShIrradiance::from_envmap(&map(128, 64, |d| {
            if d.x > 0.5 {
                [4.0, 1.0, 0.5]
            } else {
                [0.5, 0.5, 0.5]
            }
        }));
        let front = sh.irradiance(Vec3::X);
        let back = sh.irradiance(-Vec3::X);
        assert!(
            front[0] > front[2] * 2.0 && front[0] > back[0] * 2.0,
            "{front:?} {back:?}"
        );
    }
}

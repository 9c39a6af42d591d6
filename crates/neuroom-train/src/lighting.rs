//! Lighting augmentation: diffuse irradiance of real HDR environment maps as 9 spherical-harmonic
//! coefficients per colour channel, and re-lighting of captured pixels by their surface normal.
//!
//! The augmentation treats a captured colour as the surface's albedo seen under roughly even light and
//! re-shades it with the irradiance of another environment: `relit = linear(c) · E(n) / π`, with the map
//! normalised to mean radiance 1, so a uniform white environment leaves colours unchanged and only the
//! map's colour and directionality change the image. Each map gets its own learned light code.

use glam::Vec3;

/// Irradiance convolution weights Â_l for bands 0, 1, 2 (Ramamoorthi and Hanrahan 2001).
const BAND_WEIGHTS: [f32; 3] = [
    std::f32::consts::PI,
    2.0 * std::f32::consts::PI / 3.0,
    std::f32::consts::PI / 4.0,
];

/// Real spherical harmonics of bands 0–2 at a unit direction, in the order
/// (0,0), (1,−1), (1,0), (1,1), (2,−2), (2,−1), (2,0), (2,1), (2,2).
pub fn sh9(d: Vec3) -> [f32; 9] {
    let (x, y, z) = (d.x, d.y, d.z);
    [
        0.282_095,
        0.488_603 * y,
        0.488_603 * z,
        0.488_603 * x,
        1.092_548 * x * y,
        1.092_548 * y * z,
        0.315_392 * (3.0 * z * z - 1.0),
        1.092_548 * x * z,
        0.546_274 * (x * x - y * y),
    ]
}

/// Band of each of the nine coefficients.
const BAND_OF: [usize; 9] = [0, 1, 1, 1, 2, 2, 2, 2, 2];

/// Diffuse irradiance of an environment, as SH coefficients of its radiance (per colour channel).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShIrradiance {
    /// Radiance coefficients L_lm for R, G, B.
    pub coefficients: [[f32; 9]; 3],
}

impl ShIrradiance {
    /// Projects an equirectangular radiance map (linear RGB, FORMAT.md panorama convention, z up) onto
    /// bands 0–2, after scaling it to mean radiance 1 over the sphere.
    pub fn from_equirect(width: u32, height: u32, radiance: &[[f32; 3]]) -> Self {
        assert_eq!(
            radiance.len(),
            (width * height) as usize,
            "one radiance value per pixel"
        );
        let mut coefficients = [[0.0f64; 9]; 3];
        let mut total_weight = 0.0f64;
        let mut total_luminance = 0.0f64;
        let pixel_area =
            (2.0 * std::f64::consts::PI / width as f64) * (std::f64::consts::PI / height as f64);
        for v in 0..height {
            let lat = std::f64::consts::PI * (0.5 - (v as f64 + 0.5) / height as f64);
            let weight = pixel_area * lat.cos();
            for u in 0..width {
                let lon = std::f64::consts::PI * (1.0 - 2.0 * (u as f64 + 0.5) / width as f64);
                let d = Vec3::new(
                    (lat.cos() * lon.cos()) as f32,
                    (lat.cos() * lon.sin()) as f32,
                    lat.sin() as f32,
                );
                let l = radiance[(v * width + u) as usize];
                let basis = sh9(d);
                for (c, coeff) in coefficients.iter_mut().enumerate() {
                    for (k, b) in basis.iter().enumerate() {
                        coeff[k] += weight * (l[c] * b) as f64;
                    }
                }
                total_weight += weight;
                total_luminance += weight * luminance(l) as f64;
            }
        }
        let mean = (total_luminance / total_weight).max(1e-12);
        Self {
            coefficients: coefficients.map(|ch| ch.map(|x| (x / mean) as f32)),
        }
    }

    /// Irradiance E(n) arriving at a surface with unit normal `n` (linear RGB, non-negative).
    pub fn irradiance(&self, n: Vec3) -> [f32; 3] {
        let basis = sh9(n);
        self.coefficients.map(|ch| {
            let e: f32 = (0..9)
                .map(|k| BAND_WEIGHTS[BAND_OF[k]] * ch[k] * basis[k])
                .sum();
            e.max(0.0)
        })
    }

    /// Re-lights a linear colour seen on a surface with normal `n`: `c · E(n) / π`.
    pub fn relight(&self, linear_color: [f32; 3], n: Vec3) -> [f32; 3] {
        let e = self.irradiance(n);
        std::array::from_fn(|c| linear_color[c] * e[c] / std::f32::consts::PI)
    }
}

/// Rec. 709 luminance of a linear colour.
fn luminance(c: [f32; 3]) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(width: u32, height: u32, f: impl Fn(Vec3) -> [f32; 3]) -> Vec<[f32; 3]> {
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
        out
    }

    #[test]
    fn uniform_white_environment_leaves_colours_unchanged() {
        let sh = ShIrradiance::from_equirect(128, 64, &map(128, 64, |_| [3.0; 3]));
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
        let sh = ShIrradiance::from_equirect(
            256,
            128,
            &map(256, 128, |d| if d.z > 0.0 { [1.0; 3] } else { [0.0; 3] }),
        );
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
        let sh = ShIrradiance::from_equirect(
            128,
            64,
            &map(128, 64, |d| {
                if d.x > 0.5 {
                    [4.0, 1.0, 0.5]
                } else {
                    [0.5, 0.5, 0.5]
                }
            }),
        );
        let front = sh.irradiance(Vec3::X);
        let back = sh.irradiance(-Vec3::X);
        assert!(
            front[0] > front[2] * 2.0 && front[0] > back[0] * 2.0,
            "{front:?} {back:?}"
        );
    }
}

//! Order-2 spherical harmonics of environment lighting: nine coefficients per colour channel that give the
//! diffuse irradiance `E(n)` for any normal (Ramamoorthi and Hanrahan 2001). Both the synthetic renderer
//! (ambient light) and the lighting augmentation of training shade with it.

use glam::{DVec2, Vec3};

use crate::formats::EnvMap;

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

/// Convolution of each coefficient's band with the clamped cosine: π, 2π/3 and π/4 for bands 0, 1, 2.
pub const COSINE_LOBE: [f32; 9] = {
    use std::f32::consts::{FRAC_PI_3, FRAC_PI_4, PI};
    [
        PI,
        2.0 * FRAC_PI_3,
        2.0 * FRAC_PI_3,
        2.0 * FRAC_PI_3,
        FRAC_PI_4,
        FRAC_PI_4,
        FRAC_PI_4,
        FRAC_PI_4,
        FRAC_PI_4,
    ]
};

/// Radiance coefficients `L_lm` (per channel, linear RGB) of an environment map.
pub fn project_radiance(map: &EnvMap) -> [Vec3; 9] {
    let (w, h) = (map.width as usize, map.height as usize);
    let mut coeffs = [[0.0f64; 3]; 9];
    for v in 0..h {
        let lat = std::f64::consts::PI * (0.5 - (v as f64 + 0.5) / h as f64);
        let solid_angle =
            lat.cos() * (std::f64::consts::PI / h as f64) * (std::f64::consts::TAU / w as f64);
        for u in 0..w {
            let d = map
                .direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5))
                .as_vec3();
            let radiance = map.data[v * w + u];
            for (c, y) in coeffs.iter_mut().zip(sh9(d)) {
                for (k, l) in radiance.iter().enumerate() {
                    c[k] += (l * y) as f64 * solid_angle;
                }
            }
        }
    }
    coeffs.map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32))
}

/// Irradiance `E(n)` (non-negative, linear RGB) on a surface with unit normal `n`, from radiance
/// coefficients.
pub fn irradiance(radiance: &[Vec3; 9], n: Vec3) -> Vec3 {
    let basis = sh9(n);
    let e: Vec3 = (0..9)
        .map(|k| radiance[k] * (COSINE_LOBE[k] * basis[k]))
        .sum();
    e.max(Vec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn envmap(w: u32, h: u32, f: impl Fn(Vec3) -> [f32; 3]) -> EnvMap {
        let probe = EnvMap::new(w, h, vec![[0.0; 3]; (w * h) as usize]).unwrap();
        let data = (0..w * h)
            .map(|i| {
                f(probe
                    .direction(DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5))
                    .as_vec3())
            })
            .collect();
        EnvMap::new(w, h, data).unwrap()
    }

    #[test]
    fn constant_radiance_gives_pi_irradiance_everywhere() {
        let l = project_radiance(&envmap(64, 32, |_| [1.0, 0.5, 0.25]));
        for n in [Vec3::X, Vec3::Z, -Vec3::Y, Vec3::ONE.normalize()] {
            let e = irradiance(&l, n);
            assert!(
                (e - Vec3::new(1.0, 0.5, 0.25) * std::f32::consts::PI)
                    .abs()
                    .max_element()
                    < 0.01,
                "{e}"
            );
        }
    }

    #[test]
    fn light_from_above_matches_the_clamped_cosine_integral() {
        // Radiance 1 on the upper hemisphere: exact irradiance is π (1 + cos θ) / 2 at tilt θ.
        let l = project_radiance(&envmap(256, 128, |d| {
            if d.z > 0.0 { [1.0; 3] } else { [0.0; 3] }
        }));
        let pi = std::f32::consts::PI;
        assert!((irradiance(&l, Vec3::Z).x - pi).abs() < 0.05 * pi);
        assert!((irradiance(&l, Vec3::X).x - pi / 2.0).abs() < 0.03 * pi);
        assert!(irradiance(&l, -Vec3::Z).x < 0.05 * pi);
    }
}

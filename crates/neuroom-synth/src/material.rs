//! Surface materials: a textured Lambertian albedo plus an optional Blinn–Phong lobe that gives
//! local highlights under point and area lights.

use glam::{Vec2, Vec3};

use crate::texture::Texture;

/// A surface's reflectance.
#[derive(Clone, Debug)]
pub struct Material {
    /// Human-readable name (from the MTL file or the catalog).
    pub name: String,
    /// Diffuse albedo source (linear RGB).
    pub albedo: Texture,
    /// Weight of the Blinn–Phong lobe (0 = matte).
    pub specular: f32,
    /// Blinn–Phong exponent (larger = tighter highlight).
    pub shininess: f32,
}

impl Material {
    /// A matte material.
    pub fn diffuse(name: &str, albedo: Texture) -> Self {
        Self {
            name: name.into(),
            albedo,
            specular: 0.0,
            shininess: 1.0,
        }
    }

    /// A material with a highlight.
    pub fn glossy(name: &str, albedo: Texture, specular: f32, shininess: f32) -> Self {
        Self {
            name: name.into(),
            albedo,
            specular,
            shininess,
        }
    }

    /// Albedo at a texture coordinate.
    pub fn albedo_at(&self, uv: Vec2) -> Vec3 {
        self.albedo.sample(uv)
    }

    /// BRDF value (per steradian) for light direction `l` and view direction `v` (both pointing
    /// away from the surface) and normal `n`, given the albedo there. Energy-normalised Blinn–Phong.
    pub fn brdf(&self, albedo: Vec3, n: Vec3, l: Vec3, v: Vec3) -> Vec3 {
        let diffuse = albedo * std::f32::consts::FRAC_1_PI;
        if self.specular <= 0.0 {
            return diffuse;
        }
        let h = (l + v).normalize_or_zero();
        let nh = n.dot(h).max(0.0);
        let norm = (self.shininess + 8.0) / (8.0 * std::f32::consts::PI);
        diffuse * (1.0 - self.specular)
            + Vec3::splat(self.specular * norm * nh.powf(self.shininess))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Directional albedo by Monte Carlo over the hemisphere must not exceed 1 (energy conservation).
    #[test]
    fn brdf_conserves_energy() {
        let m = Material::glossy("m", Texture::solid(Vec3::ONE), 0.3, 40.0);
        let n = Vec3::Z;
        let v = Vec3::new(0.3, 0.0, 1.0).normalize();
        let steps = 400;
        let mut sum = 0.0;
        for i in 0..steps {
            for j in 0..steps {
                let z = (i as f32 + 0.5) / steps as f32;
                let phi = std::f32::consts::TAU * (j as f32 + 0.5) / steps as f32;
                let r = (1.0 - z * z).sqrt();
                let l = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                sum += m.brdf(Vec3::ONE, n, l, v).x * z;
            }
        }
        let albedo = sum * std::f32::consts::TAU / (steps * steps) as f32;
        assert!(albedo < 1.02 && albedo > 0.8, "{albedo}");
    }
}

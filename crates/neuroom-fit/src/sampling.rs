//! Which panorama pixels a fit iteration renders: `n` on the objects of the current estimate (their boxes
//! projected into the panorama, dilated by a 5×5 window) and a fraction of `n` on the rest, both drawn
//! with probability ∝ cos(latitude) so that the stretched rows near the poles of the equirectangular image
//! are not over-sampled. Seeded and deterministic.

use glam::Vec3;
use neuroom_core::Pose;
use neuroom_core::camera::{CameraModel, Equirect};
use neuroom_render::SceneObject;
use rand::Rng;
use rayon::prelude::*;

/// Pixel lists of the object and background regions with cumulative latitude weights.
#[derive(Clone, Debug, Default)]
pub struct PixelSampler {
    object: Region,
    background: Region,
}

/// Pixels of one region and the running sum of their weights.
#[derive(Clone, Debug, Default)]
struct Region {
    pixels: Vec<u32>,
    cumulative: Vec<f32>,
}

impl Region {
    fn push(&mut self, pixel: u32, weight: f32) {
        let last = self.cumulative.last().copied().unwrap_or(0.0);
        self.pixels.push(pixel);
        self.cumulative.push(last + weight);
    }

    fn draw(&self, rng: &mut impl Rng) -> Option<u32> {
        let total = *self.cumulative.last()?;
        let x = rng.random::<f32>() * total;
        let k = self.cumulative.partition_point(|&c| c <= x);
        Some(self.pixels[k.min(self.pixels.len() - 1)])
    }
}

/// Whether a world ray from `origin` along `dir` meets the box of `o` enlarged by `padding`.
fn hits_box(o: &SceneObject, origin: Vec3, dir: Vec3, padding: f32) -> bool {
    box_entry(o, origin, dir, padding).is_some()
}

/// Where a world ray from `origin` along unit `dir` enters the box of `o` enlarged by `padding` (0 when it
/// starts inside), if it meets it.
pub fn box_entry(o: &SceneObject, origin: Vec3, dir: Vec3, padding: f32) -> Option<f32> {
    let rt = o.rotation().transpose();
    let (p, d) = (rt * (origin - o.translation), rt * dir);
    let h = o.half_extents + Vec3::splat(padding);
    let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
    for a in 0..3 {
        let inv = 1.0 / d[a];
        let (ta, tb) = ((-h[a] - p[a]) * inv, (h[a] - p[a]) * inv);
        t0 = t0.max(ta.min(tb));
        t1 = t1.min(ta.max(tb));
    }
    (t0 <= t1).then_some(t0)
}

/// The object mask of `objects` seen from `camera_to_world`: a pixel is set when its ray meets a box.
pub fn object_mask(
    camera: &Equirect,
    camera_to_world: &Pose,
    objects: &[SceneObject],
    padding: f32,
) -> Vec<bool> {
    let w = camera.width as usize;
    let origin = camera_to_world.translation.as_vec3();
    let mut mask = vec![false; w * camera.height as usize];
    mask.par_chunks_mut(w).enumerate().for_each(|(v, row)| {
        for (u, m) in row.iter_mut().enumerate() {
            let dir = camera_to_world
                .transform_vector(
                    camera.direction(glam::DVec2::new(u as f64 + 0.5, v as f64 + 0.5)),
                )
                .as_vec3();
            *m = objects.iter().any(|o| hits_box(o, origin, dir, padding));
        }
    });
    mask
}

/// `mask` dilated by a square window of half-width `radius` (5×5 for 2), wrapping around in longitude.
pub fn dilate(mask: &[bool], width: usize, radius: usize) -> Vec<bool> {
    let height = mask.len() / width;
    let r = radius as isize;
    let mut rows = vec![false; mask.len()];
    for v in 0..height {
        for u in 0..width {
            rows[v * width + u] = (-r..=r).any(|du| {
                let uu = (u as isize + du).rem_euclid(width as isize) as usize;
                mask[v * width + uu]
            });
        }
    }
    (0..mask.len())
        .map(|i| {
            let (u, v) = (i % width, (i / width) as isize);
            (-r..=r).any(|dv| {
                let vv = v + dv;
                vv >= 0 && (vv as usize) < height && rows[vv as usize * width + u]
            })
        })
        .collect()
}

impl PixelSampler {
    /// Splits the panorama's pixels by `mask` (row-major, `camera`'s size) with cos-latitude weights.
    pub fn new(camera: &Equirect, mask: &[bool]) -> Self {
        let (w, h) = (camera.width as usize, camera.height as usize);
        let mut sampler = PixelSampler::default();
        for v in 0..h {
            let lat = std::f32::consts::PI * (0.5 - (v as f32 + 0.5) / h as f32);
            let weight = lat.cos();
            for u in 0..w {
                let i = v * w + u;
                let region = if mask[i] {
                    &mut sampler.object
                } else {
                    &mut sampler.background
                };
                region.push(i as u32, weight);
            }
        }
        sampler
    }

    /// Pixels on the objects.
    pub fn object_pixels(&self) -> usize {
        self.object.pixels.len()
    }

    /// Draws `n_object` pixels on the objects and `n_background` elsewhere (fewer if a region is empty)
    /// into `out` (linear pixel indices).
    pub fn draw(
        &self,
        n_object: usize,
        n_background: usize,
        rng: &mut impl Rng,
        out: &mut Vec<u32>,
    ) {
        out.clear();
        out.extend((0..n_object).filter_map(|_| self.object.draw(rng)));
        out.extend((0..n_background).filter_map(|_| self.background.draw(rng)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;
    use rand::SeedableRng;
    use rand_pcg::Pcg64Mcg;

    #[test]
    fn dilation_is_a_square_window_that_wraps_in_longitude() {
        let (w, h) = (8, 6);
        let mut mask = vec![false; w * h];
        mask[2 * w] = true;
        let d = dilate(&mask, w, 2);
        let set: Vec<(usize, usize)> = (0..w * h)
            .filter(|&i| d[i])
            .map(|i| (i % w, i / w))
            .collect();
        assert_eq!(set.len(), 25);
        assert!(set.contains(&(6, 0)) && set.contains(&(2, 4)) && !set.contains(&(3, 2)));
    }

    #[test]
    fn draws_are_seeded_split_by_the_mask_and_biased_to_the_equator() {
        let camera = Equirect::new(64, 32).unwrap();
        let pose = Pose::new(glam::DMat3::IDENTITY, DVec3::new(0.0, 0.0, 1.0));
        let object = SceneObject::new(
            0,
            1,
            &Pose::new(glam::DMat3::IDENTITY, DVec3::new(2.0, 0.0, 1.0)),
            Vec3::splat(0.5),
        );
        let mask = object_mask(&camera, &pose, &[object], 0.0);
        // The box subtends ±14° around the centre column.
        assert!(mask[16 * 64 + 32] && !mask[16 * 64] && !mask[2 * 64 + 32]);
        let sampler = PixelSampler::new(&camera, &mask);
        let draw = |seed| {
            let mut out = Vec::new();
            sampler.draw(100, 4000, &mut Pcg64Mcg::seed_from_u64(seed), &mut out);
            out
        };
        let (a, b) = (draw(3), draw(3));
        assert_eq!(a, b);
        assert!(a[..100].iter().all(|&p| mask[p as usize]));
        assert!(a[100..].iter().all(|&p| !mask[p as usize]));
        let rows = |lo: u32, hi: u32| {
            a[100..]
                .iter()
                .filter(|&&p| (lo..hi).contains(&(p / 64)))
                .count()
        };
        // Polar bands (cos lat ≈ 0.1) get far fewer draws than equatorial ones of equal pixel count.
        assert!(rows(0, 2) * 4 < rows(15, 17));
    }
}

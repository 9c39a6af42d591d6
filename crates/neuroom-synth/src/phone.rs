//! What a phone delivers instead of a renderer's exact capture: LiDAR depth on its own coarse grid
//! (256 × 192 over the colour frame's view), noisy and with holes; poses off by what
//! visual-inertial tracking drifts; every frame auto-exposed and white-balanced on its own, some
//! blurred by the hand's motion, all written as JPEG. [`PhoneModel::degrade_frame`] turns one exact frame into such a frame, from a
//! seed, so the same seed gives the same degraded room.

use glam::{DMat3, DVec3};
use neuroom_core::camera_effects::CameraEffect;
use neuroom_core::depth_upsample::upsample_depth;
use neuroom_core::formats::DepthNoise;
use neuroom_core::image::{DepthImage, Image, RgbaImage};
use neuroom_core::pose::Pose;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// Raised whenever [`PhoneModel::default`] degrades a frame differently, so that copies degraded by
/// an older model are not taken for current ones (`neuroom bench phone` keys its copies by it).
pub const PHONE_MODEL_REVISION: u32 = 2;

/// The strengths of a phone's imperfections, each with where it comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhoneModel {
    /// The LiDAR's samples (columns, rows) over the colour frame's view: an iPhone's depth map is
    /// 256 × 192 whatever its colour frame's resolution, registered to the same view, so it resolves
    /// a fixed angle (about a quarter of a degree), not a fixed share of the colour's pixels. A frame
    /// smaller than that gets one sample per pixel.
    pub lidar_samples: (u32, u32),
    /// Depth noise standard deviation and its growth with distance (a LiDAR's); the degraded
    /// captures declare it, so training knows how far their depth can be trusted.
    pub depth_noise: DepthNoise,
    /// Beyond this range (metres) the LiDAR returns nothing.
    pub max_range: f32,
    /// A depth sample whose neighbours differ from it by more than this fraction of its depth lies on
    /// an edge, where the LiDAR's wide footprint mixes surfaces: it is dropped.
    pub edge_jump: f32,
    /// The share of the remaining samples dropped at random (dark and specular surfaces).
    pub dropout: f64,
    /// Pose error in translation, centimetres.
    pub pose_error_cm: (f64, f64),
    /// Pose error in rotation, degrees.
    pub pose_error_deg: (f64, f64),
    /// Auto-exposure: a gain of 2^u with u uniform in ± this many stops.
    pub exposure_stops: f32,
    /// White balance: red and blue gains uniform in 1 ± this.
    pub white_balance: f32,
    /// The share of frames blurred by the hand's motion.
    pub blurred_share: f64,
    /// The longest blur, in pixels (at 640 pixels wide; scaled with the frame).
    pub blur_px: f64,
    /// JPEG quality of the written frames.
    pub jpeg_quality: u8,
}

impl Default for PhoneModel {
    fn default() -> Self {
        Self {
            lidar_samples: (256, 192),
            depth_noise: DepthNoise::PHONE_LIDAR,
            max_range: 5.0,
            edge_jump: 0.1,
            dropout: 0.02,
            pose_error_cm: (1.0, 2.0),
            pose_error_deg: (0.5, 1.0),
            exposure_stops: 0.5,
            white_balance: 0.1,
            blurred_share: 0.3,
            blur_px: 6.0,
            jpeg_quality: 85,
        }
    }
}

/// One frame as the phone delivered it.
#[derive(Clone, Debug)]
pub struct PhoneFrame {
    /// Colour (alpha as the exact frame had it).
    pub rgba: RgbaImage,
    /// Depth at the colour's size (the LiDAR samples upsampled), 0 where there is none.
    pub depth: Option<DepthImage>,
    /// The pose the phone's tracking reported.
    pub camera_to_world: Pose,
}

impl PhoneModel {
    /// `rgba`, `depth` and `camera_to_world` of one exact frame as the phone would have delivered
    /// them, drawn from `seed`.
    pub fn degrade_frame(
        &self,
        rgba: &RgbaImage,
        depth: Option<&DepthImage>,
        camera_to_world: &Pose,
        seed: u64,
    ) -> Result<PhoneFrame, String> {
        let mut rng = Pcg64::seed_from_u64(seed);
        let pose = self.jitter_pose(camera_to_world, &mut rng);
        let depth = depth.map(|d| self.lidar_depth(d, &mut rng));
        let rgba = self.colour(rgba, &mut rng)?;
        Ok(PhoneFrame {
            rgba,
            depth,
            camera_to_world: pose,
        })
    }

    /// `pose` moved by a random translation and turned about a random axis, each of a size uniform in
    /// its range.
    pub fn jitter_pose(&self, pose: &Pose, rng: &mut Pcg64) -> Pose {
        let shift = random_direction(rng)
            * rng.random_range(self.pose_error_cm.0..=self.pose_error_cm.1)
            / 100.0;
        let angle = rng
            .random_range(self.pose_error_deg.0..=self.pose_error_deg.1)
            .to_radians();
        let turn = DMat3::from_axis_angle(random_direction(rng), angle);
        Pose::new(turn * pose.rotation, pose.translation + shift)
    }

    /// `depth` as the LiDAR measures it: one sample per cell of its grid ([`Self::lidar_samples`],
    /// the cell's centre pixel's depth), dropped on edges, beyond range and at random, noisy,
    /// brought back to the frame's size as an importer does ([`upsample_depth`]).
    pub fn lidar_depth(&self, depth: &DepthImage, rng: &mut Pcg64) -> DepthImage {
        let (w, h) = (depth.width, depth.height);
        let cols = self.lidar_samples.0.clamp(1, w);
        let rows = self.lidar_samples.1.clamp(1, h);
        let at = |c: i64, r: i64| {
            let c = c.clamp(0, cols as i64 - 1) as u32;
            let r = r.clamp(0, rows as i64 - 1) as u32;
            let u = (((c as f64 + 0.5) * w as f64 / cols as f64) as u32).min(w - 1);
            let v = (((r as f64 + 0.5) * h as f64 / rows as f64) as u32).min(h - 1);
            *depth.get(u, v)
        };
        let mut samples = Image::filled(cols, rows, 0.0f32);
        for r in 0..rows as i64 {
            for c in 0..cols as i64 {
                let d = at(c, r);
                let neighbours = [at(c - 1, r), at(c + 1, r), at(c, r - 1), at(c, r + 1)];
                let on_edge = neighbours
                    .iter()
                    .any(|&n| (n - d).abs() > self.edge_jump * d || n <= 0.0);
                let dropped = rng.random_bool(self.dropout);
                if d <= 0.0 || d > self.max_range || on_edge || dropped {
                    continue;
                }
                let sigma = self.depth_noise.sigma_at(d);
                let noisy = d + sigma * standard_normal(rng);
                samples.set(c as u32, r as u32, noisy.max(0.01));
            }
        }
        upsample_depth(&samples, w, h)
    }

    /// `rgba` auto-exposed, white-balanced, perhaps blurred, and through JPEG; alpha unchanged.
    fn colour(&self, rgba: &RgbaImage, rng: &mut Pcg64) -> Result<RgbaImage, String> {
        let mut rgb = rgba.map(|p| [p[0], p[1], p[2]]);
        if rng.random_bool(self.blurred_share) {
            let length = rng.random_range(1.0..=self.blur_px) * rgb.width as f64 / 640.0;
            let angle = rng.random_range(0.0..std::f64::consts::PI);
            rgb = motion_blur(&rgb, length, angle);
        }
        let gain = 2f32.powf(rng.random_range(-self.exposure_stops..=self.exposure_stops));
        let wb = self.white_balance;
        let gains = [
            rng.random_range(1.0 - wb..=1.0 + wb),
            1.0,
            rng.random_range(1.0 - wb..=1.0 + wb),
        ];
        let pose = Pose::IDENTITY;
        for effect in [
            CameraEffect::Exposure { gain },
            CameraEffect::WhiteBalance { gains },
            CameraEffect::Jpeg {
                quality: self.jpeg_quality,
            },
        ] {
            rgb = effect.apply(&rgb, &pose)?.image;
        }
        Ok(Image {
            width: rgba.width,
            height: rgba.height,
            data: rgb
                .data
                .iter()
                .zip(&rgba.data)
                .map(|(c, a)| [c[0], c[1], c[2], a[3]])
                .collect(),
        })
    }
}

/// A uniformly random unit vector.
fn random_direction(rng: &mut Pcg64) -> DVec3 {
    loop {
        let v = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if let Some(unit) = v.try_normalize().filter(|_| v.length() <= 1.0) {
            return unit;
        }
    }
}

/// A standard normal draw (Box–Muller).
fn standard_normal(rng: &mut Pcg64) -> f32 {
    let u1: f64 = rng.random_range(f64::EPSILON..1.0);
    let u2: f64 = rng.random();
    ((-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()) as f32
}

/// `rgb` averaged along a line of `length` pixels at `angle` (radians from the image's x axis).
fn motion_blur(
    rgb: &neuroom_core::image::RgbImage,
    length: f64,
    angle: f64,
) -> neuroom_core::image::RgbImage {
    let taps = (length.round() as i64).max(1);
    if taps == 1 {
        return rgb.clone();
    }
    let (dy, dx) = angle.sin_cos();
    let (w, h) = (rgb.width as i64, rgb.height as i64);
    let mut out = rgb.clone();
    for v in 0..h {
        for u in 0..w {
            let mut acc = [0.0f32; 3];
            for t in 0..taps {
                let s = t as f64 - (taps - 1) as f64 / 2.0;
                let su = (u as f64 + s * dx).round().clamp(0.0, (w - 1) as f64) as u32;
                let sv = (v as f64 + s * dy).round().clamp(0.0, (h - 1) as f64) as u32;
                let c = rgb.get(su, sv);
                (0..3).for_each(|k| acc[k] += c[k]);
            }
            out.set(u as u32, v as u32, acc.map(|a| a / taps as f32));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wall(w: u32, h: u32) -> DepthImage {
        // A wall 2 m away with a box 1 m away in its middle third.
        let mut d = Image::filled(w, h, 2.0f32);
        for v in h / 3..2 * h / 3 {
            for u in w / 3..2 * w / 3 {
                d.set(u, v, 1.0);
            }
        }
        d
    }

    #[test]
    fn lidar_depth_is_coarse_noisy_and_has_holes_on_edges() {
        let model = PhoneModel::default();
        // Twice the LiDAR's grid, as a phone's colour frames are larger than its depth.
        let exact = wall(512, 384);
        let depth = model.lidar_depth(&exact, &mut Pcg64::seed_from_u64(3));
        let mut errors = Vec::new();
        let mut holes_on_edge = 0;
        for v in 0..384 {
            for u in 0..512 {
                let (d, e) = (*depth.get(u, v), *exact.get(u, v));
                let near_edge = [(170, u), (341, u), (128, v), (256, v)]
                    .iter()
                    .any(|&(edge, x)| (x as i64 - edge as i64).abs() < 3);
                if d > 0.0 && !near_edge {
                    errors.push((d - e) as f64);
                }
                if d == 0.0 && near_edge {
                    holes_on_edge += 1;
                }
            }
        }
        let mean = errors.iter().sum::<f64>() / errors.len() as f64;
        let rms = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        assert!(mean.abs() < 0.004, "unbiased: mean {mean}");
        assert!(
            (0.005..0.03).contains(&rms),
            "about a centimetre of noise: {rms}"
        );
        assert!(holes_on_edge > 100, "edges are dropped: {holes_on_edge}");
        let coverage =
            depth.data.iter().filter(|&&d| d > 0.0).count() as f64 / depth.data.len() as f64;
        assert!((0.6..0.99).contains(&coverage), "coverage {coverage}");
        // One sample per 2 × 2 pixels, interpolated: neighbouring pixels share their samples'
        // noise, and differ by about half of two samples' difference, √2 / 2 × its RMS
        // (independent noise would differ by √2 × its RMS).
        let steps: Vec<f64> = (0..512 - 1)
            .map(|u| (*depth.get(u + 1, 10) - *depth.get(u, 10)) as f64)
            .filter(|d| d.abs() < 0.2)
            .collect();
        let step_rms = (steps.iter().map(|d| d * d).sum::<f64>() / steps.len() as f64).sqrt();
        assert!(
            step_rms < 0.8 * rms,
            "pixel to pixel {step_rms} against noise {rms}"
        );
    }

    #[test]
    fn poses_are_off_by_what_tracking_drifts() {
        let model = PhoneModel::default();
        let mut rng = Pcg64::seed_from_u64(5);
        for _ in 0..200 {
            let truth = Pose::new(DMat3::from_rotation_z(0.3), DVec3::new(1.0, 2.0, 1.5));
            let jittered = model.jitter_pose(&truth, &mut rng);
            let cm = (jittered.translation - truth.translation).length() * 100.0;
            let deg = neuroom_core::metrics::rotation_error_deg(jittered.rotation, truth.rotation);
            assert!((0.999..=2.001).contains(&cm), "{cm} cm");
            assert!((0.499..=1.001).contains(&deg), "{deg} deg");
        }
    }

    #[test]
    fn the_same_seed_gives_the_same_frame_and_alpha_is_kept() {
        let model = PhoneModel::default();
        let rgba = Image {
            width: 64,
            height: 48,
            data: (0..64 * 48)
                .map(|i| {
                    [
                        (i % 64) as f32 / 64.0,
                        0.5,
                        0.3,
                        if i % 7 == 0 { 0.0 } else { 1.0 },
                    ]
                })
                .collect(),
        };
        let depth = wall(64, 48);
        let pose = Pose::IDENTITY;
        let a = model.degrade_frame(&rgba, Some(&depth), &pose, 11).unwrap();
        let b = model.degrade_frame(&rgba, Some(&depth), &pose, 11).unwrap();
        let c = model.degrade_frame(&rgba, Some(&depth), &pose, 12).unwrap();
        assert_eq!(a.rgba.data, b.rgba.data);
        assert_eq!(
            a.depth.as_ref().unwrap().data,
            b.depth.as_ref().unwrap().data
        );
        assert_ne!(a.rgba.data, c.rgba.data);
        assert!(
            a.rgba
                .data
                .iter()
                .zip(&rgba.data)
                .all(|(x, y)| x[3] == y[3])
        );
    }
}

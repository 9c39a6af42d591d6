//! What a real camera does to a panorama that a renderer does not: it is held tilted, it exposes and
//! white-balances on its own, it writes JPEG and its sensor adds noise. Each effect maps an image (and,
//! for a tilt, its camera) to what such a camera would have delivered, so benchmarks can measure what
//! each costs and training can show the identification network such panoramas. Seeded: the same effect
//! gives the same image.

use glam::{DMat3, DVec2, DVec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::camera::{CameraModel, Equirect};
use crate::image::{RgbImage, linear_to_srgb, srgb_to_linear};
use crate::pose::Pose;

/// One camera effect.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CameraEffect {
    /// The camera turned `degrees` about a horizontal axis of its own frame at `axis_deg` from its
    /// forward direction (0: pitched, 90: rolled): a hand-held or robot-mounted camera that is not level.
    Tilt {
        /// Angle of the tilt.
        degrees: f64,
        /// Direction of the tilt's axis in the camera's horizontal plane, degrees from forward.
        axis_deg: f64,
    },
    /// Every pixel's light multiplied by `gain` (×2: one stop over), clipped as a sensor clips.
    Exposure {
        /// Gain on linear light.
        gain: f32,
    },
    /// Per-channel gains on linear light: another white balance.
    WhiteBalance {
        /// Gains of red, green and blue.
        gains: [f32; 3],
    },
    /// Written as a JPEG of `quality` (1–100) and read back.
    Jpeg {
        /// JPEG quality.
        quality: u8,
    },
    /// Sensor noise on linear light: shot noise (variance `shot · signal`) plus read noise (`read`
    /// standard deviation), drawn from `seed`.
    Noise {
        /// Shot-noise scale (variance per unit of signal).
        shot: f32,
        /// Read-noise standard deviation.
        read: f32,
        /// Seed of the draw.
        seed: u64,
    },
}

/// A panorama as a camera with an effect delivered it, and the camera it was then taken from.
#[derive(Clone, Debug)]
pub struct AffectedPanorama {
    /// The image.
    pub image: RgbImage,
    /// The camera (world frame) of that image: the original camera, tilted by a [`CameraEffect::Tilt`].
    pub camera_to_world: Pose,
}

impl CameraEffect {
    /// The named effects of the suite's camera benchmark, at the strengths real cameras reach: a 10°
    /// tilt, one stop under and over, a warm and a cold white balance, JPEG at quality 80 and the noise
    /// of a small sensor in a dim room.
    pub fn named(name: &str) -> Option<Self> {
        Some(match name {
            "tilt" => Self::Tilt {
                degrees: 10.0,
                axis_deg: 35.0,
            },
            "underexposed" => Self::Exposure { gain: 0.5 },
            "overexposed" => Self::Exposure { gain: 2.0 },
            "warm" => Self::WhiteBalance {
                gains: [1.25, 1.0, 0.75],
            },
            "cold" => Self::WhiteBalance {
                gains: [0.8, 1.0, 1.3],
            },
            "jpeg" => Self::Jpeg { quality: 80 },
            "noise" => Self::Noise {
                shot: 0.004,
                read: 0.01,
                seed: 7,
            },
            _ => return None,
        })
    }

    /// The names [`CameraEffect::named`] knows.
    pub const NAMES: [&'static str; 7] = [
        "tilt",
        "underexposed",
        "overexposed",
        "warm",
        "cold",
        "jpeg",
        "noise",
    ];

    /// `image`, taken from `camera_to_world`, as a camera with this effect would have delivered it.
    /// A tilt needs a full panorama (width = 2 × height).
    pub fn apply(
        &self,
        image: &RgbImage,
        camera_to_world: &Pose,
    ) -> Result<AffectedPanorama, String> {
        let same_camera = |image| AffectedPanorama {
            image,
            camera_to_world: *camera_to_world,
        };
        Ok(match *self {
            Self::Tilt { degrees, axis_deg } => {
                let tilt = tilt_rotation(degrees, axis_deg);
                AffectedPanorama {
                    image: rotate_panorama(image, &tilt)?,
                    camera_to_world: camera_to_world.compose(&Pose::new(tilt, DVec3::ZERO)),
                }
            }
            Self::Exposure { gain } => same_camera(map_linear(image, |c, _| c * gain)),
            Self::WhiteBalance { gains } => same_camera(map_linear(image, |c, k| c * gains[k])),
            Self::Jpeg { quality } => same_camera(jpeg_round_trip(image, quality)?),
            Self::Noise { shot, read, seed } => same_camera(add_noise(image, shot, read, seed)),
        })
    }
}

/// The rotation of a camera tilted by `degrees` about the horizontal axis at `axis_deg` from forward
/// (in the panorama camera frame: x forward, y left, z up).
fn tilt_rotation(degrees: f64, axis_deg: f64) -> DMat3 {
    let (s, c) = axis_deg.to_radians().sin_cos();
    DMat3::from_axis_angle(DVec3::new(c, s, 0.0), degrees.to_radians())
}

/// The panorama seen by a camera turned by `rotation` (new camera frame → old camera frame) about its
/// centre: every pixel looks along its direction turned into the old frame, sampled bilinearly (the
/// seam wraps, the poles clamp). Errors unless `image` is twice as wide as high.
pub fn rotate_panorama(image: &RgbImage, rotation: &DMat3) -> Result<RgbImage, String> {
    let camera = Equirect::new(image.width, image.height)?;
    let mut out = RgbImage::filled(image.width, image.height, [0.0; 3]);
    for v in 0..image.height {
        for u in 0..image.width {
            let d = camera.direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
            let (pixel, _) = camera
                .project(*rotation * d)
                .expect("a unit direction projects");
            out.set(u, v, sample_wrapped(image, pixel));
        }
    }
    Ok(out)
}

/// Bilinear sample at continuous pixel coordinates, wrapping across the seam and clamping rows.
fn sample_wrapped(image: &RgbImage, pixel: DVec2) -> [f32; 3] {
    let (w, h) = (image.width as i64, image.height as i64);
    let x = pixel.x - 0.5;
    let y = (pixel.y - 0.5).clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = ((x - x0) as f32, (y - y0) as f32);
    let at = |dx: i64, dy: i64| {
        let u = (x0 as i64 + dx).rem_euclid(w) as u32;
        let v = (y0 as i64 + dy).clamp(0, h - 1) as u32;
        *image.get(u, v)
    };
    let (a, b, c, d) = (at(0, 0), at(1, 0), at(0, 1), at(1, 1));
    std::array::from_fn(|k| {
        (a[k] * (1.0 - fx) + b[k] * fx) * (1.0 - fy) + (c[k] * (1.0 - fx) + d[k] * fx) * fy
    })
}

/// Applies `f(linear value, channel)` to every channel in linear light, then clips to [0, 1].
fn map_linear(image: &RgbImage, f: impl Fn(f32, usize) -> f32) -> RgbImage {
    image.map(|p| std::array::from_fn(|k| linear_to_srgb(f(srgb_to_linear(p[k]), k))))
}

/// `image` written as a JPEG of `quality` and decoded again.
fn jpeg_round_trip(image: &RgbImage, quality: u8) -> Result<RgbImage, String> {
    let bytes: Vec<u8> = image
        .data
        .iter()
        .flat_map(|p| p.map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8))
        .collect();
    let mut jpeg = Vec::new();
    image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, quality.clamp(1, 100))
        .encode(
            &bytes,
            image.width,
            image.height,
            image::ExtendedColorType::Rgb8,
        )
        .map_err(|e| format!("JPEG encoding: {e}"))?;
    let decoded = image::load_from_memory_with_format(&jpeg, image::ImageFormat::Jpeg)
        .map_err(|e| format!("JPEG decoding: {e}"))?
        .to_rgb8();
    Ok(RgbImage {
        width: image.width,
        height: image.height,
        data: decoded
            .pixels()
            .map(|p| p.0.map(|c| c as f32 / 255.0))
            .collect(),
    })
}

/// Shot and read noise on linear light, drawn from `seed` (Box–Muller normals).
fn add_noise(image: &RgbImage, shot: f32, read: f32, seed: u64) -> RgbImage {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut normal = move || {
        let (u1, u2): (f32, f32) = (rng.random::<f32>().max(1e-12), rng.random());
        (-2.0 * u1.ln()).sqrt() * (std::f32::consts::TAU * u2).cos()
    };
    let data = image
        .data
        .iter()
        .map(|p| {
            std::array::from_fn(|k| {
                let signal = srgb_to_linear(p[k]);
                let sigma = (shot * signal + read * read).sqrt();
                linear_to_srgb(signal + sigma * normal())
            })
        })
        .collect();
    RgbImage {
        width: image.width,
        height: image.height,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panorama whose colour is its pixel's viewing direction, mapped to [0, 1].
    fn direction_panorama(width: u32) -> RgbImage {
        let camera = Equirect::new(width, width / 2).unwrap();
        let mut image = RgbImage::filled(width, width / 2, [0.0; 3]);
        for v in 0..width / 2 {
            for u in 0..width {
                let d = camera.direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
                image.set(u, v, [d.x, d.y, d.z].map(|c| (0.5 + 0.5 * c) as f32));
            }
        }
        image
    }

    #[test]
    fn a_tilted_camera_sees_each_world_direction_where_its_own_frame_puts_it() {
        let image = direction_panorama(256);
        let camera = Pose::from_yaw_translation(0.7, DVec3::new(1.0, 2.0, 1.5));
        let effect = CameraEffect::Tilt {
            degrees: 10.0,
            axis_deg: 35.0,
        };
        let tilted = effect.apply(&image, &camera).unwrap();
        // The original image's colour encodes the direction in the level camera's frame; in the tilted
        // image, the pixel looking along d (tilted frame) must show that direction turned into the
        // level frame.
        let eq = Equirect::new(256, 128).unwrap();
        let to_level = camera.inverse().compose(&tilted.camera_to_world).rotation;
        let mut worst = 0.0f64;
        for (u, v) in [(10, 40), (128, 64), (200, 90), (250, 30), (70, 100)] {
            let d = eq.direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
            let want = to_level * d;
            let got = tilted.image.get(u, v).map(|c| 2.0 * c as f64 - 1.0);
            worst = worst.max((DVec3::from(got) - want).length());
        }
        assert!(worst < 0.03, "direction error {worst}");
        let angle =
            crate::metrics::rotation_error_deg(camera.rotation, tilted.camera_to_world.rotation);
        assert!((angle - 10.0).abs() < 1e-9, "{angle}");
    }

    #[test]
    fn exposure_and_white_balance_act_on_linear_light_and_clip() {
        let image = RgbImage::filled(4, 2, [0.5, 0.5, 0.5]);
        let camera = Pose::IDENTITY;
        let twice = CameraEffect::Exposure { gain: 2.0 }
            .apply(&image, &camera)
            .unwrap()
            .image;
        let want = linear_to_srgb(2.0 * srgb_to_linear(0.5));
        assert!((twice.get(0, 0)[0] - want).abs() < 1e-6);
        let balanced = CameraEffect::WhiteBalance {
            gains: [5.0, 1.0, 0.5],
        }
        .apply(&image, &camera)
        .unwrap()
        .image;
        let p = balanced.get(1, 1);
        assert!(p[0] > 0.999_999, "{}", p[0]);
        assert!((p[1] - 0.5).abs() < 1e-5 && p[2] < 0.4);
    }

    #[test]
    fn jpeg_and_noise_change_the_image_a_little_and_the_same_way_each_time() {
        let image = direction_panorama(64);
        let camera = Pose::IDENTITY;
        for name in ["jpeg", "noise"] {
            let effect = CameraEffect::named(name).unwrap();
            let a = effect.apply(&image, &camera).unwrap().image;
            let b = effect.apply(&image, &camera).unwrap().image;
            assert_eq!(a.data, b.data, "{name}");
            let mean_abs = a
                .data
                .iter()
                .zip(&image.data)
                .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).abs()).sum::<f32>() / 3.0)
                .sum::<f32>()
                / a.data.len() as f32;
            assert!(mean_abs > 1e-3 && mean_abs < 0.06, "{name}: {mean_abs}");
        }
    }

    #[test]
    fn every_named_effect_is_known() {
        for name in CameraEffect::NAMES {
            assert!(CameraEffect::named(name).is_some(), "{name}");
        }
        assert!(CameraEffect::named("fisheye").is_none());
    }
}

//! What the query camera saw, on the sphere of directions. A panorama sees every direction. A photo
//! with known intrinsics is warped onto the sphere of a level camera looking along +x (the panorama
//! frame of docs/formats.md), and sees only its field of view; localization and the object search leave the
//! rest out, so one pipeline serves both.

use glam::{DMat3, DVec2, DVec3};
use neuroom_core::camera::{CameraModel, Pinhole};
use neuroom_core::image::{RgbImage, linear_to_srgb, srgb_to_linear};
use neuroom_panorama::plane::{Plane, add_colour, downsample_rgb, for_each_target, nearest_source};
use neuroom_panorama::sphere::direction;

use crate::features::FeatureMap;

/// Rotation from the OpenGL pinhole frame (looks along −z, +y up, +x right) to the panorama frame of
/// the same camera (+x forward, +y left, +z up). A photo's `camera_to_world` is its panorama frame's
/// `camera_to_world` times this.
pub const PANORAMA_FROM_PINHOLE: DMat3 = DMat3::from_cols(
    DVec3::new(0.0, -1.0, 0.0),
    DVec3::new(0.0, 0.0, 1.0),
    DVec3::new(-1.0, 0.0, 0.0),
);

/// Least sRGB value, in every channel, of a clipped pixel as a share of the image's limit in that
/// channel ([`ClipLevel`], [`SphereImage::without_clipped`]).
pub const CLIPPED: f32 = 0.97;

/// Half a channel's linear value, as an sRGB value, where the channel is at the top of its range:
/// one stop under it.
pub const ONE_STOP_UNDER: f32 = 0.735;

/// The sensor's limit in each channel of an image, as a white-balanced, exposed image shows it.
///
/// A camera clips its raw values; its white balance then scales each channel, so a burnt-out lamp
/// is white in a neutral image but (1, 1, 0.88) in a warm one, and a clipped pixel is one at the
/// limit of *every* channel, whatever each limit is. An exposure set after the clip (a darker
/// rendition, an edit) scales all the limits alike: a window burnt out at one exposure is a flat
/// area at 0.735 a stop under it, and still no view of the room. So the limits are found at the
/// image's own top, wherever the exposure put it: each channel's limit is the brightest value it
/// takes among the pixels that reach, in some channel, [`CLIPPED`] of the image's brightest value
/// (the share it is of 1, carried to that value in linear light): those the sensor clipped
/// somewhere. An image whose brightest value is 1 keeps the limits it always had.
///
/// A white balance moves a channel by at most about a stop, so limits of which one lies more than
/// a stop (in linear light) below the brightest ([`ONE_STOP_UNDER`] where that is 1) are no
/// white-balanced clip but a saturated colour (a red at the red limit only); such an image, and an
/// empty one, has the limit 1 in every channel. Below the top of the format ([`CLIPPED`]) the limit
/// is a hypothesis, kept only where the pixels at it are at most half the image: an image mostly
/// at its own top is evenly lit, not burnt out. In an image that nothing burnt out, the pixels
/// near its brightest value seldom make an area, and [`SphereImage::without_clipped`] keeps only
/// areas; where they do (an evenly lit white surface at the image's top), that surface is left out
/// too.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipLevel {
    /// The limit of each channel (sRGB).
    pub limit: [f32; 3],
}

impl ClipLevel {
    /// The limits of an image that nothing white-balanced: 1 in every channel.
    pub const WHITE: ClipLevel = ClipLevel { limit: [1.0; 3] };

    /// The limits the `pixels` show (sRGB).
    pub fn of<'a, I>(pixels: I) -> ClipLevel
    where
        I: IntoIterator<Item = &'a [f32; 3]> + Clone,
    {
        let top = (pixels.clone().into_iter())
            .flat_map(|c| c.iter().copied())
            .fold(0.0f32, f32::max);
        if top <= 0.0 {
            return Self::WHITE;
        }
        let linear_top = srgb_to_linear(top);
        let reaches = linear_to_srgb(srgb_to_linear(CLIPPED) * linear_top);
        let mut limit = [0.0f32; 3];
        for c in pixels.clone() {
            if c.iter().any(|x| *x >= reaches) {
                for (l, x) in limit.iter_mut().zip(c) {
                    *l = l.max(*x);
                }
            }
        }
        let least = srgb_to_linear(ONE_STOP_UNDER) * linear_top;
        if !limit.iter().all(|l| srgb_to_linear(*l) >= least) {
            return Self::WHITE;
        }
        let level = ClipLevel { limit };
        if top >= CLIPPED {
            return level;
        }
        // Below the format's top the limit is a hypothesis: a darkened clip is a part of the image,
        // while an image mostly at its own top is evenly lit, not burnt out.
        let (clipped, all) = (pixels.into_iter()).fold((0usize, 0usize), |(c, n), p| {
            (c + level.clips(p) as usize, n + 1)
        });
        if 2 * clipped <= all {
            level
        } else {
            Self::WHITE
        }
    }

    /// Whether the sRGB colour `c` is at the limit of every channel.
    pub fn clips(&self, c: &[f32; 3]) -> bool {
        c.iter().zip(&self.limit).all(|(x, l)| *x >= CLIPPED * l)
    }
}

/// How far around a clipped pixel (degrees of longitude) the panorama is taken as not seen: the
/// glow just around a light source is the light's, not the room's surface.
pub const CLIPPED_GROWTH: f64 = 1.5;

/// Widest sphere image a photo is warped to (columns); finer photos are sampled bilinearly.
pub const MAX_PHOTO_SPHERE_WIDTH: usize = 2048;

/// Colours on the equirectangular sphere and which of its pixels the camera saw.
#[derive(Clone, Debug, PartialEq)]
pub struct SphereImage {
    /// Colour per pixel (`width = 2 × height`); meaningless where not seen.
    pub rgb: RgbImage,
    /// Pixels the camera saw; `None` for a panorama, which sees them all.
    pub seen: Option<Vec<bool>>,
}

impl SphereImage {
    /// A full panorama.
    pub fn panorama(rgb: RgbImage) -> Self {
        Self { rgb, seen: None }
    }

    /// `photo`, taken by `camera` held level, warped onto its panorama frame at a width that keeps the
    /// photo's resolution at its centre (at most [`MAX_PHOTO_SPHERE_WIDTH`]).
    pub fn from_photo(photo: &RgbImage, camera: &Pinhole) -> Self {
        let natural = (std::f64::consts::TAU * camera.fx.max(camera.fy)).round() as usize;
        let width = (natural.clamp(64, MAX_PHOTO_SPHERE_WIDTH) / 2) * 2;
        Self::from_photo_at(photo, camera, width)
    }

    /// [`SphereImage::from_photo`] at a given width.
    pub fn from_photo_at(photo: &RgbImage, camera: &Pinhole, width: usize) -> Self {
        let height = width / 2;
        let to_pinhole = PANORAMA_FROM_PINHOLE.transpose();
        let (data, seen): (Vec<[f32; 3]>, Vec<bool>) = (0..width * height)
            .map(|i| {
                let d = direction(
                    (i % width) as f64 + 0.5,
                    (i / width) as f64 + 0.5,
                    width,
                    height,
                );
                match camera.project(to_pinhole * d) {
                    Some((pixel, _)) if camera.in_image(pixel) => {
                        (bilinear(photo, pixel, false), true)
                    }
                    _ => ([0.0; 3], false),
                }
            })
            .unzip();
        Self {
            rgb: RgbImage {
                width: width as u32,
                height: height as u32,
                data,
            },
            seen: Some(seen),
        }
    }

    /// Columns.
    pub fn width(&self) -> usize {
        self.rgb.width as usize
    }

    /// Rows.
    pub fn height(&self) -> usize {
        self.rgb.height as usize
    }

    /// Whether pixel `i` was seen.
    pub fn sees(&self, i: usize) -> bool {
        self.seen.as_ref().is_none_or(|s| s[i])
    }

    /// The image at `width × height` by box averaging over the seen pixels; a pixel is seen when at
    /// least half of what it averages was. A pixel that averages nothing (the image enlarged) takes
    /// its nearest source pixel, seen or not, as [`downsample_rgb`] does.
    pub fn downsample(&self, width: usize, height: usize) -> SphereImage {
        let Some(seen) = &self.seen else {
            return Self::panorama(downsample_rgb(&self.rgb, width, height));
        };
        let (sw, sh) = (self.width(), self.height());
        let mut sum = vec![[0.0f32; 5]; width * height];
        for_each_target(sw, sh, width, height, |target, source| {
            let s = &mut sum[target];
            s[4] += 1.0;
            if seen[source] {
                add_colour(s, self.rgb.data[source]);
            }
        });
        let (data, small_seen) = (sum.iter().enumerate())
            .map(|(i, s)| {
                if s[4] > 0.0 {
                    (
                        std::array::from_fn(|c| s[c] / s[3].max(1.0)),
                        2.0 * s[3] >= s[4],
                    )
                } else {
                    let n = nearest_source(sw, sh, width, height, i);
                    (self.rgb.data[n], seen[n])
                }
            })
            .unzip();
        SphereImage {
            rgb: RgbImage {
                width: width as u32,
                height: height as u32,
                data,
            },
            seen: Some(small_seen),
        }
    }

    /// This image with its clipped areas (pixels at the limit of every channel, [`ClipLevel`]: a
    /// lamp, a window, a burnt-out highlight; opened, so that lone pixels at the limit stay) and the
    /// pixels within [`CLIPPED_GROWTH`] of them taken as not seen. Their
    /// colour is the sensor's limit and their edges are the light's, which the room's model does not
    /// have: a window bright in the panorama is a dark pane in the room rendered under the captures'
    /// light, and its edges there have the opposite sign.
    pub fn without_clipped(&self) -> SphereImage {
        let (w, h) = (self.width(), self.height());
        let seen = || (self.rgb.data.iter().enumerate()).filter(|(i, _)| self.sees(*i));
        let level = ClipLevel::of(seen().map(|(_, c)| c));
        let clipped: Vec<bool> = (self.rgb.data.iter().enumerate())
            .map(|(i, c)| self.sees(i) && level.clips(c))
            .collect();
        // Opened: a light source that burns out is an area; a lone pixel at the limit is a firefly
        // or noise on a bright surface, and growing each such pixel by the glow would riddle the
        // panorama with holes whose borders hold every alignment where it starts.
        let clipped = crate::evidence::dilate(&crate::evidence::erode(&clipped, w, h), w, h);
        if !clipped.iter().any(|c| *c) {
            return self.clone();
        }
        let grow = (w as f64 * CLIPPED_GROWTH / 360.0).ceil() as usize;
        let near = (0..grow).fold(clipped, |m, _| crate::evidence::dilate(&m, w, h));
        SphereImage {
            rgb: self.rgb.clone(),
            seen: Some((0..w * h).map(|i| self.sees(i) && !near[i]).collect()),
        }
    }

    /// Illumination-robust features ([`FeatureMap`]) blurred by `sigma`; for a photo, blurred over the
    /// seen pixels only, so the edge of its field of view makes no edge.
    pub fn features(&self, sigma: f32) -> FeatureMap {
        match &self.seen {
            Some(seen) => FeatureMap::masked(&self.rgb, seen, sigma),
            None => FeatureMap::new(&self.rgb, sigma),
        }
    }

    /// `depth` (one value per pixel, 0 = no surface) with the pixels not seen set to 0, so that fits
    /// over surfaces (the room's re-shading) use only what was seen.
    pub fn seen_depth<'a>(&self, depth: &'a [f32]) -> std::borrow::Cow<'a, [f32]> {
        match &self.seen {
            None => std::borrow::Cow::Borrowed(depth),
            Some(seen) => depth
                .iter()
                .zip(seen)
                .map(|(d, s)| if *s { *d } else { 0.0 })
                .collect(),
        }
    }

    /// The seen pixels as a plane of 1 (seen, with every 4-neighbour seen) and 0, for bilinear tests of
    /// whether a continuous position lies well inside the field of view; `None` for a panorama.
    pub fn seen_plane(&self) -> Option<Plane> {
        let seen = self.seen.as_ref()?;
        let inner = crate::evidence::erode(seen, self.width(), self.height());
        Some(Plane {
            width: self.width(),
            height: self.height(),
            data: inner.iter().map(|s| f32::from(*s)).collect(),
        })
    }
}

/// The photo `camera` would take from the centre of `panorama`, held level and turned by `heading`
/// (radians about +z from the panorama's +x), sampled bilinearly: a perspective view with exactly known
/// intrinsics and pose, for testing and benchmarking photo input on rooms that hold panoramas.
pub fn photo_from_panorama(panorama: &RgbImage, camera: &Pinhole, heading: f64) -> RgbImage {
    let (w, h) = (camera.width as usize, camera.height as usize);
    let (pw, ph) = (panorama.width as usize, panorama.height as usize);
    let turn = DMat3::from_rotation_z(heading) * PANORAMA_FROM_PINHOLE;
    let data = (0..w * h)
        .map(|i| {
            let ray = camera.direction(DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5));
            let at = neuroom_panorama::sphere::project(turn * ray, pw, ph).unwrap_or(DVec2::ZERO);
            bilinear(panorama, at, true)
        })
        .collect();
    RgbImage {
        width: w as u32,
        height: h as u32,
        data,
    }
}

/// Whether a direction of the panorama frame (as in [`photo_from_panorama`]) falls inside the photo of
/// `camera` turned by `heading`.
pub fn photo_sees(camera: &Pinhole, heading: f64, direction: DVec3) -> bool {
    let turn = DMat3::from_rotation_z(heading) * PANORAMA_FROM_PINHOLE;
    camera
        .project(turn.transpose() * direction)
        .is_some_and(|(pixel, _)| camera.in_image(pixel))
}

/// Bilinear sample of `image` at continuous pixel coordinates (centres at `i + 0.5`): rows clamped at
/// the borders, columns clamped too or, for a panorama (`wrap_columns`), wrapping round.
fn bilinear(image: &RgbImage, pixel: DVec2, wrap_columns: bool) -> [f32; 3] {
    let (w, h) = (image.width as usize, image.height as usize);
    let x = if wrap_columns {
        (pixel.x - 0.5).rem_euclid(w as f64)
    } else {
        (pixel.x - 0.5).clamp(0.0, (w - 1) as f64)
    };
    let y = (pixel.y - 0.5).clamp(0.0, (h - 1) as f64);
    let (x0, y0) = (x.floor() as usize % w, y.floor() as usize);
    let x1 = if wrap_columns {
        (x0 + 1) % w
    } else {
        (x0 + 1).min(w - 1)
    };
    let y1 = (y0 + 1).min(h - 1);
    let (fx, fy) = ((x - x.floor()) as f32, (y - y0 as f64) as f32);
    let at = |u: usize, v: usize| image.data[v * w + u];
    let (a, b, c, d) = (at(x0, y0), at(x1, y0), at(x0, y1), at(x1, y1));
    std::array::from_fn(|k| {
        let top = a[k] + fx * (b[k] - a[k]);
        let bottom = c[k] + fx * (d[k] - c[k]);
        top + fy * (bottom - top)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use neuroom_panorama::sphere::project;

    fn ramp_photo(w: usize, h: usize) -> RgbImage {
        RgbImage {
            width: w as u32,
            height: h as u32,
            data: (0..w * h)
                .map(|i| [(i % w) as f32 / w as f32, (i / w) as f32 / h as f32, 0.5])
                .collect(),
        }
    }

    /// `c` exposed a stop darker, as an exposure set after the sensor clipped makes it.
    fn a_stop_darker(c: [f32; 3]) -> [f32; 3] {
        c.map(|x| linear_to_srgb(0.5 * srgb_to_linear(x)))
    }

    #[test]
    fn the_pinhole_frame_maps_onto_the_panorama_frame() {
        let r = PANORAMA_FROM_PINHOLE;
        assert!((r.determinant() - 1.0).abs() < 1e-12);
        // Forward, right and up of the OpenGL camera.
        assert!((r * DVec3::NEG_Z).abs_diff_eq(DVec3::X, 1e-12));
        assert!((r * DVec3::X).abs_diff_eq(DVec3::NEG_Y, 1e-12));
        assert!((r * DVec3::Y).abs_diff_eq(DVec3::Z, 1e-12));
    }

    /// A white balance scales each channel's limit: a burnt-out window is (1, 1, 0.88) in a warm
    /// panorama and still clipped, while a colour at the limit of one channel only is not.
    #[test]
    fn a_white_balanced_window_is_clipped() {
        let warm_window = [1.0, 1.0, 0.88];
        let level = ClipLevel::of(&[[0.5, 0.4, 0.3], warm_window, [0.99, 0.8, 0.5]]);
        assert_eq!(level.limit, warm_window);
        assert!(level.clips(&warm_window));
        assert!(level.clips(&[0.98, 0.99, 0.86]));
        assert!(
            !level.clips(&[0.99, 0.8, 0.5]),
            "a colour at the red limit only"
        );
        assert_eq!(
            ClipLevel::of(&[[0.5, 0.9, 0.96]]),
            ClipLevel::WHITE,
            "nothing clipped"
        );
        assert_eq!(
            ClipLevel::of(&[[0.99, 0.8, 0.5]]),
            ClipLevel::WHITE,
            "a saturated red is no clip"
        );
        assert!(!ClipLevel::WHITE.clips(&warm_window));
        let level = ClipLevel::of(&[a_stop_darker([0.5, 0.4, 0.3]), a_stop_darker(warm_window)]);
        assert_eq!(level.limit, a_stop_darker(warm_window), "a stop darker");
        assert!(level.clips(&a_stop_darker([0.98, 0.99, 0.86])));
        assert_eq!(
            ClipLevel::of(&[a_stop_darker([0.99, 0.8, 0.5])]),
            ClipLevel::WHITE,
            "a saturated red a stop darker"
        );
        assert_eq!(
            ClipLevel::of(&[[0.4; 3]; 6]),
            ClipLevel::WHITE,
            "an evenly lit grey image"
        );
    }

    #[test]
    fn clipped_pixels_and_their_glow_are_not_seen() {
        let (w, h) = (240, 120);
        let mut rgb = ramp_photo(w, h);
        let panorama = SphereImage::panorama(rgb.clone());
        assert_eq!(panorama.without_clipped(), panorama, "nothing clipped");
        // A window: a square of white, one channel just below clipping at one pixel of it.
        for v in 50..60 {
            for u in 100..110 {
                rgb.data[v * w + u] = [1.0; 3];
            }
        }
        rgb.data[55 * w + 105] = [1.0, 1.0, 0.9];
        let masked = SphereImage::panorama(rgb.clone()).without_clipped();
        let grow = (w as f64 * CLIPPED_GROWTH / 360.0).ceil() as usize;
        assert!(!masked.sees(55 * w + 105), "inside the window");
        assert!(!masked.sees(55 * w + 100 - grow), "its glow");
        assert!(masked.sees(55 * w + 100 - grow - 1));
        assert!(masked.sees(20 * w + 30));
        // A photo keeps what it did not see unseen.
        let camera = Pinhole::new(80, 60, 50.0, 50.0, 40.0, 30.0);
        let photo = SphereImage::from_photo_at(&ramp_photo(80, 60), &camera, 240);
        let kept = photo.without_clipped();
        assert!((0..w * h).all(|i| kept.sees(i) == photo.sees(i)));
        // The window a stop darker (an exposure set after the clip) is taken out alike.
        let darker = SphereImage::panorama(rgb.map(|c| a_stop_darker(*c))).without_clipped();
        assert!((0..w * h).all(|i| darker.sees(i) == masked.sees(i)));
        // The window as a warm white balance shows it is taken out alike.
        for c in rgb.data.iter_mut().filter(|c| c.iter().all(|x| *x >= 0.9)) {
            c[2] *= 0.88;
        }
        let warm = SphereImage::panorama(rgb).without_clipped();
        assert!((0..w * h).all(|i| warm.sees(i) == masked.sees(i)));
    }

    #[test]
    fn lone_pixels_at_the_limit_are_no_light_source() {
        let (w, h) = (240, 120);
        let mut rgb = ramp_photo(w, h);
        // Fireflies: single pixels, and pairs, at the limit of every channel.
        for k in 0..40 {
            let (u, v) = (7 + 5 * k, 10 + 2 * k);
            rgb.data[v * w + u] = [1.0; 3];
            if k % 2 == 0 {
                rgb.data[v * w + u + 1] = [1.0; 3];
            }
        }
        let panorama = SphereImage::panorama(rgb.clone());
        assert_eq!(panorama.without_clipped(), panorama);
        // A lamp of 3 × 3 pixels among them is taken out with its glow.
        for v in 80..83 {
            for u in 50..53 {
                rgb.data[v * w + u] = [1.0; 3];
            }
        }
        let masked = SphereImage::panorama(rgb).without_clipped();
        assert!(!masked.sees(81 * w + 51));
        assert!(!masked.sees(81 * w + 49));
        assert!(masked.sees(10 * w + 7), "a firefly");
    }

    #[test]
    fn a_masked_image_enlarged_keeps_what_was_seen() {
        let (w, h) = (64, 32);
        let mut image = SphereImage::panorama(ramp_photo(w, h));
        // The left half seen, the right half not.
        image.seen = Some((0..w * h).map(|i| i % w < w / 2).collect());
        let large = image.downsample(4 * w, 4 * h);
        for i in 0..16 * w * h {
            let (u, v) = (i % (4 * w), i / (4 * w));
            assert_eq!(large.sees(i), u < 2 * w, "pixel ({u}, {v})");
            if large.sees(i) {
                assert_eq!(large.rgb.data[i], image.rgb.data[(v / 4) * w + u / 4]);
            }
        }
    }

    #[test]
    fn a_photo_lands_where_its_rays_point() {
        let camera = Pinhole::new(80, 60, 50.0, 50.0, 40.0, 30.0);
        let photo = ramp_photo(80, 60);
        let sphere = SphereImage::from_photo_at(&photo, &camera, 512);
        let seen = sphere.seen.as_ref().unwrap();
        // Horizontal field of view 2·atan(40/50) = 77.3° of 360°.
        let fraction_of_row =
            seen[128 * 512..129 * 512].iter().filter(|s| **s).count() as f64 / 512.0;
        assert!(
            (fraction_of_row - 77.32 / 360.0).abs() < 0.01,
            "{fraction_of_row}"
        );
        // The photo's pixel (60.5, 20.5) is seen along its ray; the sphere shows its colour there.
        let ray = PANORAMA_FROM_PINHOLE * camera.unproject(DVec2::new(60.5, 20.5), 1.0);
        let at = project(ray, 512, 256).unwrap();
        let i = at.y as usize * 512 + at.x as usize;
        assert!(seen[i]);
        let expected = photo.data[20 * 80 + 60];
        let got = sphere.rgb.data[i];
        assert!((got[0] - expected[0]).abs() < 0.02 && (got[1] - expected[1]).abs() < 0.03);
        // Behind the camera nothing is seen.
        let back = project(DVec3::NEG_X, 512, 256).unwrap();
        assert!(!seen[back.y as usize * 512 + back.x as usize]);
    }

    #[test]
    fn a_photo_cut_from_a_panorama_warps_back_onto_it() {
        let (pw, ph) = (256usize, 128usize);
        let panorama = RgbImage {
            width: pw as u32,
            height: ph as u32,
            data: (0..pw * ph)
                .map(|i| {
                    let d = direction((i % pw) as f64 + 0.5, (i / pw) as f64 + 0.5, pw, ph);
                    [
                        (0.5 + 0.4 * d.x) as f32,
                        (0.5 + 0.4 * d.y) as f32,
                        (0.5 + 0.4 * d.z) as f32,
                    ]
                })
                .collect(),
        };
        let camera = Pinhole::new(96, 72, 48.0, 48.0, 48.0, 36.0);
        let heading = 1.0;
        let photo = photo_from_panorama(&panorama, &camera, heading);
        // The photo's centre looks along the heading.
        let centre = photo.data[36 * 96 + 48];
        assert!((centre[0] - (0.5 + 0.4 * heading.cos()) as f32).abs() < 0.02);
        assert!((centre[1] - (0.5 + 0.4 * heading.sin()) as f32).abs() < 0.02);
        assert!(photo_sees(
            &camera,
            heading,
            DVec3::new(heading.cos(), heading.sin(), 0.1)
        ));
        assert!(!photo_sees(
            &camera,
            heading,
            DVec3::new(-heading.cos(), 0.0, 0.0)
        ));
        // Back on the sphere of the turned camera, every seen pixel shows the panorama's colour of
        // its direction turned by the heading.
        let sphere = SphereImage::from_photo_at(&photo, &camera, pw);
        let turn = DMat3::from_rotation_z(heading);
        let mut checked = 0;
        for (i, c) in sphere.rgb.data.iter().enumerate() {
            if sphere.sees(i) {
                let d = turn * direction((i % pw) as f64 + 0.5, (i / pw) as f64 + 0.5, pw, ph);
                let want = [0.5 + 0.4 * d.x, 0.5 + 0.4 * d.y, 0.5 + 0.4 * d.z];
                for k in 0..3 {
                    assert!((c[k] as f64 - want[k]).abs() < 0.03, "{c:?} vs {want:?}");
                }
                checked += 1;
            }
        }
        assert!(checked > 1000, "{checked}");
    }

    #[test]
    fn downsampling_averages_seen_pixels_only() {
        let mut rgb = RgbImage {
            width: 8,
            height: 4,
            data: vec![[1.0, 0.0, 0.0]; 32],
        };
        let mut seen = vec![true; 32];
        for u in 0..8 {
            for v in 0..4 {
                if u % 4 == 0 || (u < 4 && v < 2) {
                    seen[v * 8 + u] = false;
                    rgb.data[v * 8 + u] = [0.0, 0.0, 9.0];
                }
            }
        }
        let image = SphereImage {
            rgb,
            seen: Some(seen),
        };
        let small = image.downsample(2, 1);
        // The left half saw 6 of its 16 pixels, the right half 12: only the right one counts as seen,
        // and neither takes the unseen pixels' colour.
        assert_eq!(small.seen, Some(vec![false, true]));
        assert_eq!(small.rgb.data, vec![[1.0, 0.0, 0.0]; 2]);
        let mostly_unseen = SphereImage {
            rgb: image.rgb.clone(),
            seen: Some(vec![false; 32]),
        };
        assert_eq!(
            mostly_unseen.downsample(2, 1).seen,
            Some(vec![false, false])
        );
    }
}

//! Training panoramas composed from the trained room, with their labels for free (the paper's data
//! augmentation): a database panorama of the empty room (rendered from the background model at a camera
//! over the free floor), the object models' coloured surface clouds splatted into it at random poses that
//! follow the room's rules ([`crate::place`]), under a random light gain and tint and a random tone per
//! object, with a little blur and noise, turned to a random heading. Each pixel is labelled with the model
//! of the nearest splatted object, or background.

use neuroom_core::image::RgbImage;
use neuroom_core::image::relit;
use neuroom_core::obb::OrientedBox;
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use neuroom_panorama::ObjectModel;
use neuroom_panorama::cloud::{SplatView, ZBuffer, splat};
use neuroom_panorama::database::{Database, DatabaseEntry};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::{Deserialize, Serialize};

use crate::place::{PlaceConfig, place_objects};

/// Label of pixels where no object is seen.
pub const BACKGROUND: u8 = 0;

/// How training panoramas vary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ComposeConfig {
    /// Where objects may stand.
    pub place: PlaceConfig,
    /// Range of the global light gain (linear light).
    pub light_gain: [f32; 2],
    /// Largest deviation of one channel's gain from the global gain (a tinted light), as a fraction.
    pub light_tint: f32,
    /// Range of an object's own gain (its tone adjuster).
    pub object_gain: [f32; 2],
    /// Largest per-channel colour shift of an object (sRGB).
    pub object_shift: f32,
    /// Largest per-channel mismatch between the empty room given to the network and the room in the
    /// panorama (locate's re-shading of the empty room is not exact).
    pub empty_mismatch: f32,
    /// Smooth changes of the light over the panorama that the empty room does not show (a lamp's glow,
    /// a shadow, re-shading that is not exact): this many soft blobs of gain…
    pub glows: usize,
    /// …each with a log-gain in this range (linear light)…
    pub glow_log_gain: [f32; 2],
    /// …and a radius in this range (fractions of the panorama's width).
    pub glow_radius: [f32; 2],
    /// Largest amplitude of the per-pixel noise (sRGB).
    pub noise: f32,
    /// Chance that the panorama is blurred a little.
    pub blur_probability: f64,
    /// Depth tolerance of the room's occlusion of objects (metres).
    pub occlusion_tolerance: f32,
}

impl Default for ComposeConfig {
    fn default() -> Self {
        Self {
            place: PlaceConfig::default(),
            light_gain: [0.55, 1.6],
            light_tint: 0.15,
            object_gain: [0.7, 1.35],
            object_shift: 0.04,
            empty_mismatch: 0.06,
            glows: 3,
            glow_log_gain: [-0.5, 0.6],
            glow_radius: [0.03, 0.25],
            noise: 0.03,
            blur_probability: 0.5,
            occlusion_tolerance: 0.05,
        }
    }
}

/// One composed training panorama at the database's resolution.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// The panorama with objects (sRGB).
    pub query: RgbImage,
    /// The empty room at the same camera under about the same light (sRGB).
    pub empty: RgbImage,
    /// Per pixel: [`BACKGROUND`] or 1 + the model index of the nearest object.
    pub labels: Vec<u8>,
    /// The objects placed: model index and box (world frame; the panorama was turned afterwards, so
    /// these are at the database camera's heading).
    pub boxes: Vec<(usize, OrientedBox)>,
}

/// The trained room the composer draws from: the background field (free space, floor and walls) and
/// the database of empty-room panoramas (at least one).
pub struct RoomSource<'a, F> {
    pub(crate) field: &'a F,
    pub(crate) database: &'a Database,
}

impl<F> Clone for RoomSource<'_, F> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<F> Copy for RoomSource<'_, F> {}

impl<'a, F> RoomSource<'a, F> {
    /// The room of the background model's `field` and its localization `database`; `None` when the
    /// database holds no panorama.
    pub fn new(field: &'a F, database: &'a Database) -> Option<Self> {
        (!database.entries.is_empty()).then_some(Self { field, database })
    }
}

/// Composes the training panorama of `seed` (deterministic).
pub fn compose<F: Field>(
    room: RoomSource<F>,
    models: &[ObjectModel],
    config: &ComposeConfig,
    seed: u64,
) -> Sample {
    let mut rng = Pcg64::seed_from_u64(seed);
    let entries = &room.database.entries;
    let entry = &entries[rng.random_range(0..entries.len())];
    let placed = place_objects(room, entry, models, &config.place, &mut rng);
    let light = random_light(config, &mut rng);
    let (w, h) = (room.database.width, room.database.height);
    let mut query: Vec<[f32; 3]> = entry.rgb.data.iter().map(|c| relit(*c, light)).collect();
    let mut labels = vec![BACKGROUND; w * h];
    draw_objects(
        entry,
        models,
        &placed,
        config,
        light,
        (w, h),
        &mut query,
        &mut labels,
        &mut rng,
    );
    let glow = glow_field(config, w, h, &mut rng);
    for (c, g) in query.iter_mut().zip(&glow) {
        *c = relit(*c, [*g; 3]);
    }
    if rng.random_bool(config.blur_probability) {
        query = blur(&query, w, h);
    }
    add_noise(&mut query, config.noise, &mut rng);
    let mismatch: [f32; 3] =
        std::array::from_fn(|_| 1.0 + rng.random_range(-1.0..=1.0) * config.empty_mismatch);
    let empty: Vec<[f32; 3]> = entry
        .rgb
        .data
        .iter()
        .map(|c| relit(*c, std::array::from_fn(|k| light[k] * mismatch[k])))
        .collect();
    let shift = rng.random_range(0..w);
    Sample {
        query: image(turn(&query, w, h, shift), w, h),
        empty: image(turn(&empty, w, h, shift), w, h),
        labels: turn(&labels, w, h, shift),
        boxes: placed
            .iter()
            .map(|(m, pose)| {
                (
                    *m,
                    OrientedBox::new(*pose, 2.0 * models[*m].half.as_dvec3()),
                )
            })
            .collect(),
    }
}

/// Per-channel light gains: a global gain times a small tint.
fn random_light(config: &ComposeConfig, rng: &mut Pcg64) -> [f32; 3] {
    let gain = rng.random_range(config.light_gain[0]..=config.light_gain[1]);
    std::array::from_fn(|_| gain * (1.0 + rng.random_range(-1.0..=1.0) * config.light_tint))
}

/// Per pixel, the gain of a few soft random blobs of light or shade ([`ComposeConfig::glows`]);
/// distances wrap around across columns.
fn glow_field(config: &ComposeConfig, w: usize, h: usize, rng: &mut Pcg64) -> Vec<f32> {
    let blobs: Vec<(f32, f32, f32, f32)> = (0..config.glows)
        .map(|_| {
            let u = rng.random_range(0.0..w as f32);
            let v = rng.random_range(0.0..h as f32);
            let radius = w as f32 * rng.random_range(config.glow_radius[0]..=config.glow_radius[1]);
            let log_gain = rng.random_range(config.glow_log_gain[0]..=config.glow_log_gain[1]);
            (u, v, radius, log_gain)
        })
        .collect();
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32 + 0.5, (i / w) as f32 + 0.5);
            let sum: f32 = blobs
                .iter()
                .map(|&(u, v, r, g)| {
                    let du = (x - u).abs().min(w as f32 - (x - u).abs());
                    g * (-(du * du + (y - v) * (y - v)) / (2.0 * r * r)).exp()
                })
                .sum();
            sum.exp()
        })
        .collect()
}

/// Splats every placed object, nearest first per pixel, into `query` and `labels`; rim pixels mix
/// the object with what lies behind.
#[allow(clippy::too_many_arguments)]
fn draw_objects(
    entry: &DatabaseEntry,
    models: &[ObjectModel],
    placed: &[(usize, Pose)],
    config: &ComposeConfig,
    light: [f32; 3],
    (w, h): (usize, usize),
    query: &mut [[f32; 3]],
    labels: &mut [u8],
    rng: &mut Pcg64,
) {
    let camera = entry.camera_to_world();
    let mut nearest = vec![f32::INFINITY; w * h];
    let mut buffer = ZBuffer::default();
    let background = query.to_vec();
    for (m, pose) in placed {
        let gain = rng.random_range(config.object_gain[0]..=config.object_gain[1]);
        let shift: [f32; 3] =
            std::array::from_fn(|_| rng.random_range(-1.0..=1.0) * config.object_shift);
        let view = SplatView {
            camera_to_world: &camera,
            width: w,
            height: h,
            room_depth: &entry.depth,
            tolerance: config.occlusion_tolerance,
            supersample: 1,
        };
        let sil = splat(&models[*m].coarse, pose, &view, &mut buffer);
        for k in 0..sil.pixels.len() {
            let p = sil.pixels[k] as usize;
            if sil.depths[k] >= nearest[p] {
                continue;
            }
            nearest[p] = sil.depths[k];
            let c = sil.colors[k].to_array();
            let toned: [f32; 3] = std::array::from_fn(|i| (c[i] + shift[i]).clamp(0.0, 1.0));
            let object = relit(toned, light.map(|l| l * gain));
            let cover = sil.cover[k];
            query[p] =
                std::array::from_fn(|i| cover * object[i] + (1.0 - cover) * background[p][i]);
            labels[p] = 1 + *m as u8;
        }
    }
}

/// A 3-tap binomial blur along both axes (columns wrap around).
fn blur(data: &[[f32; 3]], w: usize, h: usize) -> Vec<[f32; 3]> {
    let mix = |a: [f32; 3], b: [f32; 3], c: [f32; 3]| -> [f32; 3] {
        std::array::from_fn(|i| 0.25 * a[i] + 0.5 * b[i] + 0.25 * c[i])
    };
    let across: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let (u, v) = (i % w, i / w);
            let row = v * w;
            mix(
                data[row + (u + w - 1) % w],
                data[i],
                data[row + (u + 1) % w],
            )
        })
        .collect();
    (0..w * h)
        .map(|i| {
            let (u, v) = (i % w, i / w);
            let up = v.saturating_sub(1) * w + u;
            let down = (v + 1).min(h - 1) * w + u;
            mix(across[up], across[i], across[down])
        })
        .collect()
}

/// Adds uniform noise of a random amplitude up to `amplitude`.
fn add_noise(data: &mut [[f32; 3]], amplitude: f32, rng: &mut Pcg64) {
    let a = rng.random_range(0.0..=amplitude);
    for c in data.iter_mut().flatten() {
        *c = (*c + a * rng.random_range(-1.0f32..=1.0)).clamp(0.0, 1.0);
    }
}

/// The panorama turned about the vertical: column `u` takes column `u + shift`.
fn turn<T: Copy>(data: &[T], w: usize, h: usize, shift: usize) -> Vec<T> {
    (0..w * h)
        .map(|i| data[(i / w) * w + (i % w + shift) % w])
        .collect()
}

fn image(data: Vec<[f32; 3]>, w: usize, h: usize) -> RgbImage {
    RgbImage {
        width: w as u32,
        height: h as u32,
        data,
    }
}

//! The image renderer: for every pixel, jittered anti-aliased colour samples shaded with direct
//! light (area lights with soft shadows, point lights with hard shadows, a Blinn–Phong highlight),
//! environment and one-bounce ambient attenuated by ambient occlusion; plus depth and instance id
//! from one ray through the exact pixel centre. Rows run in parallel with rayon; every pixel draws
//! its random numbers from its own stream, so images are identical for any thread count.

use glam::{DVec2, Vec3};
use neuroom_core::Pose;
use neuroom_core::camera::{Camera, CameraModel};
use neuroom_core::image::{DepthImage, Image, MaskImage, RgbaImage, linear_to_srgb};
use rand::Rng;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::lighting::{Environment, Light, Lighting};
use crate::scene::{Surface, TracedScene};

/// A light prepared for sampling.
#[derive(Clone, Copy, Debug)]
enum Emitter {
    Area {
        centre: Vec3,
        half_u: Vec3,
        half_v: Vec3,
        normal: Vec3,
        radiance: Vec3,
        area: f32,
    },
    Point {
        position: Vec3,
        intensity: Vec3,
    },
}

/// An illumination prepared for shading: emitters, environment irradiance and ambient terms.
#[derive(Clone, Debug)]
pub struct LightRig {
    emitters: Vec<Emitter>,
    environment: Option<(Environment, f32)>,
    ambient: Vec3,
    ao_distance: f32,
    exposure: f32,
}

/// How a closed room returns light: its inner surface area and mean albedo, for the classic
/// one-bounce (split-flux) estimate of indirect irradiance `Φ ρ / (S (1 − ρ))`.
#[derive(Clone, Copy, Debug)]
pub struct RoomBounce {
    /// Total inner surface area (m²).
    pub area: f32,
    /// Area-weighted mean albedo.
    pub albedo: Vec3,
}

impl LightRig {
    /// Prepares `lighting`. `environment` is the irradiance of its HDRI (if it names one);
    /// `bounce` adds the indirect light of a closed room; `ao_distance` bounds the occlusion rays
    /// (short in rooms, where walls would otherwise occlude everything; infinite for lone objects).
    pub fn new(
        lighting: &Lighting,
        environment: Option<Environment>,
        bounce: Option<RoomBounce>,
        ao_distance: f32,
    ) -> Self {
        let emitters = lighting.lights.iter().map(prepare).collect();
        let strength = lighting.environment.as_ref().map_or(0.0, |e| e.strength);
        let mut ambient = Vec3::splat(lighting.ambient);
        if let Some(b) = bounce {
            let flux: Vec3 = lighting.lights.iter().map(Light::flux).sum();
            ambient += flux * b.albedo / (b.area * (Vec3::ONE - b.albedo).max(Vec3::splat(0.05)));
        }
        Self {
            emitters,
            environment: environment
                .filter(|_| strength > 0.0)
                .map(|e| (e, strength)),
            ambient,
            ao_distance,
            exposure: 2f32.powf(lighting.exposure_ev),
        }
    }

    /// Radiance of an emitter seen directly along a primary ray, if one lies closer than `t_max`.
    fn visible_emitter(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<Vec3> {
        self.emitters.iter().find_map(|e| match *e {
            Emitter::Area {
                centre,
                half_u,
                half_v,
                normal,
                radiance,
                ..
            } => {
                let dn = d.dot(normal);
                if dn >= 0.0 {
                    return None;
                }
                let t = (centre - o).dot(normal) / dn;
                let local = o + d * t - centre;
                let inside = local.dot(half_u).abs() <= half_u.length_squared()
                    && local.dot(half_v).abs() <= half_v.length_squared();
                (t > 0.0 && t < t_max && inside).then_some(radiance)
            }
            Emitter::Point { .. } => None,
        })
    }
}

fn prepare(light: &Light) -> Emitter {
    match light {
        Light::Area {
            position,
            size,
            normal,
            axis_u,
            power_w,
            color_rgb_linear,
            ..
        } => {
            let normal = Vec3::from(*normal).normalize();
            let u = Vec3::from(*axis_u).normalize();
            let v = normal.cross(u);
            let area = size[0] * size[1];
            Emitter::Area {
                centre: Vec3::from(*position),
                half_u: u * size[0] * 0.5,
                half_v: v * size[1] * 0.5,
                normal,
                radiance: Vec3::from(*color_rgb_linear) * *power_w / (std::f32::consts::PI * area),
                area,
            }
        }
        Light::Point {
            position,
            power_w,
            color_rgb_linear,
            ..
        } => Emitter::Point {
            position: Vec3::from(*position),
            intensity: Vec3::from(*color_rgb_linear) * *power_w / (4.0 * std::f32::consts::PI),
        },
    }
}

/// Sampling effort per pixel.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Quality {
    /// Anti-aliasing samples per pixel (jittered on a grid).
    pub spp: u32,
    /// Ambient-occlusion rays per colour sample.
    pub ao_rays: u32,
}

/// A camera placed in the world.
#[derive(Clone, Copy, Debug)]
pub struct PlacedCamera {
    /// Intrinsics.
    pub camera: Camera,
    /// Camera-to-world pose in the camera model's own frame convention.
    pub camera_to_world: Pose,
}

/// One rendered view.
#[derive(Clone, Debug)]
pub struct RenderedFrame {
    /// sRGB colour with coverage alpha (alpha 0 where no surface was hit).
    pub colour: RgbaImage,
    /// Stored depth at pixel centres in metres (pinhole: z-depth; panorama: ray distance), 0 = none.
    pub depth: DepthImage,
    /// Instance id at pixel centres.
    pub mask: MaskImage,
    /// Rays traced (primary, shadow and occlusion).
    pub rays: u64,
}

struct Pixel {
    colour: [f32; 4],
    depth: f32,
    id: u16,
    rays: u64,
}

/// Renders one view. `stream` distinguishes views of one run so their noise differs.
pub fn render(
    scene: &TracedScene,
    rig: &LightRig,
    view: &PlacedCamera,
    quality: Quality,
    seed: u64,
    stream: u64,
) -> RenderedFrame {
    let (w, h) = (view.camera.width(), view.camera.height());
    let rows: Vec<Vec<Pixel>> = (0..h)
        .into_par_iter()
        .map(|v| {
            (0..w)
                .map(|u| render_pixel(scene, rig, view, quality, seed, stream, u, v))
                .collect()
        })
        .collect();
    let pixels: Vec<Pixel> = rows.into_iter().flatten().collect();
    RenderedFrame {
        colour: Image {
            width: w,
            height: h,
            data: pixels.iter().map(|p| p.colour).collect(),
        },
        depth: Image {
            width: w,
            height: h,
            data: pixels.iter().map(|p| p.depth).collect(),
        },
        mask: Image {
            width: w,
            height: h,
            data: pixels.iter().map(|p| p.id).collect(),
        },
        rays: pixels.iter().map(|p| p.rays).sum(),
    }
}

/// A deterministic random stream for one pixel of one view.
fn pixel_rng(seed: u64, stream: u64, u: u32, v: u32) -> Pcg32 {
    let key = seed
        ^ stream.wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ ((v as u64) << 32 | u as u64).wrapping_mul(0xD1B5_4A32_D192_ED03);
    Pcg32::new(key, stream.wrapping_mul(2).wrapping_add(1))
}

#[allow(clippy::too_many_arguments)]
fn render_pixel(
    scene: &TracedScene,
    rig: &LightRig,
    view: &PlacedCamera,
    q: Quality,
    seed: u64,
    stream: u64,
    u: u32,
    v: u32,
) -> Pixel {
    let mut rng = pixel_rng(seed, stream, u, v);
    let origin = view.camera_to_world.translation.as_vec3();
    let world_dir = |px: DVec2| {
        let d = view.camera.direction(px);
        (
            view.camera_to_world
                .transform_vector(d)
                .as_vec3()
                .normalize(),
            d,
        )
    };
    let (centre_dir, centre_cam) = world_dir(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
    let mut rays = 1;
    let (depth, id) = match scene.intersect(origin, centre_dir, f32::INFINITY) {
        Some(hit) => {
            let stored = view
                .camera
                .project(centre_cam * hit.t as f64)
                .map_or(0.0, |(_, d)| d as f32);
            (stored, scene.instances()[hit.instance as usize].id)
        }
        None => (0.0, 0),
    };
    let grid = (q.spp as f32).sqrt().ceil() as u32;
    let (mut sum, mut covered) = (Vec3::ZERO, 0u32);
    let mut sample = |d: Vec3, index: u32, rng: &mut Pcg32| -> Option<Vec3> {
        rays += 1;
        let hit = scene.intersect(origin, d, f32::INFINITY);
        let t_max = hit.map_or(f32::INFINITY, |h| h.t);
        if let Some(l) = rig.visible_emitter(origin, d, t_max) {
            return Some(l);
        }
        let surface = scene.surface(&hit?, origin, d);
        let strata = Strata {
            index: index * q.ao_rays,
            count: q.spp * q.ao_rays,
        };
        let (l, n) = shade(scene, rig, &surface, -d, q.ao_rays, strata, rng);
        rays += n;
        Some(l)
    };
    for s in 0..q.spp {
        let jitter = DVec2::new(
            ((s % grid) as f64 + rng.random::<f64>()) / grid as f64,
            ((s / grid) as f64 + rng.random::<f64>()) / grid as f64,
        );
        let (d, _) = world_dir(DVec2::new(u as f64, v as f64) + jitter);
        if let Some(l) = sample(d, s, &mut rng) {
            sum += l;
            covered += 1;
        }
    }
    // Alpha 0 means "no surface" (docs/formats.md): where the pixel centre — which decides depth and mask — hits
    // a surface that every jittered sample missed, shade the centre so the pixel keeps a non-zero alpha.
    if covered == 0
        && depth > 0.0
        && let Some(l) = sample(centre_dir, 0, &mut rng)
    {
        sum += l;
        covered += 1;
    }
    let colour = if covered == 0 {
        [0.0; 4]
    } else {
        let c = sum / covered as f32 * rig.exposure;
        [
            linear_to_srgb(c.x),
            linear_to_srgb(c.y),
            linear_to_srgb(c.z),
            covered as f32 / q.spp as f32,
        ]
    };
    Pixel {
        colour,
        depth,
        id,
        rays,
    }
}

/// Which of a pixel's occlusion rays a colour sample casts: strata `index..index + ao_rays` of
/// `count`, so the rays of all samples of a pixel cover the hemisphere evenly.
#[derive(Clone, Copy, Debug)]
struct Strata {
    index: u32,
    count: u32,
}

/// Share of the ambient light that occlusion can remove; the rest stands for light reaching
/// corners by longer paths, and keeps low-sample occlusion noise faint.
const OCCLUDABLE: f32 = 0.7;

/// Outgoing radiance towards `wo` at a surface, and the number of rays traced for it.
#[allow(clippy::too_many_arguments)]
fn shade(
    scene: &TracedScene,
    rig: &LightRig,
    s: &Surface,
    wo: Vec3,
    ao_rays: u32,
    strata: Strata,
    rng: &mut Pcg32,
) -> (Vec3, u64) {
    let albedo = s.material.albedo_at(s.uv);
    let n = s.normal;
    let p = s.position + s.geometric_normal * (1e-4 + 1e-5 * s.position.abs().max_element());
    let mut radiance = Vec3::ZERO;
    let mut rays = 0;
    for e in &rig.emitters {
        let (to_light, incident) = match *e {
            Emitter::Area {
                centre,
                half_u,
                half_v,
                normal,
                radiance,
                area,
            } => {
                let y = centre
                    + half_u * rng.random_range(-1.0..1.0f32)
                    + half_v * rng.random_range(-1.0..1.0f32);
                let d = y - p;
                let dist2 = d.length_squared();
                let cos_l = -(d.dot(normal)) / dist2.sqrt();
                (d, radiance * (cos_l.max(0.0) * area / dist2))
            }
            Emitter::Point {
                position,
                intensity,
            } => {
                let d = position - p;
                (d, intensity / d.length_squared())
            }
        };
        let dist = to_light.length();
        let l = to_light / dist;
        let cos_s = n.dot(l);
        if cos_s <= 0.0 || incident == Vec3::ZERO || l.dot(s.geometric_normal) <= 0.0 {
            continue;
        }
        rays += 1;
        if !scene.occluded(p, l, dist * (1.0 - 1e-3)) {
            radiance += s.material.brdf(albedo, n, l, wo) * incident * cos_s;
        }
    }
    let open = occlusion(scene, p, n, rig.ao_distance, ao_rays, strata, rng);
    rays += ao_rays as u64;
    let mut irradiance = rig.ambient;
    if let Some((env, strength)) = &rig.environment {
        irradiance += env.irradiance(n) * *strength;
    }
    radiance +=
        albedo * std::f32::consts::FRAC_1_PI * irradiance * (1.0 - OCCLUDABLE + OCCLUDABLE * open);
    (radiance, rays)
}

/// Fraction of `count` cosine-weighted rays around `n` that travel `distance` without a hit
/// (1 when `count` is 0); ray k takes elevation stratum `strata.index + k` of `strata.count`.
fn occlusion(
    scene: &TracedScene,
    p: Vec3,
    n: Vec3,
    distance: f32,
    count: u32,
    strata: Strata,
    rng: &mut Pcg32,
) -> f32 {
    if count == 0 {
        return 1.0;
    }
    let (t, b) = n.any_orthonormal_pair();
    let mut open = 0;
    for k in 0..count {
        let r1 = ((strata.index + k) as f32 + rng.random::<f32>()) / strata.count as f32;
        let r2: f32 = rng.random();
        let (r, phi) = (r1.sqrt(), std::f32::consts::TAU * r2);
        let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - r1).max(0.0).sqrt();
        if !scene.occluded(p, d.normalize(), distance) {
            open += 1;
        }
    }
    open as f32 / count as f32
}

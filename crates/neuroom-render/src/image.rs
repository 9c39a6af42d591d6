//! Whole images of a scene for either camera kind: colour, depth (pinhole: z-depth; panorama: ray
//! distance, as docs/formats.md stores them) and instance ids, rendered in tiles of pixels in parallel. Tiles are
//! small because a field's forward pass keeps its activations (a few kB per sample of a NeuS field).

use crate::config::RenderConfig;
use crate::renderer::Renderer;
use crate::scene::Scene;
use glam::DVec2;
use neuroom_core::Ray;
use neuroom_core::camera::CameraModel;
use neuroom_core::image::{DepthImage, Image, MaskImage, RgbImage};
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use rayon::prelude::*;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Pixels per rayon task (row-major runs).
const TILE_PIXELS: usize = 512;

/// Opacity above which a pixel has a depth.
const DEPTH_OPACITY: f32 = 0.5;

/// Renders `scene` seen by `camera` at `camera_to_world`: colour (composited, clamped to `[0, 1]`, black
/// where nothing is hit), depth in the camera kind's stored convention (0 where the opacity is below ½),
/// and the instance id of the dominant field per pixel (0: background).
pub fn render_image<F: Field, C: CameraModel + Sync>(
    scene: &Scene<F>,
    camera: &C,
    camera_to_world: &Pose,
    config: &RenderConfig,
) -> (RgbImage, DepthImage, MaskImage) {
    render_image_reporting(scene, camera, camera_to_world, config, &|_| {})
}

/// How far a render is: pixels rendered of all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderedShare {
    /// Pixels rendered so far.
    pub done: usize,
    /// All the image's pixels.
    pub total: usize,
}

/// Reports of a render this many times at most, evenly spread.
const PROGRESS_REPORTS: usize = 100;

/// [`render_image`], telling `progress` how far it is about a hundred times, from any of
/// the render's threads but one at a time and never backwards.
pub fn render_image_reporting<F: Field, C: CameraModel + Sync>(
    scene: &Scene<F>,
    camera: &C,
    camera_to_world: &Pose,
    config: &RenderConfig,
    progress: &(dyn Fn(RenderedShare) + Sync),
) -> (RgbImage, DepthImage, MaskImage) {
    let (w, h) = (camera.width(), camera.height());
    let total = w as usize * h as usize;
    let tiles = total.div_ceil(TILE_PIXELS);
    let stride = tiles.div_ceil(PROGRESS_REPORTS).max(1);
    let finished = AtomicUsize::new(0);
    let reported = Mutex::new(0usize);
    let tell = |tile_count: usize| {
        if !tile_count.is_multiple_of(stride) && tile_count != tiles {
            return;
        }
        let mut last = reported.lock().unwrap_or_else(|e| e.into_inner());
        if tile_count > *last {
            *last = tile_count;
            progress(RenderedShare {
                done: (tile_count * TILE_PIXELS).min(total),
                total,
            });
        }
    };
    let mut rgb = Image::filled(w, h, [0.0f32; 3]);
    let mut depth = Image::filled(w, h, 0.0f32);
    let mut mask = Image::filled(w, h, 0u16);
    rgb.data
        .par_chunks_mut(TILE_PIXELS)
        .zip(depth.data.par_chunks_mut(TILE_PIXELS))
        .zip(mask.data.par_chunks_mut(TILE_PIXELS))
        .enumerate()
        .for_each_init(
            || (Renderer::new(*config), Vec::new(), Vec::new()),
            |(renderer, rays, dirs), (k, ((c, d), m))| {
                tile_rays(
                    camera,
                    camera_to_world,
                    k * TILE_PIXELS,
                    c.len(),
                    rays,
                    dirs,
                );
                renderer.render(scene, rays);
                let ids = renderer.instances();
                for (i, out) in renderer.outputs().iter().enumerate() {
                    c[i] = out.rgb.map(|v| v.clamp(0.0, 1.0));
                    m[i] = ids[i];
                    if out.opacity > DEPTH_OPACITY {
                        let point = dirs[i] * (out.depth / out.opacity) as f64;
                        d[i] = camera.project(point).map_or(0.0, |(_, z)| z as f32);
                    }
                }
                tell(finished.fetch_add(1, Ordering::Relaxed) + 1);
            },
        );
    (rgb, depth, mask)
}

/// World rays and camera-frame directions of `count` pixels from linear pixel index `first` on.
fn tile_rays<C: CameraModel>(
    camera: &C,
    camera_to_world: &Pose,
    first: usize,
    count: usize,
    rays: &mut Vec<Ray>,
    dirs: &mut Vec<glam::DVec3>,
) {
    let w = camera.width() as usize;
    rays.clear();
    dirs.clear();
    let origin = camera_to_world.translation.as_vec3();
    for i in first..first + count {
        let (u, v) = (i % w, i / w);
        let dir = camera.direction(DVec2::new(u as f64 + 0.5, v as f64 + 0.5));
        dirs.push(dir);
        rays.push(Ray::new(
            origin,
            camera_to_world.transform_vector(dir).as_vec3(),
        ));
    }
}

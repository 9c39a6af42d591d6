//! `neuroom bench synth`: ray-traced samples per second for one furnished panorama of the
//! `bedroom` preset, rendered without writing files.

use std::time::Instant;

use glam::DVec3;
use neuroom_core::Pose;
use neuroom_core::camera::{Camera, Equirect};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::generate::{ROOM_AO_DISTANCE, SynthError, build_models};
use crate::illumination::{load_hdris, test_lighting};
use crate::preset::Preset;
use crate::render::{LightRig, PlacedCamera, Quality, render};
use crate::sampler::{Item, RoomSpace, YawBox};
use crate::scene::{Instance, TracedScene};
use crate::shell::build_shell;

/// The measured throughput.
#[derive(Clone, Debug, Serialize)]
pub struct SynthBenchReport {
    /// Panorama width (height is half).
    pub width: u32,
    /// Colour samples per pixel.
    pub spp: u32,
    /// Occlusion rays per colour sample.
    pub ao_rays: u32,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Rayon threads used.
    pub threads: usize,
    /// Colour samples traced (pixels × spp).
    pub samples: u64,
    /// All rays traced (primary, shadow, occlusion).
    pub rays: u64,
    /// Wall-clock seconds of the render.
    pub seconds: f64,
    /// Colour samples per second (each fully shaded).
    pub samples_per_second: f64,
    /// Rays per second.
    pub rays_per_second: f64,
}

/// Renders one `width`-wide panorama of a furnished `bedroom` (seed `seed`) and times it.
pub fn bench_panorama(
    width: u32,
    quality: Quality,
    seed: u64,
) -> Result<SynthBenchReport, SynthError> {
    let preset = Preset::named("bedroom").expect("built-in preset");
    let shell = build_shell(DVec3::from_array(preset.room_size), seed);
    let models = build_models(&preset, seed, None)?;
    let items: Vec<Item> = preset
        .objects
        .iter()
        .map(|o| Item {
            furniture: &models[preset
                .models
                .iter()
                .position(|m| m.name == o.model)
                .expect("valid preset")],
            support: o
                .on
                .as_ref()
                .and_then(|s| preset.objects.iter().position(|x| &x.name == s)),
        })
        .collect();
    let mut rng = Pcg64::seed_from_u64(seed);
    let space = RoomSpace {
        size: shell.size,
        keep_out: &shell.keep_out,
    };
    let placed = space
        .arrange(&items, &[], &mut rng)
        .map_err(SynthError::Arrangement)?;
    let boxes: Vec<YawBox> = placed
        .iter()
        .map(|p| YawBox::of(&p.pose, items[p.index].furniture.size))
        .collect();
    let camera_pose = space
        .camera(&boxes, 0.35, &mut rng)
        .ok_or_else(|| SynthError::Arrangement("no camera spot".into()))?;
    let mut instances = vec![Instance::new(shell.model.clone(), Pose::IDENTITY, 0)];
    instances.extend(placed.iter().map(|p| {
        Instance::new(
            items[p.index].furniture.model.clone(),
            p.pose,
            p.index as u16 + 1,
        )
    }));
    let scene = TracedScene::new(instances);
    let hdris = load_hdris(&[])?;
    let lighting = test_lighting(0, shell.size, &hdris, &mut rng);
    let rig = LightRig::new(
        &lighting,
        Some(hdris[0].environment),
        Some(shell.bounce),
        ROOM_AO_DISTANCE,
    );
    let camera = Camera::Equirect(Equirect::new(width, width / 2).map_err(SynthError::Preset)?);
    let start = Instant::now();
    let rendered = render(
        &scene,
        &rig,
        &PlacedCamera {
            camera,
            camera_to_world: camera_pose,
        },
        quality,
        seed,
        0,
    );
    let seconds = start.elapsed().as_secs_f64();
    let samples = width as u64 * (width / 2) as u64 * quality.spp as u64;
    Ok(SynthBenchReport {
        width,
        spp: quality.spp,
        ao_rays: quality.ao_rays,
        triangles: scene.triangle_count(),
        threads: rayon::current_num_threads(),
        samples,
        rays: rendered.rays,
        seconds,
        samples_per_second: samples as f64 / seconds,
        rays_per_second: rendered.rays as f64 / seconds,
    })
}

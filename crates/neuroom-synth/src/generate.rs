//! The room generator: builds the shell and the furniture of a preset, samples arrangements and
//! lightings, renders every capture and panorama, and writes the room in the docs/formats.md layout
//! through the readers/writers of `neuroom-core`. Everything follows from the seed: two runs with
//! one seed write identical bytes whatever the thread count.

use std::collections::BTreeMap;
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::DVec3;
use neuroom_core::Pose;
use neuroom_core::camera::{Camera, Equirect, Pinhole, look_at};
use neuroom_core::formats::{
    ArrangedObject, Arrangement, BackgroundSpec, Capture, CaptureDevice, Frame, Room, RoomObject,
    write_arrangement, write_capture, write_depth, write_mask, write_rgb, write_rgba, write_room,
};
use neuroom_core::image::RgbImage;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;
use serde_json::{Map, Value, json};

use crate::furniture::{Furniture, Stand};
use crate::illumination::{Hdri, background_lighting, load_hdris, object_lighting, test_lighting};
use crate::lighting::Lighting;
use crate::ply::write_ply;
use crate::preset::{CapturePlacement, ObjectCaptureConfig, Preset};
use crate::render::{LightRig, PlacedCamera, RenderedFrame, render};
use crate::sampler::{Item, Placed, RoomSpace, YawBox};
use crate::scene::{Instance, TracedScene};
use crate::sh3d::Sh3dCatalog;
use crate::shell::{Shell, build_shell};
use crate::views::{room_views, sphere_band};

/// Metres per unit of the written depth PNGs.
pub const DEPTH_UNIT: f64 = 0.001;
/// Ambient-occlusion reach inside rooms (m).
pub(crate) const ROOM_AO_DISTANCE: f32 = 0.35;

/// What can go wrong while generating.
#[derive(Debug, thiserror::Error)]
pub enum SynthError {
    /// Writing or reading a file failed.
    #[error(transparent)]
    Format(#[from] neuroom_core::FormatError),
    /// The preset is inconsistent.
    #[error("preset: {0}")]
    Preset(String),
    /// The furniture catalog could not be used.
    #[error("furniture catalog: {0}")]
    Catalog(String),
    /// No valid arrangement was found.
    #[error("arrangement: {0}")]
    Arrangement(String),
}

/// Progress of a long stage: `done` of `total` items.
#[derive(Clone, Copy, Debug)]
pub struct StageProgress<'a> {
    /// Stage name (`background`, `object:<name>`, `panoramas`, …).
    pub stage: &'a str,
    /// Items finished.
    pub done: usize,
    /// Items in the stage.
    pub total: usize,
}

/// What a run wrote and how long it took.
#[derive(Clone, Debug, Serialize)]
pub struct Summary {
    /// The room folder.
    pub room: PathBuf,
    /// Room name.
    pub name: String,
    /// Number of objects.
    pub objects: usize,
    /// Number of distinct object captures.
    pub object_captures: usize,
    /// Views written over all captures.
    pub capture_frames: usize,
    /// Panoramas written.
    pub panoramas: usize,
    /// Rays traced.
    pub rays: u64,
    /// Seconds per stage.
    pub seconds: BTreeMap<String, f64>,
}

/// One writing stage; returns how many views or panoramas it wrote.
type Stage = fn(&mut Context, &mut dyn FnMut(StageProgress)) -> Result<usize, SynthError>;

/// Everything generation shares between stages.
struct Context<'a> {
    preset: &'a Preset,
    out: &'a Path,
    seed: u64,
    shell: Shell,
    models: Vec<Furniture>,
    /// Model index of every object.
    object_model: Vec<usize>,
    /// Per model, its capture's frame to the model's canonical frame (identity for isolated
    /// captures, the room's world to the object for captures in the room).
    capture_to_object: Vec<Pose>,
    hdris: Vec<Hdri>,
    rays: u64,
}

/// Generates the room of `preset` into `out` (created if needed). `furniture` is a Sweet Home 3D
/// catalog folder whose models replace the procedural ones where a match exists; `hdris` are
/// environment maps (`.hdr`/`.exr`/`.exr.js`) for ambient light (none: a built-in studio map).
pub fn generate(
    preset: &Preset,
    out: &Path,
    seed: u64,
    furniture: Option<&Path>,
    hdris: &[PathBuf],
    progress: &mut dyn FnMut(StageProgress),
) -> Result<Summary, SynthError> {
    preset.validate().map_err(SynthError::Preset)?;
    let mut seconds = BTreeMap::new();
    let start = Instant::now();
    let mut rng = Pcg64::seed_from_u64(seed);
    let jitter = |rng: &mut Pcg64| rng.random_range(0.92..1.08);
    let size = DVec3::new(
        preset.room_size[0] * jitter(&mut rng),
        preset.room_size[1] * jitter(&mut rng),
        preset.room_size[2],
    );
    let catalog = furniture
        .map(Sh3dCatalog::open)
        .transpose()
        .map_err(SynthError::Catalog)?;
    let models = build_models(preset, seed, catalog.as_ref())?;
    let object_model = preset
        .objects
        .iter()
        .map(|o| {
            preset
                .models
                .iter()
                .position(|m| m.name == o.model)
                .expect("validated")
        })
        .collect();
    let mut ctx = Context {
        preset,
        out,
        seed,
        shell: build_shell(size, seed),
        capture_to_object: vec![Pose::IDENTITY; models.len()],
        models,
        object_model,
        hdris: load_hdris(hdris)?,
        rays: 0,
    };
    seconds.insert("setup".into(), start.elapsed().as_secs_f64());
    let stages: [(&str, Stage); 4] = [
        ("background", write_background),
        ("objects", write_object_captures),
        ("panoramas", write_panoramas),
        ("room", write_room_files),
    ];
    let mut counts = Vec::new();
    for (name, stage) in stages {
        let t = Instant::now();
        counts.push(stage(&mut ctx, progress)?);
        seconds.insert(name.into(), t.elapsed().as_secs_f64());
    }
    seconds.insert("total".into(), start.elapsed().as_secs_f64());
    Ok(Summary {
        room: out.to_path_buf(),
        name: preset.name.clone(),
        objects: preset.objects.len(),
        object_captures: preset.models.len(),
        capture_frames: counts[0] + counts[1],
        panoramas: counts[2],
        rays: ctx.rays,
        seconds,
    })
}

/// One model per preset model spec: from the OBJ catalog when it has a match, else procedural.
pub(crate) fn build_models(
    preset: &Preset,
    seed: u64,
    catalog: Option<&Sh3dCatalog>,
) -> Result<Vec<Furniture>, SynthError> {
    preset
        .models
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let model_seed = seed
                .wrapping_mul(0x2545_F491_4F6C_DD1D)
                .wrapping_add(i as u64 * 7919 + 1);
            match catalog {
                Some(c) => c
                    .furniture_for(m.kind, &m.name, model_seed)
                    .map_err(SynthError::Catalog),
                None => Ok(m.kind.build(&m.name, model_seed)),
            }
        })
        .collect()
}

/// Drops alpha (every pixel of a closed room is covered).
fn rgb_of(r: &RenderedFrame) -> RgbImage {
    r.colour.map(|c| [c[0], c[1], c[2]])
}

/// Writes one capture view's three images and returns its frame.
fn write_view(
    dir: &Path,
    index: usize,
    rendered: &RenderedFrame,
    camera: Pinhole,
    pose: Pose,
    rgba: bool,
) -> Result<Frame, SynthError> {
    let name = format!("{index:04}.png");
    let (image, depth, mask) = (
        Path::new("images").join(&name),
        Path::new("depths").join(&name),
        Path::new("masks").join(&name),
    );
    if rgba {
        write_rgba(dir.join(&image), &rendered.colour)?;
    } else {
        write_rgb(dir.join(&image), &rgb_of(rendered))?;
    }
    write_depth(dir.join(&depth), &rendered.depth, DEPTH_UNIT)?;
    write_mask(dir.join(&mask), &rendered.mask)?;
    Ok(Frame {
        image,
        depth: Some(depth),
        instance: Some(mask),
        camera,
        camera_to_world: pose,
        light: None,
        extra: Map::new(),
    })
}

fn capture_with_lighting(dir: &Path, frames: Vec<Frame>, lighting: &Lighting) -> Capture {
    let mut extra = Map::new();
    extra.insert(
        "lighting".into(),
        serde_json::to_value(lighting).expect("lighting serialises"),
    );
    Capture {
        dir: dir.to_path_buf(),
        frames,
        depth_unit_scale_factor: DEPTH_UNIT,
        device: CaptureDevice::default(),
        extra,
    }
}

/// The light a capture is taken under, and the rig that renders it.
struct CaptureLight {
    lighting: Lighting,
    rig: LightRig,
}

impl CaptureLight {
    /// The empty room's light: the background capture's, and that of objects captured in the room.
    fn room(ctx: &Context) -> Self {
        let lighting = background_lighting(ctx.shell.size, &ctx.hdris[0].name);
        let rig = LightRig::new(
            &lighting,
            Some(ctx.hdris[0].environment),
            Some(ctx.shell.bounce),
            ROOM_AO_DISTANCE,
        );
        CaptureLight { lighting, rig }
    }

    /// The light of an object captured alone: no room to bounce off or occlude.
    fn isolated(ctx: &Context) -> Self {
        let lighting = object_lighting(&ctx.hdris[0].name);
        let rig = LightRig::new(
            &lighting,
            Some(ctx.hdris[0].environment),
            None,
            f32::INFINITY,
        );
        CaptureLight { lighting, rig }
    }
}

/// The background capture: the empty room from inside, masks all 0.
fn write_background(
    ctx: &mut Context,
    progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    let cfg = &ctx.preset.background;
    let dir = ctx.out.join("captures/background");
    let light = CaptureLight::room(ctx);
    let scene = TracedScene::new(vec![Instance::new(
        ctx.shell.model.clone(),
        Pose::IDENTITY,
        0,
    )]);
    let camera = Pinhole::new(
        cfg.width,
        cfg.height,
        cfg.focal,
        cfg.focal,
        cfg.width as f64 / 2.0,
        cfg.height as f64 / 2.0,
    );
    let mut rng = Pcg64::seed_from_u64(ctx.seed ^ 0xBAC6_0000);
    let poses = room_views(cfg.views, ctx.shell.size, 0.4, &mut rng);
    let mut frames = Vec::new();
    for (i, pose) in poses.into_iter().enumerate() {
        let view = PlacedCamera {
            camera: Camera::Pinhole(camera),
            camera_to_world: pose,
        };
        let rendered = render(
            &scene,
            &light.rig,
            &view,
            cfg.quality,
            ctx.seed,
            1 + i as u64,
        );
        ctx.rays += rendered.rays;
        frames.push(write_view(&dir, i, &rendered, camera, pose, false)?);
        progress(StageProgress {
            stage: "background",
            done: i + 1,
            total: cfg.views as usize,
        });
    }
    let n = frames.len();
    write_capture(&dir, &capture_with_lighting(&dir, frames, &light.lighting))?;
    Ok(n)
}

/// The id written to a model's capture masks: the smallest id among the objects instancing it.
fn capture_id(ctx: &Context, model: usize) -> u16 {
    ctx.object_model
        .iter()
        .position(|&m| m == model)
        .map_or(0, |i| i as u16 + 1)
}

/// One capture per distinct model, where the preset's capture placement puts it.
fn write_object_captures(
    ctx: &mut Context,
    progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    match ctx.preset.object_capture.placement {
        CapturePlacement::Isolated => write_isolated_captures(ctx, progress),
        CapturePlacement::InRoom => write_in_room_captures(ctx, progress),
    }
}

/// Camera distance at which an object of `size` fills a view of `fov_deg`.
fn framing_distance(size: DVec3, fov_deg: f64) -> f64 {
    size.length() * 0.5 / (fov_deg.to_radians() / 2.0).sin() * 1.05
}

/// The square pinhole camera of object captures.
fn object_capture_camera(cfg: &ObjectCaptureConfig) -> Pinhole {
    let focal = cfg.resolution as f64 / 2.0 / (cfg.fov_deg.to_radians() / 2.0).tan();
    let c = cfg.resolution as f64 / 2.0;
    Pinhole::new(cfg.resolution, cfg.resolution, focal, focal, c, c)
}

/// What a model's capture is rendered from.
struct CaptureShoot<'a> {
    scene: TracedScene,
    light: &'a CaptureLight,
    camera: Pinhole,
    /// Alpha kept (an object alone) or dropped (an object in the room).
    rgba: bool,
}

/// Renders model `m`'s capture from `poses` into `captures/<name>`; returns the views written.
fn shoot_capture(
    ctx: &mut Context,
    m: usize,
    shoot: &CaptureShoot,
    poses: Vec<Pose>,
    progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    let name = ctx.models[m].name.clone();
    let dir = ctx.out.join("captures").join(&name);
    let stage = format!("object:{name}");
    let quality = ctx.preset.object_capture.quality;
    let total = poses.len();
    let mut frames = Vec::new();
    for (i, pose) in poses.into_iter().enumerate() {
        let view = PlacedCamera {
            camera: Camera::Pinhole(shoot.camera),
            camera_to_world: pose,
        };
        let stream = ((m as u64 + 1) << 20) + i as u64;
        let rendered = render(
            &shoot.scene,
            &shoot.light.rig,
            &view,
            quality,
            ctx.seed,
            stream,
        );
        ctx.rays += rendered.rays;
        frames.push(write_view(
            &dir,
            i,
            &rendered,
            shoot.camera,
            pose,
            shoot.rgba,
        )?);
        progress(StageProgress {
            stage: &stage,
            done: i + 1,
            total,
        });
    }
    write_capture(
        &dir,
        &capture_with_lighting(&dir, frames, &shoot.light.lighting),
    )?;
    Ok(total)
}

/// One capture per distinct model standing on the floor in the middle of the empty room, turned
/// by a seeded yaw, under the room's light: views around it inside the room, masks true to the
/// pixel (the object's id on it, 0 on the room).
fn write_in_room_captures(
    ctx: &mut Context,
    progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    let cfg = ctx.preset.object_capture.clone();
    let size = ctx.shell.size;
    let light = CaptureLight::room(ctx);
    // Eyes stay this far inside the walls, floor and ceiling.
    let margin = 0.2;
    let mut total = 0;
    for m in 0..ctx.models.len() {
        let f = &ctx.models[m];
        let mut rng = Pcg64::seed_from_u64(ctx.seed ^ (0x1A20_0C00 + m as u64));
        let centre = DVec3::new(size.x / 2.0, size.y / 2.0, f.size.z / 2.0);
        let placed = Pose::from_yaw_translation(rng.random_range(0.0..TAU), centre);
        let shoot = CaptureShoot {
            scene: TracedScene::new(vec![
                Instance::new(ctx.shell.model.clone(), Pose::IDENTITY, 0),
                Instance::new(f.model.clone(), placed, capture_id(ctx, m)),
            ]),
            light: &light,
            camera: object_capture_camera(&cfg),
            rgba: false,
        };
        let distance = framing_distance(f.size, cfg.fov_deg);
        let poses = sphere_band(cfg.views, distance, cfg.elevation_deg, &mut rng)
            .into_iter()
            .map(|around| {
                let eye = (centre + around.translation)
                    .clamp(DVec3::splat(margin), size - DVec3::splat(margin));
                look_at(eye, centre)
            })
            .collect();
        total += shoot_capture(ctx, m, &shoot, poses, progress)?;
        ctx.capture_to_object[m] = placed.inverse();
    }
    Ok(total)
}

/// One capture per distinct model: the object alone at the origin of its canonical frame.
fn write_isolated_captures(
    ctx: &mut Context,
    progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    let cfg = ctx.preset.object_capture.clone();
    let light = CaptureLight::isolated(ctx);
    let mut total = 0;
    for m in 0..ctx.models.len() {
        let f = &ctx.models[m];
        let shoot = CaptureShoot {
            scene: TracedScene::new(vec![Instance::new(
                f.model.clone(),
                Pose::IDENTITY,
                capture_id(ctx, m),
            )]),
            light: &light,
            camera: object_capture_camera(&cfg),
            rgba: true,
        };
        let distance = framing_distance(f.size, cfg.fov_deg);
        let mut rng = Pcg64::seed_from_u64(ctx.seed ^ (0x0B1E_C700 + m as u64));
        let poses = sphere_band(cfg.views, distance, cfg.elevation_deg, &mut rng);
        total += shoot_capture(ctx, m, &shoot, poses, progress)?;
    }
    Ok(total)
}

/// Objects that no other object stands on (safe to leave out of an arrangement).
fn leaves(ctx: &Context) -> Vec<usize> {
    let objs = &ctx.preset.objects;
    (0..objs.len())
        .filter(|&i| {
            !objs
                .iter()
                .any(|o| o.on.as_deref() == Some(objs[i].name.as_str()))
        })
        .collect()
}

fn items<'a>(ctx: &'a Context) -> Vec<Item<'a>> {
    let objs = &ctx.preset.objects;
    objs.iter()
        .zip(&ctx.object_model)
        .map(|(o, &m)| Item {
            furniture: &ctx.models[m],
            support: o
                .on
                .as_ref()
                .and_then(|s| objs.iter().position(|x| &x.name == s)),
        })
        .collect()
}

/// Samples one arrangement (objects and camera); the last of several always leaves one object out.
fn sample_arrangement(
    ctx: &Context,
    index: u32,
    rng: &mut Pcg64,
) -> Result<(Vec<Placed>, Pose), SynthError> {
    let items = items(ctx);
    let space = RoomSpace {
        size: ctx.shell.size,
        keep_out: &ctx.shell.keep_out,
    };
    let last = index + 1 == ctx.preset.panoramas.arrangements && index > 0;
    let candidates = leaves(ctx);
    let omit: Vec<usize> =
        if (last || (index > 0 && rng.random_bool(0.3))) && ctx.preset.objects.len() > 1 {
            vec![candidates[rng.random_range(0..candidates.len())]]
        } else {
            Vec::new()
        };
    let placed = space
        .arrange(&items, &omit, rng)
        .map_err(|e| SynthError::Arrangement(format!("arrangement {index}: {e}")))?;
    let boxes: Vec<YawBox> = placed
        .iter()
        .map(|p| YawBox::of(&p.pose, items[p.index].furniture.size))
        .collect();
    let camera = space.camera(&boxes, 0.35, rng).ok_or_else(|| {
        SynthError::Arrangement(format!(
            "no free spot for the camera in arrangement {index}"
        ))
    })?;
    Ok((placed, camera))
}

/// The test panoramas: arrangements × lightings, with ground-truth arrangement, depth and mask.
fn write_panoramas(
    ctx: &mut Context,
    progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    let cfg = ctx.preset.panoramas.clone();
    let dir = ctx.out.join("panoramas");
    let mut rng = Pcg64::seed_from_u64(ctx.seed ^ 0x9A40_0000);
    let lightings: Vec<Lighting> = (0..cfg.lightings)
        .map(|j| test_lighting(j, ctx.shell.size, &ctx.hdris, &mut rng))
        .collect();
    let camera =
        Camera::Equirect(Equirect::new(cfg.width, cfg.width / 2).map_err(SynthError::Preset)?);
    let total = (cfg.arrangements * cfg.lightings) as usize;
    for a in 0..cfg.arrangements {
        let (placed, camera_pose) = sample_arrangement(ctx, a, &mut rng)?;
        let mut instances = vec![Instance::new(ctx.shell.model.clone(), Pose::IDENTITY, 0)];
        for p in &placed {
            instances.push(Instance::new(
                ctx.models[ctx.object_model[p.index]].model.clone(),
                p.pose,
                p.index as u16 + 1,
            ));
        }
        let scene = TracedScene::new(instances);
        for (j, lighting) in lightings.iter().enumerate() {
            let hdri = ctx
                .hdris
                .iter()
                .find(|h| Some(&h.name) == lighting.environment.as_ref().map(|e| &e.hdri))
                .map(|h| h.environment);
            let rig = LightRig::new(lighting, hdri, Some(ctx.shell.bounce), ROOM_AO_DISTANCE);
            let view = PlacedCamera {
                camera,
                camera_to_world: camera_pose,
            };
            let stream = (1 << 40) + ((a as u64) << 8) + j as u64;
            let rendered = render(&scene, &rig, &view, cfg.quality, ctx.seed, stream);
            ctx.rays += rendered.rays;
            let stem = format!("{}_a{a}_l{j}", ctx.preset.name);
            write_rgb(dir.join(format!("{stem}.png")), &rgb_of(&rendered))?;
            write_depth(
                dir.join(format!("{stem}.depth.png")),
                &rendered.depth,
                DEPTH_UNIT,
            )?;
            write_mask(dir.join(format!("{stem}.mask.png")), &rendered.mask)?;
            write_arrangement(
                dir.join(format!("{stem}.json")),
                &arrangement(ctx, &stem, &placed, camera_pose, lighting, a, j),
            )?;
            progress(StageProgress {
                stage: "panoramas",
                done: (a * cfg.lightings) as usize + j + 1,
                total,
            });
        }
    }
    Ok(total)
}

fn arrangement(
    ctx: &Context,
    stem: &str,
    placed: &[Placed],
    camera: Pose,
    lighting: &Lighting,
    a: u32,
    j: usize,
) -> Arrangement {
    let objs = &ctx.preset.objects;
    let objects = placed
        .iter()
        .map(|p| ArrangedObject {
            id: p.index as u16 + 1,
            name: objs[p.index].name.clone(),
            object_to_world: p.pose,
            extra: Map::new(),
        })
        .collect();
    let support: Map<String, Value> = placed
        .iter()
        .filter_map(|p| {
            objs[p.index]
                .on
                .as_ref()
                .map(|s| (objs[p.index].name.clone(), Value::from(s.clone())))
        })
        .collect();
    let mut extra = Map::new();
    extra.insert("arrangement_index".into(), a.into());
    extra.insert("lighting_index".into(), j.into());
    extra.insert("support".into(), Value::Object(support));
    extra.insert("room_box".into(), room_box(ctx.shell.size));
    Arrangement {
        image: format!("{stem}.png"),
        camera_to_world: camera,
        objects,
        lighting: serde_json::to_value(lighting).expect("lighting serialises"),
        extra,
    }
}

fn room_box(size: DVec3) -> Value {
    json!({ "min": [0.0, 0.0, 0.0], "max": size.to_array() })
}

/// Relation hints of an object for room.json.
fn relations(f: &Furniture, on: Option<&str>) -> Vec<String> {
    match (&f.placement.stand, on) {
        (_, Some(s)) => vec![format!("on:{s}")],
        (Stand::Floor, None) if f.placement.against_wall => vec!["floor".into(), "wall".into()],
        (Stand::Floor, None) => vec!["floor".into()],
        (Stand::Wall { .. }, None) => vec!["wall".into()],
        (Stand::OnSupport, None) => Vec::new(),
    }
}

/// room.json, the ground-truth meshes and `meta/generation.json` (the config and provenance).
fn write_room_files(
    ctx: &mut Context,
    _progress: &mut dyn FnMut(StageProgress),
) -> Result<usize, SynthError> {
    let objects: Vec<RoomObject> = ctx
        .preset
        .objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let f = &ctx.models[ctx.object_model[i]];
            RoomObject {
                id: i as u16 + 1,
                name: o.name.clone(),
                category: f.category.clone(),
                capture: Path::new("captures").join(&f.name),
                size: f.size,
                capture_to_object: ctx.capture_to_object[ctx.object_model[i]],
                relations: relations(f, o.on.as_deref()),
            }
        })
        .collect();
    for (o, &m) in objects.iter().zip(&ctx.object_model) {
        write_ply(
            &ctx.out.join("meshes").join(format!("{}.ply", o.name)),
            &ctx.models[m].model.mesh,
        )?;
    }
    let mut extra = Map::new();
    extra.insert("room_box".into(), room_box(ctx.shell.size));
    let room = Room {
        root: ctx.out.to_path_buf(),
        name: ctx.preset.name.clone(),
        background: BackgroundSpec {
            capture: PathBuf::from("captures/background"),
        },
        objects,
        extra,
    };
    write_room(ctx.out, &room)?;
    let meta = json!({
        "generator": "neuroom-synth",
        "seed": ctx.seed,
        "preset": ctx.preset,
        "room_size": ctx.shell.size.to_array(),
        "door": { "wall": ctx.shell.door.0, "at": ctx.shell.door.1 },
        "hdris": ctx.hdris.iter().map(|h| h.name.clone()).collect::<Vec<_>>(),
        "models": ctx.models.iter().map(|f| json!({ "name": f.name, "category": f.category, "size": f.size.to_array(), "source": f.source, "triangles": f.model.mesh.triangle_count() })).collect::<Vec<_>>(),
    });
    let bytes = serde_json::to_vec_pretty(&meta).expect("meta serialises");
    neuroom_core::formats::atomic_write(ctx.out.join("meta/generation.json"), &bytes)?;
    Ok(0)
}

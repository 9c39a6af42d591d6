//! `neuroom locate`: from a bare panorama and a trained room, the camera, the objects and their initial
//! poses, then the holistic fit from there; and `neuroom bench locate`, which scores all of a room's test
//! panoramas against their ground truth.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use glam::Vec3;
use neuroom_core::formats::{
    self, ArrangedObject, Arrangement, Room, RoomObject, read_rgb, read_room,
};
use neuroom_core::image::RgbImage;
use neuroom_core::metrics::ArrangementScore;
use neuroom_core::pose::Pose;
use neuroom_field::{CodeSet, NeusField};
use neuroom_fit::{FitConfig, IterationLog};
use neuroom_identify::{DetectConfig, Network, NetworkDetector};
use neuroom_locate::cloud::{FreeSpace, carve, surface_cloud};
use neuroom_locate::evidence::{Detection, Detector, ResidualDetector, View};
use neuroom_locate::objects::{
    Found, ObjectModel, Placement, SearchConfig, SearchInput, find_objects,
};
use neuroom_locate::plane::{blur_rgb, downsample_rgb};
use neuroom_locate::shading::match_shading;
use neuroom_locate::{
    CameraEstimate, DATABASE_FILE, Database, DatabaseConfig, LocalizeConfig, build_database,
    localize, render_background,
};
use neuroom_render::RenderConfig;
use neuroom_render::scene::{Background, Model, Scene};
use neuroom_train::dataset::{PixelClass, Role, load_views};
use neuroom_train::{ModelKind, RoomModels};
use serde::{Deserialize, Serialize};

use crate::scene::load_models;

/// The database file of a model folder.
pub fn database_path(models: &Path) -> PathBuf {
    models.join(DATABASE_FILE)
}

/// The empty room of loaded models: the background field alone (object fields stay in the list unused).
pub fn empty_scene(models: &RoomModels) -> anyhow::Result<Scene<NeusField>> {
    let index = models
        .manifest
        .models
        .iter()
        .position(|m| m.kind == ModelKind::Background)
        .context("the model folder has no background model")?;
    let bounds = &models.manifest.models[index].bounds;
    Ok(Scene {
        models: models.fields.iter().cloned().map(Model::neus).collect(),
        background: Background {
            model: index,
            bounds_min: Vec3::from(bounds.min),
            bounds_max: Vec3::from(bounds.max),
            codes: Default::default(),
            tone: Default::default(),
        },
        objects: Vec::new(),
    })
}

/// Renders the localization database of the room in `models` and writes it beside its manifest
/// (`locate.safetensors`). `neuroom train` calls this after the background is trained; `neuroom locate`
/// calls it on first use when the file is missing. `progress` gets (done, total).
pub fn build_locate_database(
    models: &Path,
    config: &DatabaseConfig,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<Database> {
    let loaded = load_models(models)?;
    let scene = empty_scene(&loaded)?;
    let db = build_database(&scene, config, progress);
    anyhow::ensure!(
        !db.entries.is_empty(),
        "{}: no database camera fits inside the background model's room",
        models.display()
    );
    db.write(&database_path(models))?;
    Ok(db)
}

/// The database of `models`, read from disk, or built and written when missing.
pub fn ensure_database(
    models: &Path,
    config: &DatabaseConfig,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<Database> {
    let path = database_path(models);
    if path.exists() {
        Ok(Database::read(&path)?)
    } else {
        build_locate_database(models, config, progress)
    }
}

/// Settings of the locate pipeline.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LocateConfig {
    /// The database, when it must be built.
    pub database: DatabaseConfig,
    /// Camera localization.
    pub localize: LocalizeConfig,
    /// Width of the panorama objects are searched in (height is half).
    pub object_width: usize,
    /// Rendering of the empty room the panorama is compared with.
    pub render: RenderConfig,
    /// Blur of that rendering (pixels): it is point-sampled and the panorama area-averaged.
    pub empty_blur: f32,
    /// Re-shade that rendering to the panorama's lighting by a gain depending on the surface normal
    /// ([`match_shading`]) before objects are searched; otherwise only a global per-channel gain.
    pub match_shading: bool,
    /// Which detector finds the object regions.
    pub detection: DetectorChoice,
    /// Object detection from the difference with the empty room.
    pub detector: ResidualDetector,
    /// Thresholds of the identification network's detector.
    pub network: DetectConfig,
    /// Pose hypotheses and their selection.
    pub search: SearchConfig,
}

impl Default for LocateConfig {
    fn default() -> Self {
        Self {
            database: DatabaseConfig::default(),
            localize: LocalizeConfig::default(),
            object_width: 512,
            render: LocalizeConfig::default().render,
            empty_blur: 0.7,
            match_shading: true,
            detection: DetectorChoice::default(),
            detector: ResidualDetector::default(),
            network: DetectConfig::default(),
            search: SearchConfig::default(),
        }
    }
}

/// Which detector finds where objects are seen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DetectorChoice {
    /// Where the panorama differs from the empty room ([`ResidualDetector`]); regions name no model.
    #[default]
    Residual,
    /// The identification network (`identify.safetensors`); an error when the folder lacks it.
    Network,
    /// The residual detector's regions, each named by the models the network sees in it
    /// ([`NetworkDetector::name_regions`]); an error when the folder lacks the network.
    Named,
    /// The network when the model folder holds one, else the residual.
    Auto,
}

impl std::str::FromStr for DetectorChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "residual" => Ok(Self::Residual),
            "network" => Ok(Self::Network),
            "named" => Ok(Self::Named),
            "auto" => Ok(Self::Auto),
            _ => Err(format!(
                "unknown detector `{s}` (residual, network, named or auto)"
            )),
        }
    }
}

/// How far beyond an object's box (room.json `size`) its surface clouds reach (metres).
const CLOUD_MARGIN: f32 = 0.01;

/// Searchable object models: one per object model of the manifest, with coloured surface clouds and
/// where it may stand from room.json's relation hints (`on:NAME`, else `floor`, else `wall`; floor by
/// default).
pub fn object_models(room: &Room, loaded: &RoomModels) -> anyhow::Result<Vec<ObjectModel>> {
    let entries: Vec<usize> = (0..loaded.manifest.models.len())
        .filter(|&k| loaded.manifest.models[k].kind == ModelKind::Object)
        .collect();
    let model_of = |name: &str| {
        let id = room.objects.iter().find(|o| o.name == name)?.id;
        entries
            .iter()
            .position(|&k| loaded.manifest.models[k].ids.contains(&id))
    };
    entries
        .iter()
        .map(|&k| {
            let entry = &loaded.manifest.models[k];
            let first = room
                .objects
                .iter()
                .find(|o| entry.ids.contains(&o.id))
                .with_context(|| format!("model `{}` draws no object of room.json", entry.name))?;
            let placement = placement(&first.relations, &model_of);
            let against_wall = placement == Placement::Wall
                || (placement == Placement::Floor && first.relations.iter().any(|r| r == "wall"));
            // The model's bounds carry a margin; the object's box is room.json's `size` (FORMAT.md).
            let bounds = Vec3::from(entry.bounds.centred_half_extents());
            let half = (0.5 * first.size).as_vec3();
            let spacing = (2.0 * bounds.max_element() / 25.0).clamp(0.02, 0.06);
            // Surfaces the field holds outside the object's box are floaters of training, not the
            // object: the clouds stop a little beyond the box.
            let extent = (half + CLOUD_MARGIN).min(bounds);
            let field = &loaded.fields[k];
            let free = free_space(room, first, &entry.ids)?;
            let cloud = |spacing: f32| {
                let cloud = surface_cloud(field, extent, spacing, CodeSet::default());
                carve(cloud, &free, CARVE_TOLERANCE)
            };
            Ok(ObjectModel {
                ids: entry.ids.clone(),
                half,
                coarse: cloud(spacing),
                fine: cloud(0.6 * spacing),
                placement,
                against_wall,
            })
        })
        .collect()
}

/// How far in front of what a capture frame saw a cloud point must lie to be carved away (metres).
const CARVE_TOLERANCE: f32 = 0.02;

/// What the frames of `object`'s capture saw of its model's free space (model frame), for [`carve`];
/// none when the room folder holds no such capture (models shipped without their captures).
fn free_space(room: &Room, object: &RoomObject, ids: &[u16]) -> anyhow::Result<Vec<FreeSpace>> {
    let dir = room.capture_dir(&object.capture);
    if !dir.join(formats::transforms::TRANSFORMS_FILE).is_file() {
        return Ok(Vec::new());
    }
    let capture = formats::read_capture(&dir)?;
    let role = Role::Object {
        ids: ids.to_vec(),
        capture_to_object: object.capture_to_object,
    };
    Ok(load_views(&capture, &role)?
        .into_iter()
        .map(|view| FreeSpace {
            camera: view.camera,
            camera_to_model: view.camera_to_model,
            free: view
                .class
                .iter()
                .zip(&view.distance)
                .map(|(class, d)| match class {
                    PixelClass::Empty => f32::INFINITY,
                    PixelClass::Surface => *d,
                    PixelClass::Ignored => 0.0,
                })
                .collect(),
        })
        .collect())
}

fn placement(relations: &[String], model_of: &dyn Fn(&str) -> Option<usize>) -> Placement {
    if let Some(m) = relations
        .iter()
        .find_map(|r| r.strip_prefix("on:").and_then(model_of))
    {
        return Placement::On(m);
    }
    let has = |k: &str| relations.iter().any(|r| r == k);
    if !has("floor") && has("wall") {
        Placement::Wall
    } else {
        Placement::Floor
    }
}

/// Everything the locate pipeline needs in memory for one room.
pub struct LocateContext {
    /// room.json.
    pub room: Room,
    /// The empty room (background alone).
    pub scene: Scene<NeusField>,
    /// The localization database.
    pub database: Database,
    /// Searchable object models, in manifest order of the object models.
    pub objects: Vec<ObjectModel>,
    /// The identification network, when the model folder holds one and the detector choice uses it.
    pub network: Option<Network>,
}

impl LocateContext {
    /// Loads the room, its models and database (building the database when missing).
    pub fn load(room: &Path, models: &Path, config: &LocateConfig) -> anyhow::Result<Self> {
        let room = read_room(room)?;
        let database = ensure_database(models, &config.database, &mut |_, _| {})?;
        let loaded = load_models(models)?;
        let objects = object_models(&room, &loaded)?;
        let scene = empty_scene(&loaded)?;
        let network = match config.detection {
            DetectorChoice::Residual => None,
            DetectorChoice::Auto => crate::identify::load_network(models, &loaded)?,
            DetectorChoice::Network | DetectorChoice::Named => Some(
                crate::identify::load_network(models, &loaded)?.with_context(|| {
                    format!(
                        "{}: missing; `neuroom train` builds it",
                        crate::identify::network_path(models).display()
                    )
                })?,
            ),
        };
        Ok(Self {
            room,
            scene,
            database,
            objects,
            network,
        })
    }
}

/// What locating one panorama found.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Located {
    /// The camera.
    pub camera: CameraEstimate,
    /// Detected regions.
    pub detections: usize,
    /// The objects placed, with their scores.
    pub found: Vec<Found>,
    /// Seconds: camera, objects.
    pub seconds: [f64; 2],
}

/// Locates `image` in the room of `ctx`: camera, detections, objects and initial poses; returns the
/// arrangement (FORMAT.md, with the camera; `image` names the panorama file) and the details.
pub fn locate_image(
    ctx: &LocateContext,
    image: &RgbImage,
    image_name: &str,
    config: &LocateConfig,
) -> anyhow::Result<(Arrangement, Located)> {
    let t0 = Instant::now();
    let camera = localize(&ctx.scene, &ctx.database, image, &config.localize)
        .map_err(|m| anyhow::anyhow!("{image_name}: {m}"))?;
    let t1 = Instant::now();
    let pose = camera.pose();
    let w = config.object_width;
    let (empty, empty_depth) = render_background(&ctx.scene, &pose, w, &config.render);
    let query = downsample_rgb(image, w, w / 2);
    let mut empty = blur_rgb(&empty, config.empty_blur);
    if config.match_shading {
        empty = match_shading(&query, &empty, &empty_depth);
    }
    let view = View {
        query,
        empty,
        empty_depth,
    };
    let detections = detect_objects(ctx, &view, config);
    let input = SearchInput {
        empty: &ctx.scene,
        view: &view,
        camera_to_world: pose,
        detections: &detections,
        models: &ctx.objects,
    };
    let found = find_objects(&input, &config.search);
    let objects = found
        .iter()
        .map(|f| ArrangedObject {
            id: f.id,
            name: ctx
                .room
                .objects
                .iter()
                .find(|o| o.id == f.id)
                .map(|o| o.name.clone())
                .unwrap_or_default(),
            object_to_world: Pose::from_rows_unchecked(&f.object_to_world),
            extra: Default::default(),
        })
        .collect();
    let arrangement = Arrangement {
        image: image_name.to_string(),
        camera_to_world: pose,
        objects,
        lighting: serde_json::Value::Null,
        extra: Default::default(),
    };
    let located = Located {
        camera,
        detections: detections.len(),
        found,
        seconds: [(t1 - t0).as_secs_f64(), t1.elapsed().as_secs_f64()],
    };
    Ok((arrangement, located))
}

/// The object regions of `view` by the detector `config` chooses: the network's (alone, or naming the
/// residual detector's regions) when `ctx` holds one, else the residual detector's.
fn detect_objects(ctx: &LocateContext, view: &View, config: &LocateConfig) -> Vec<Detection> {
    let Some(network) = &ctx.network else {
        return config.detector.detect(view);
    };
    let detector = NetworkDetector {
        network,
        config: config.network.clone(),
    };
    if config.detection == DetectorChoice::Named {
        detector.name_regions(view, config.detector.detect(view))
    } else {
        detector.detect(view)
    }
}

/// What `neuroom locate` wrote.
#[derive(Clone, Debug)]
pub struct LocateOutputs {
    /// The initial arrangement (camera + initial poses): `<OUT stem>.init.json`.
    pub init: PathBuf,
    /// The final arrangement (after the fit, when run).
    pub arrangement: PathBuf,
    /// What was found.
    pub located: Located,
}

/// `neuroom locate`: finds the camera and the objects of `panorama` in `room` with the models in
/// `models`, writes the initial arrangement beside `out` (`<stem>.init.json`), then, with `fit`, runs the
/// holistic fit from it and writes the solved arrangement to `out` (without, `out` gets the initial one).
pub fn locate(
    room: &Path,
    models: &Path,
    panorama: &Path,
    out: &Path,
    config: &LocateConfig,
    fit: Option<&FitConfig>,
    progress: &mut dyn FnMut(&IterationLog),
) -> anyhow::Result<LocateOutputs> {
    let image = read_rgb(panorama)?.image;
    anyhow::ensure!(
        image.width == 2 * image.height,
        "{}: a panorama must be twice as wide as it is high, found {}×{}",
        panorama.display(),
        image.width,
        image.height
    );
    let ctx = LocateContext::load(room, models, config)?;
    let name = panorama
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (mut arrangement, located) = locate_image(&ctx, &image, &name, config)?;
    arrangement
        .extra
        .insert("locate".into(), serde_json::to_value(&located)?);
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "locate".into());
    let init = out.with_file_name(format!("{stem}.init.json"));
    formats::write_arrangement(&init, &arrangement)?;
    match fit {
        Some(fit) if !arrangement.objects.is_empty() => {
            crate::fit::fit_panorama(models, panorama, &init, Some(room), out, fit, progress)?;
        }
        _ => formats::write_arrangement(out, &arrangement)?,
    }
    Ok(LocateOutputs {
        init,
        arrangement: out.to_path_buf(),
        located,
    })
}

/// Scores of one test panorama.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PanoramaScore {
    /// Panorama file name.
    pub panorama: String,
    /// Distance between the found and true camera centres (cm).
    pub camera_position_error_cm: f64,
    /// Geodesic angle between the found and true camera rotations (degrees).
    pub camera_rotation_error_deg: f64,
    /// Identification and pose scores (FORMAT.md metrics) of the final arrangement: after the fit when
    /// it ran, else the initial poses.
    pub objects: ArrangementScore,
    /// The initial poses' scores, when the fit ran after them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<ArrangementScore>,
    /// Seconds for the whole panorama (camera + objects, and the fit when it ran).
    pub seconds: f64,
    /// Details.
    pub located: Located,
}

/// Means over the test panoramas.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct LocateMean {
    /// Panoramas.
    pub panoramas: usize,
    /// Mean camera position error (cm).
    pub camera_position_error_cm: f64,
    /// Largest camera position error (cm).
    pub camera_position_error_max_cm: f64,
    /// Mean camera rotation error (degrees).
    pub camera_rotation_error_deg: f64,
    /// Largest camera rotation error (degrees).
    pub camera_rotation_error_max_deg: f64,
    /// Identification precision.
    pub precision: f64,
    /// Identification recall.
    pub recall: f64,
    /// Mean IoU (missed objects count 0), percent.
    pub iou_percent: f64,
    /// Mean rotation error of the found objects (degrees).
    pub are_deg: f64,
    /// Mean position error of the found objects (cm).
    pub ape_cm: f64,
    /// Mean seconds per panorama.
    pub seconds: f64,
    /// Mean IoU, ARE and APE of the initial poses, when the fit ran after them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<[f64; 3]>,
}

/// `neuroom bench locate`: locates every test panorama of `room` (those with ground truth) and scores
/// camera, identification and initial poses, and with `fit` the poses the holistic fit solves from
/// them. `each` sees every panorama's score as it is measured.
pub fn bench_locate(
    room: &Path,
    models: &Path,
    config: &LocateConfig,
    fit: Option<&FitConfig>,
    each: &mut dyn FnMut(&PanoramaScore),
) -> anyhow::Result<(Vec<PanoramaScore>, LocateMean)> {
    let ctx = LocateContext::load(room, models, config)?;
    let hints = crate::fit::room_hints(room)?;
    let mut scores = Vec::new();
    for (png, truth) in test_panoramas(room)? {
        let image = read_rgb(&png)?.image;
        let name = png
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let start = Instant::now();
        let (initial, located) = locate_image(&ctx, &image, &name, config)?;
        let initial_score = fit.map(|_| crate::score::score_in_room(&ctx.room, &truth, &initial));
        let arrangement = match fit {
            Some(fit) if !initial.objects.is_empty() => {
                let result = crate::fit::fit_arrangement(
                    models,
                    &image,
                    &initial,
                    &hints,
                    fit,
                    &mut |_| {},
                )?;
                crate::fit::solved_arrangement(&initial, &result.report(), &name)
            }
            _ => initial,
        };
        let seconds = start.elapsed().as_secs_f64();
        let score = PanoramaScore {
            panorama: name,
            camera_position_error_cm: 100.0
                * arrangement
                    .camera_to_world
                    .translation
                    .distance(truth.camera_to_world.translation),
            camera_rotation_error_deg: neuroom_core::metrics::rotation_error_deg(
                truth.camera_to_world.rotation,
                arrangement.camera_to_world.rotation,
            ),
            objects: crate::score::score_in_room(&ctx.room, &truth, &arrangement),
            initial: initial_score,
            seconds,
            located,
        };
        each(&score);
        scores.push(score);
    }
    let mean = mean_scores(&scores);
    Ok((scores, mean))
}

fn mean_scores(scores: &[PanoramaScore]) -> LocateMean {
    let n = scores.len().max(1) as f64;
    let mean = |f: &dyn Fn(&PanoramaScore) -> f64| scores.iter().map(f).sum::<f64>() / n;
    let max = |f: &dyn Fn(&PanoramaScore) -> f64| scores.iter().map(f).fold(0.0, f64::max);
    LocateMean {
        panoramas: scores.len(),
        camera_position_error_cm: mean(&|s| s.camera_position_error_cm),
        camera_position_error_max_cm: max(&|s| s.camera_position_error_cm),
        camera_rotation_error_deg: mean(&|s| s.camera_rotation_error_deg),
        camera_rotation_error_max_deg: max(&|s| s.camera_rotation_error_deg),
        precision: mean(&|s| s.objects.precision),
        recall: mean(&|s| s.objects.recall),
        iou_percent: mean(&|s| s.objects.mean_iou_percent.unwrap_or(0.0)),
        are_deg: mean(&|s| s.objects.mean_rotation_error_deg.unwrap_or(0.0)),
        ape_cm: mean(&|s| s.objects.mean_position_error_cm.unwrap_or(0.0)),
        seconds: mean(&|s| s.seconds),
        initial: scores.iter().all(|s| s.initial.is_some()).then(|| {
            let of = |f: &dyn Fn(&ArrangementScore) -> Option<f64>| {
                mean(&|s| s.initial.as_ref().and_then(f).unwrap_or(0.0))
            };
            [
                of(&|a| a.mean_iou_percent),
                of(&|a| a.mean_rotation_error_deg),
                of(&|a| a.mean_position_error_cm),
            ]
        }),
    }
}

/// The test panoramas of a room folder: `panoramas/*.png` with a ground-truth `*.json` beside them.
pub fn test_panoramas(room: &Path) -> anyhow::Result<Vec<(PathBuf, Arrangement)>> {
    let dir = room.join("panoramas");
    let entries =
        std::fs::read_dir(&dir).with_context(|| format!("{}: cannot list", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            let name = p.to_string_lossy();
            name.ends_with(".png") && !name.ends_with(".depth.png") && !name.ends_with(".mask.png")
        })
        .collect();
    paths.sort();
    let mut out = Vec::new();
    for png in paths {
        let json = png.with_extension("json");
        if json.exists() {
            out.push((png, formats::read_arrangement(&json)?));
        }
    }
    anyhow::ensure!(
        !out.is_empty(),
        "{}: no panorama with a ground-truth arrangement",
        dir.display()
    );
    Ok(out)
}

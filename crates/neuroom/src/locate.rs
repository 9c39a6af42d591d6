//! `neuroom locate`: from a bare panorama and a trained room, the camera, the objects and their initial
//! poses, then the holistic fit from there; and `neuroom bench locate`, which scores all of a room's test
//! panoramas against their ground truth.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context as _;
use glam::Vec3;
use neuroom_core::camera::{Equirect, Pinhole};
use neuroom_core::camera_effects::CameraEffect;
use neuroom_core::formats::{
    self, ArrangedObject, Arrangement, RefinedPoses, Room, RoomObject, read_rgb, read_room,
};
use neuroom_core::image::{RgbImage, linear_to_srgb};
use neuroom_core::metrics::ArrangementScore;
use neuroom_core::pose::Pose;
use neuroom_field::{CodeSet, Codes, NeusField};
use neuroom_fit::{FitConfig, IterationLog};
use neuroom_identify::{DetectConfig, DetectorView, Network, NetworkDetector};
pub use neuroom_locate::LocateStage;
use neuroom_locate::evidence::{Detector, ResidualDetector, SearchView, colour_error};
pub use neuroom_locate::local_light::LocalLightConfig;
use neuroom_locate::local_light::RoomLight;
use neuroom_locate::localize::camera_correlation;
use neuroom_locate::merge::merge_views;
use neuroom_locate::objects::{
    Found, ObjectStanding, SearchConfig, SearchInput, arrangement_error, find_objects,
    object_standings,
};
use neuroom_locate::point_light::PointLight;
use neuroom_locate::shading::{match_shading, panorama_normals};
use neuroom_locate::{
    CameraEstimate, LocalizeConfig, PANORAMA_FROM_PINHOLE, SphereImage, localize, render_background,
};
use neuroom_panorama::cloud::{FreeSpace, carve, surface_cloud};
use neuroom_panorama::plane::blur_rgb;
use neuroom_panorama::{
    DATABASE_FILE, Database, DatabaseConfig, Detection, ObjectModel, Support, build_database,
    without_capture_shading,
};
use neuroom_render::RenderConfig;
use neuroom_render::scene::{Background, Model, Scene};
use neuroom_train::dataset::{PixelClass, Role, load_views};
use neuroom_train::{MANIFEST_FILE, ModelKind, RoomModels};
use serde::{Deserialize, Serialize};

use crate::scene::{light_code, load_models};
use crate::score::{ShapeSymmetries, score_in_room};

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
    /// Relight that rendering, and the objects, by the light as it varies over the panorama (a lamp
    /// lighting one corner, a spot, a window:
    /// [`fit_light_field`](neuroom_locate::local_light::fit_light_field)); `None`: one light everywhere.
    #[serde(default = "default_local_light")]
    pub local_light: Option<LocalLightConfig>,
    /// Which detector finds the object regions.
    pub detection: DetectorChoice,
    /// Object detection from the difference with the empty room.
    pub detector: ResidualDetector,
    /// Thresholds of the identification network's detector.
    pub network: DetectConfig,
    /// Pose hypotheses and their selection.
    pub search: SearchConfig,
    /// Light code (by its name in the model manifest, e.g. `studio`) under which the object search
    /// sees the objects' colours; `None`: the first capture lighting. Objects captured under a light
    /// unlike the room's (a studio environment lighting them from all around, where the room's lamps
    /// light them from above) may be told apart better under another of their learnt lights.
    #[serde(default)]
    pub object_light: Option<String>,
    /// Take the light each object was captured under, as it varies with the surface's orientation,
    /// out of its clouds' colours before the search compares them with the panorama
    /// ([`without_capture_shading`], one light fitted over all the objects captured under it): a sky
    /// that lit one side of every object warm and the other blue does not light the room. Off by
    /// default: measured, it helped the validation suite's playroom a little and cost the bedroom
    /// preset (docs/experiment-log.md); `bench locate --set` turns it on.
    #[serde(default)]
    pub neutral_capture_light: bool,
}

fn default_local_light() -> Option<LocalLightConfig> {
    Some(LocalLightConfig::default())
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
            local_light: default_local_light(),
            detection: DetectorChoice::default(),
            detector: ResidualDetector::default(),
            network: DetectConfig::default(),
            search: SearchConfig::default(),
            object_light: None,
            neutral_capture_light: false,
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

impl DetectorChoice {
    /// Whether this detector cannot run without the identification network.
    pub fn needs_network(self) -> bool {
        matches!(self, Self::Network | Self::Named)
    }
}

/// How far beyond an object's box (room.json `size`) its surface clouds reach (metres).
const CLOUD_MARGIN: f32 = 0.01;

/// Searchable object models: one per object model of the manifest, with coloured surface clouds and
/// where it may stand from room.json's relation hints (`on:NAME`, else `floor`, else `wall`; floor by
/// default). The clouds are coloured under the light code named `light` (see
/// [`LocateConfig::object_light`]), or the first capture lighting.
pub fn object_models(
    room: &Room,
    loaded: &RoomModels,
    light: Option<&str>,
) -> anyhow::Result<Vec<ObjectModel>> {
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
            let support = support(&first.relations, &model_of);
            let against_wall = support == Support::Wall
                || (support == Support::Floor && first.relations.iter().any(|r| r == "wall"));
            // The model's bounds carry a margin; the object's box is room.json's `size` (docs/formats.md).
            let bounds = Vec3::from(entry.bounds.centred_half_extents());
            let half = (0.5 * first.size).as_vec3();
            let spacing = (2.0 * bounds.max_element() / 25.0).clamp(0.02, 0.06);
            // Surfaces the field holds outside the object's box are floaters of training, not the
            // object: the clouds stop a little beyond the box.
            let extent = (half + CLOUD_MARGIN).min(bounds);
            let field = &loaded.fields[k];
            let free = free_space(room, first, &entry.ids, loaded.refined_poses[k].as_ref())?;
            let codes = CodeSet {
                light: Codes::Fixed(light_code(entry, light)?),
                ..CodeSet::default()
            };
            let cloud = |spacing: f32| {
                let cloud = surface_cloud(field, extent, spacing, codes);
                carve(cloud, &free, CARVE_TOLERANCE)
            };
            Ok(ObjectModel {
                ids: entry.ids.clone(),
                half,
                coarse: cloud(spacing),
                fine: cloud(0.6 * spacing),
                support,
                against_wall,
            })
        })
        .collect()
}

/// The name of the light each object model's clouds are coloured under ([`object_models`], in its
/// order): the light code `light` names, or the first capture lighting.
fn cloud_lights(loaded: &RoomModels, light: Option<&str>) -> anyhow::Result<Vec<String>> {
    loaded
        .manifest
        .models
        .iter()
        .filter(|entry| entry.kind == ModelKind::Object)
        .map(|entry| {
            let code = light_code(entry, light)? as usize;
            Ok(entry
                .light_codes
                .names
                .get(code)
                .cloned()
                .unwrap_or_default())
        })
        .collect()
}

/// How far in front of what a capture frame saw a cloud point must lie to be carved away (metres).
const CARVE_TOLERANCE: f32 = 0.02;

/// What the frames of `object`'s capture saw of its model's free space (model frame), for [`carve`];
/// none when the room folder holds no such capture (models shipped without their captures). A
/// phone's tracker leaves its poses off by one or two centimetres and a degree, so near every
/// silhouette a frame sees through where the object stands and carving by them wears the clouds
/// away: a capture with `tracked_poses` carves by the poses training refined (`refined`, its
/// training frames alone), which agree with the model's geometry, and carves nothing without them.
/// Noisy depth leaves free only what lies in front of its spread: two of the noise's standard
/// deviations.
fn free_space(
    room: &Room,
    object: &RoomObject,
    ids: &[u16],
    refined: Option<&RefinedPoses>,
) -> anyhow::Result<Vec<FreeSpace>> {
    let dir = room.capture_dir(&object.capture);
    if !dir.join(formats::transforms::TRANSFORMS_FILE).is_file() {
        return Ok(Vec::new());
    }
    let mut capture = formats::read_capture(&dir)?;
    if capture.device.tracked_poses {
        match refined {
            Some(refined) => capture.frames = refined_frames(&capture, refined)?,
            None => return Ok(Vec::new()),
        }
    }
    let spread = |d: f32| {
        capture
            .device
            .depth_noise
            .map_or(0.0, |noise| 2.0 * noise.sigma_at(d))
    };
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
                    PixelClass::Surface => (*d - spread(*d)).max(0.0),
                    PixelClass::Ignored => 0.0,
                })
                .collect(),
        })
        .collect())
}

/// The frames of `capture` that `refined` lists, at their refined poses; an error when `refined`
/// names frames the capture does not hold (a model trained on another recording).
fn refined_frames(
    capture: &formats::Capture,
    refined: &RefinedPoses,
) -> anyhow::Result<Vec<formats::Frame>> {
    refined
        .frames
        .iter()
        .map(|r| {
            let frame = capture
                .frames
                .get(r.index)
                .filter(|f| f.image == r.image)
                .with_context(|| {
                    format!(
                        "the model's {} names frame {} `{}`, which {} does not hold: the model was \
                         trained on another recording of it; train it again",
                        formats::REFINED_POSES_FILE,
                        r.index,
                        r.image.display(),
                        capture.dir.display()
                    )
                })?;
            Ok(formats::Frame {
                camera_to_world: r.camera_to_world,
                ..frame.clone()
            })
        })
        .collect()
}

/// Where an object with room.json's `relations` may stand.
fn support(relations: &[String], model_of: &dyn Fn(&str) -> Option<usize>) -> Support {
    if let Some(m) = relations
        .iter()
        .find_map(|r| r.strip_prefix("on:").and_then(model_of))
    {
        return Support::On(m);
    }
    let has = |k: &str| relations.iter().any(|r| r == k);
    if !has("floor") && has("wall") {
        Support::Wall
    } else {
        Support::Floor
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
        let mut objects = object_models(&room, &loaded, config.object_light.as_deref())
            .with_context(|| models.join(MANIFEST_FILE).display().to_string())?;
        if config.neutral_capture_light {
            let lights = cloud_lights(&loaded, config.object_light.as_deref())?;
            objects = without_capture_shading(objects, &lights);
        }
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
    /// The level camera at the same place and heading that the object search looked from, at the
    /// panorama levelled to it ([`Located::search_pose`]); the camera itself when it was level.
    #[serde(default)]
    pub search_camera: [[f64; 4]; 4],
    /// Detected regions.
    pub detections: usize,
    /// The objects placed, with their scores.
    pub found: Vec<Found>,
    /// Seconds: camera, objects.
    pub seconds: [f64; 2],
}

impl Located {
    /// The camera the object search looked from, with which its view is judged.
    pub fn search_pose(&self) -> Pose {
        Pose::from_rows_unchecked(&self.search_camera)
    }
}

/// The image `locate` understands.
#[derive(Clone, Debug)]
pub enum QueryImage {
    /// An equirectangular panorama (docs/formats.md).
    Panorama(RgbImage),
    /// A photo with its intrinsics, taken by a camera held level (no pitch or roll).
    Photo {
        /// The photo.
        rgb: RgbImage,
        /// Its intrinsics (OpenGL frame, as in `transforms.json`).
        camera: Pinhole,
    },
}

impl QueryImage {
    /// The image on the sphere of its camera's panorama frame.
    pub fn sphere(&self) -> SphereImage {
        match self {
            Self::Panorama(rgb) => SphereImage::panorama(rgb.clone()),
            Self::Photo { rgb, camera } => SphereImage::from_photo(rgb, camera),
        }
    }

    /// The camera as the arrangement states it, from its panorama frame: a photo's is its OpenGL frame.
    pub fn camera_to_world(&self, panorama_frame: &Pose) -> Pose {
        match self {
            Self::Panorama(_) => *panorama_frame,
            Self::Photo { .. } => Pose::new(
                panorama_frame.rotation * PANORAMA_FROM_PINHOLE,
                panorama_frame.translation,
            ),
        }
    }

    /// The intrinsics an arrangement records for a photo (`transforms.json` keys).
    fn intrinsics_json(&self) -> Option<serde_json::Value> {
        let Self::Photo { camera: c, .. } = self else {
            return None;
        };
        Some(serde_json::json!({
            "camera_model": "OPENCV", "w": c.width, "h": c.height, "fl_x": c.fx, "fl_y": c.fy,
            "cx": c.cx, "cy": c.cy, "k1": c.k1, "k2": c.k2, "p1": c.p1, "p2": c.p2,
        }))
    }
}

/// Locates `query` in the room of `ctx`: camera, detections, objects and initial poses; returns the
/// arrangement (docs/formats.md, with the camera, its `camera_confidence` and any `warnings`; `image_name`
/// names the image file; a photo's intrinsics are recorded as `camera`), the details (whose camera is
/// the panorama frame) and the query's view at the found camera (`object_view`), in which
/// arrangements are judged.
pub fn locate_image(
    ctx: &LocateContext,
    query: &QueryImage,
    image_name: &str,
    config: &LocateConfig,
    progress: &mut dyn FnMut(LocateStep),
) -> anyhow::Result<(Arrangement, Located, SearchView)> {
    let views = [(query.clone(), image_name.to_string())];
    let (arrangement, mut located, mut object_views) = locate_views(ctx, &views, config, progress)?;
    let (Some(located), Some(view)) = (located.pop(), object_views.pop()) else {
        anyhow::bail!("{image_name}: nothing located");
    };
    Ok((arrangement, located, view))
}

/// Locates several views of one arrangement (panoramas or photos, [`QueryImage`]), each on its own,
/// and merges their objects ([`merge_views`]). The arrangement states the first view's camera and
/// image; every view's image, camera and intrinsics are listed under `views`. Each view's details and
/// its view at the found camera (`object_view`) come with it. `progress` is told each stage as it
/// starts, and once more when all views are located.
pub fn locate_views(
    ctx: &LocateContext,
    views: &[(QueryImage, String)],
    config: &LocateConfig,
    progress: &mut dyn FnMut(LocateStep),
) -> anyhow::Result<(Arrangement, Vec<Located>, Vec<SearchView>)> {
    let (first, first_name) = views.first().context("no image to locate")?;
    let total = views.len() * LocateStage::PLANNED.len();
    let (located, object_views): (Vec<Located>, Vec<SearchView>) = views
        .iter()
        .enumerate()
        .map(|(k, (query, name))| {
            let mut report = |stage: LocateStage| {
                progress(LocateStep {
                    image: name,
                    stage: Some(stage),
                    done: k * LocateStage::PLANNED.len() + stage.position(),
                    total,
                })
            };
            locate_view(ctx, query, name, config, &mut report)
        })
        .collect::<anyhow::Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    progress(LocateStep {
        image: first_name,
        stage: None,
        done: total,
        total,
    });
    let merged = match located.as_slice() {
        [one] => one.found.clone(),
        _ => {
            let found: Vec<Vec<Found>> = located.iter().map(|l| l.found.clone()).collect();
            merge_views(&found, &ctx.objects, &config.search)
        }
    };
    let mut arrangement = arrangement_of(ctx, &merged, first, &located[0].camera.pose());
    arrangement.image = first_name.clone();
    arrangement.extra.insert(
        "camera_confidence".into(),
        located[0].camera.confidence.into(),
    );
    if let Some(point) = (object_views[0].light.as_ref()).and_then(|l| l.point.as_ref()) {
        arrangement
            .extra
            .insert("point_light".into(), point_light_json(point, &located[0]));
    }
    let warnings: Vec<String> = views
        .iter()
        .zip(&located)
        .filter_map(|((_, name), l)| Some(format!("{name}: {}", l.camera.warning.as_ref()?)))
        .collect();
    if !warnings.is_empty() {
        arrangement.extra.insert("warnings".into(), warnings.into());
    }
    let listed: Vec<serde_json::Value> = views
        .iter()
        .zip(&located)
        .map(|((query, name), l)| {
            serde_json::json!({
                "image": name,
                "camera_to_world": query.camera_to_world(&l.camera.pose()).to_rows(),
                "camera": query.intrinsics_json(),
            })
        })
        .collect();
    arrangement.extra.insert("views".into(), listed.into());
    Ok((arrangement, located, object_views))
}

/// The point light fitted to a view ([`PointLight`]) in the world frame, as the arrangement states it:
/// where it is and its gains over the captures' light (linear, per channel).
fn point_light_json(point: &PointLight, located: &Located) -> serde_json::Value {
    let pose = located.search_pose();
    let position = pose.transform_point(point.position.as_dvec3());
    let facing = (point.facing).map(|m| (pose.rotation * m.as_dvec3()).to_array());
    serde_json::json!({
        "position": position.to_array(),
        "facing": facing,
        "ambient": point.ambient,
        "strength": point.strength,
    })
}

/// Where [`locate_views`] is: the stage starting, as a share of all the planned stages of all views.
#[derive(Clone, Copy, Debug)]
pub struct LocateStep<'a> {
    /// The image being located (the first one once all are).
    pub image: &'a str,
    /// The stage starting; `None` once every view is located.
    pub stage: Option<LocateStage>,
    /// Planned stages done before it ([`LocateStage::position`]), over all views.
    pub done: usize,
    /// All planned stages of all views.
    pub total: usize,
}

/// The camera and the objects of one view, and the view at that camera ([`object_view`]);
/// `progress` is told each stage as it starts.
fn locate_view(
    ctx: &LocateContext,
    query: &QueryImage,
    image_name: &str,
    config: &LocateConfig,
    progress: &mut dyn FnMut(LocateStage),
) -> anyhow::Result<(Located, SearchView)> {
    let t0 = Instant::now();
    let sphere = query.sphere();
    let camera = localize(
        &ctx.scene,
        &ctx.database,
        &sphere,
        &config.localize,
        progress,
    )
    .map_err(|m| anyhow::anyhow!("{image_name}: {m}"))?;
    let t1 = Instant::now();
    let (sphere, pose) = levelled_for_search(sphere, &camera.pose())?;
    progress(LocateStage::View);
    let view = object_view(ctx, &sphere, &pose, config);
    progress(LocateStage::Detect);
    let detections = detect_objects(ctx, &view, config);
    let input = SearchInput {
        empty: &ctx.scene,
        view: &view,
        camera_to_world: pose,
        detections: &detections,
        models: &ctx.objects,
    };
    let found = find_objects(&input, &config.search, progress);
    let located = Located {
        camera,
        search_camera: pose.to_rows(),
        detections: detections.len(),
        found,
        seconds: [(t1 - t0).as_secs_f64(), t1.elapsed().as_secs_f64()],
    };
    Ok((located, view))
}

/// Tilts of the found camera below this (degrees) are left to the object search, which handles any
/// camera pose; larger ones are levelled first, as its hypotheses follow the image's columns.
const SEARCH_LEVEL_TILT_DEG: f64 = 0.5;

/// The panorama `sphere` taken from `camera`, as a level camera at the same place and heading would
/// have taken it, and that camera: what the object search looks at. Photos, and cameras tilted less
/// than [`SEARCH_LEVEL_TILT_DEG`], stay as they are.
fn levelled_for_search(sphere: SphereImage, camera: &Pose) -> anyhow::Result<(SphereImage, Pose)> {
    let level = Pose::from_yaw_translation(camera.yaw(), camera.translation);
    let to_level = level.rotation.transpose() * camera.rotation;
    let tilt = neuroom_core::metrics::rotation_error_deg(level.rotation, camera.rotation);
    if sphere.seen.is_some() || tilt < SEARCH_LEVEL_TILT_DEG {
        return Ok((sphere, *camera));
    }
    let rgb = neuroom_core::camera_effects::rotate_panorama(&sphere.rgb, &to_level.transpose())
        .map_err(|e| anyhow::anyhow!("levelling the panorama: {e}"))?;
    Ok((SphereImage::panorama(rgb), level))
}

/// The arrangement of `found` seen by `query` from the panorama frame `camera` (its image left empty).
fn arrangement_of(
    ctx: &LocateContext,
    found: &[Found],
    query: &QueryImage,
    camera: &Pose,
) -> Arrangement {
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
            object_to_world: f.pose(),
            extra: Default::default(),
        })
        .collect();
    let mut arrangement = Arrangement {
        image: String::new(),
        camera_to_world: query.camera_to_world(camera),
        objects,
        lighting: serde_json::Value::Null,
        extra: Default::default(),
    };
    if let Some(intrinsics) = query.intrinsics_json() {
        arrangement.extra.insert("camera".into(), intrinsics);
    }
    arrangement
}

/// The query at the object search's resolution beside the empty room rendered at `pose`, re-shaded
/// to the query's light and relit by the light as it varies over the panorama
/// ([`LocateConfig::local_light`]) from what the query saw; where it saw nothing, the query shows that
/// empty room.
fn object_view(
    ctx: &LocateContext,
    sphere: &SphereImage,
    pose: &Pose,
    config: &LocateConfig,
) -> SearchView {
    let w = config.object_width;
    let (empty, empty_depth) = render_background(&ctx.scene, pose, w, &config.render);
    let small = sphere.downsample(w, w / 2);
    let mut empty = blur_rgb(&empty, config.empty_blur);
    let light = match &config.local_light {
        Some(local) => {
            let light = RoomLight::fit(
                &small.rgb,
                &empty,
                &empty_depth,
                small.seen.as_deref(),
                config.match_shading,
                local,
            );
            empty = light.relight_room(
                &empty,
                &empty_depth,
                &panorama_normals(&empty_depth, w, w / 2),
            );
            Some(light)
        }
        None if config.match_shading => {
            empty = match_shading(&small.rgb, &empty, &small.seen_depth(&empty_depth));
            None
        }
        None => None,
    };
    let SphereImage {
        rgb: mut query,
        seen,
    } = small;
    if let Some(seen) = &seen {
        for ((q, e), s) in query.data.iter_mut().zip(&empty.data).zip(seen) {
            if !s {
                *q = *e;
            }
        }
    }
    SearchView {
        query,
        empty,
        empty_depth,
        seen,
        light,
    }
}

/// The object regions of `view` by the detector `config` chooses: the network's (alone, or naming the
/// residual detector's regions) when `ctx` holds one, else the residual detector's.
fn detect_objects(ctx: &LocateContext, view: &SearchView, config: &LocateConfig) -> Vec<Detection> {
    let Some(network) = &ctx.network else {
        return config.detector.detect(view);
    };
    let detector = NetworkDetector {
        network,
        config: config.network.clone(),
    };
    let pair = DetectorView {
        query: &view.query,
        empty: &view.empty,
    };
    if config.detection == DetectorChoice::Named {
        detector.name_regions(pair, config.detector.detect(view))
    } else {
        detector.detect(pair)
    }
}

/// What `neuroom locate` wrote.
#[derive(Clone, Debug)]
pub struct LocateOutputs {
    /// The initial arrangement (camera + initial poses): `<OUT stem>.init.json`.
    pub init: PathBuf,
    /// The final arrangement (after the fit, when run).
    pub arrangement: PathBuf,
    /// Whether the holistic fit ran (it takes one panorama).
    pub fitted: bool,
    /// What was found in each view.
    pub located: Vec<Located>,
}

/// What [`locate`] tells as it goes: each stage of locating the images, then each iteration of the fit.
pub struct LocateProgress<'a> {
    /// Each stage of locating, as it starts ([`locate_views`]).
    pub stage: &'a mut dyn FnMut(LocateStep),
    /// Each iteration of the holistic fit.
    pub fit: &'a mut dyn FnMut(&IterationLog),
}

/// The images `neuroom locate` is given.
#[derive(Clone, Copy, Debug)]
pub struct LocateInput<'a> {
    /// Panoramas, or photos with `intrinsics`; several are views of one arrangement.
    pub images: &'a [PathBuf],
    /// The photos' intrinsics file ([`formats::read_intrinsics_file`]); `None` for panoramas.
    pub intrinsics: Option<&'a Path>,
    /// A folder that receives what the object search saw of each image ([`write_search_view`]).
    pub search_views: Option<&'a Path>,
}

/// `neuroom locate`: finds the camera and the objects of `images` (panoramas, or with `intrinsics`
/// photos: [`read_query`]; several are views of one arrangement, [`locate_views`]) in `room` with the
/// models in `models`, writes the initial arrangement beside `out` (`<stem>.init.json`), then, with
/// `fit`, runs the holistic fit from it and writes the solved arrangement to `out`. The fit takes one
/// panorama; otherwise (and without `fit`) `out` gets the initial arrangement.
pub fn locate(
    room: &Path,
    models: &Path,
    input: &LocateInput,
    out: &Path,
    config: &LocateConfig,
    fit: Option<&FitConfig>,
    progress: LocateProgress,
) -> anyhow::Result<LocateOutputs> {
    let LocateInput {
        images,
        intrinsics,
        search_views,
    } = *input;
    let views = images
        .iter()
        .map(|image| {
            let name = image
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            Ok((read_query(image, intrinsics)?, name))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    let ctx = LocateContext::load(room, models, config)?;
    let (mut arrangement, located, object_views) =
        locate_views(&ctx, &views, config, progress.stage)?;
    if let Some(dir) = search_views {
        for ((_, name), view) in views.iter().zip(&object_views) {
            let detections = detect_objects(&ctx, view, config);
            write_search_view(dir, name, view, &detections)?;
        }
    }
    record_located(&mut arrangement, &located)?;
    let stem = out
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "locate".into());
    let init = out.with_file_name(format!("{stem}.init.json"));
    formats::write_arrangement(&init, &arrangement)?;
    let fitted = match (fit, views.as_slice()) {
        (Some(fit), [(QueryImage::Panorama(image), name)]) if !arrangement.objects.is_empty() => {
            let hints = crate::fit::relation_hints(&ctx.room);
            let result = crate::fit::fit_arrangement(
                models,
                image,
                &arrangement,
                &hints,
                config.object_light.as_deref(),
                fit,
                progress.fit,
            )?;
            let report = result.report();
            let solved = crate::fit::solved_arrangement(&arrangement, &report, name);
            let camera = located[0].search_pose();
            let view = &object_views[0];
            let solved = keep_better_poses(&ctx, view, &camera, &arrangement, solved, config);
            crate::fit::write_fit(out, &solved, &report, &result)?;
            true
        }
        _ => {
            formats::write_arrangement(out, &arrangement)?;
            false
        }
    };
    Ok(LocateOutputs {
        init,
        arrangement: out.to_path_buf(),
        fitted,
        located,
    })
}

/// Records what locating each view found (camera, scores, timings) in the arrangement's `locate`.
pub fn record_located(arrangement: &mut Arrangement, located: &[Located]) -> anyhow::Result<()> {
    arrangement
        .extra
        .insert("locate".into(), serde_json::to_value(located)?);
    Ok(())
}

/// Writes what the object search saw of the image `name` into `dir` (created when missing), as PNGs
/// at the search's resolution: `<stem>.query.png` (the image), `<stem>.room.png` (the empty room as the
/// image's light shows it, which the objects must explain the image better than),
/// `<stem>.light.png` (that light relative to the captures', linear gain / 2, when it varies over the
/// image) and `<stem>.evidence.png` (their difference ×4, the detected regions in red).
pub fn write_search_view(
    dir: &Path,
    name: &str,
    view: &SearchView,
    detections: &[Detection],
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create", dir.display()))?;
    let stem = Path::new(name)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "view".into());
    let path = |kind: &str| dir.join(format!("{stem}.{kind}.png"));
    formats::write_rgb(path("query"), &view.query)?;
    formats::write_rgb(path("room"), &view.empty)?;
    if let Some(light) = &view.light {
        let gains = RgbImage {
            width: view.query.width,
            height: view.query.height,
            data: light
                .field
                .gains
                .iter()
                .map(|g| g.map(|x| linear_to_srgb((0.5 * x).min(1.0))))
                .collect(),
        };
        formats::write_rgb(path("light"), &gains)?;
    }
    let mut evidence = RgbImage {
        width: view.query.width,
        height: view.query.height,
        data: (view.query.data.iter().zip(&view.empty.data))
            .map(|(q, e)| [(4.0 * colour_error(*q, *e)).min(1.0); 3])
            .collect(),
    };
    for d in detections {
        for &p in &d.pixels {
            let c = &mut evidence.data[p as usize];
            *c = [0.5 + 0.5 * c[0], 0.5 * c[1], 0.5 * c[2]];
        }
    }
    formats::write_rgb(path("evidence"), &evidence)?;
    Ok(())
}

/// Reads the image `locate` is given: a panorama (twice as wide as high), or with `intrinsics` (a
/// JSON file of `transforms.json`'s camera keys, [`formats::read_intrinsics_file`]) a photo of that
/// size.
pub fn read_query(image: &Path, intrinsics: Option<&Path>) -> anyhow::Result<QueryImage> {
    let rgb = formats::read_colour_photo(image)?.image;
    let Some(intrinsics) = intrinsics else {
        // The shape check of `formats::read_panorama`, with the hint only a wrong shape needs.
        Equirect::new(rgb.width, rgb.height).map_err(|e| {
            anyhow::anyhow!("{}: {e} (a photo needs --intrinsics)", image.display())
        })?;
        return Ok(QueryImage::Panorama(rgb));
    };
    let camera = formats::read_intrinsics_file(intrinsics)?;
    anyhow::ensure!(
        (camera.width, camera.height) == (rgb.width, rgb.height),
        "{}: the photo is {}×{} but {} gives intrinsics for {}×{}",
        image.display(),
        rgb.width,
        rgb.height,
        intrinsics.display(),
        camera.width,
        camera.height
    );
    Ok(QueryImage::Photo { rgb, camera })
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
    /// Identification and pose scores (docs/formats.md metrics) of the final arrangement: after the fit when
    /// it ran, else the initial poses.
    pub objects: ArrangementScore,
    /// The initial poses' scores, when the fit ran after them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<ArrangementScore>,
    /// Seconds for the whole panorama (camera + objects, and the fit when it ran).
    pub seconds: f64,
    /// The object search's objective at the initial poses it found and at the true poses, when
    /// measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub objective: Option<SearchObjective>,
    /// The camera's correlation with the empty room at the found and at the true camera
    /// ([`camera_correlation`]), when measured.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera_objective: Option<CameraObjective>,
    /// Details.
    pub located: Located,
}

/// The localization's objective ([`camera_correlation`], higher is better) at the camera it found and
/// at the true one. When the truth scores higher, the search never reached it; when lower, the
/// correlation prefers the wrong place.
#[derive(Clone, Copy, Debug, Serialize, Deserialize)]
pub struct CameraObjective {
    /// At the camera found.
    pub found: f64,
    /// At the true camera.
    pub truth: f64,
}

/// The object search's objective ([`neuroom_locate::objects::arrangement_error`], lower is better) at
/// the arrangement it found and at the true one, both seen from the found camera. When the truth scores
/// lower, the search missed it; when higher, its colour model prefers the wrong arrangement.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SearchObjective {
    /// At the initial poses found.
    pub found: f64,
    /// At the true poses.
    pub truth: f64,
    /// How each true object stands among the other true objects, as the search judges it
    /// ([`object_standings`]).
    #[serde(default)]
    pub truth_standings: Vec<ObjectStanding>,
}

/// [`SearchObjective`] of `located` against the arrangement `truth`, with `view` its query at the
/// found camera ([`object_view`]).
fn search_objective(
    ctx: &LocateContext,
    view: &SearchView,
    located: &Located,
    truth: &Arrangement,
    config: &LocateConfig,
) -> SearchObjective {
    let input = judging_input(ctx, view, located.search_pose());
    let placed_truth = placed_objects(ctx, truth);
    SearchObjective {
        found: arrangement_error(&input, &located.found, &config.search),
        truth: arrangement_error(&input, &placed_truth, &config.search),
        truth_standings: object_standings(&input, &placed_truth, &config.search),
    }
}

/// The object search's input for judging whole arrangements ([`arrangement_error`]) in `view`, seen
/// from `camera`: no detections.
fn judging_input<'a>(
    ctx: &'a LocateContext,
    view: &'a SearchView,
    camera: Pose,
) -> SearchInput<'a, NeusField> {
    SearchInput {
        empty: &ctx.scene,
        view,
        camera_to_world: camera,
        detections: &[],
        models: &ctx.objects,
    }
}

/// The objects of `arrangement` as the object search places them (those of a model of `ctx`).
fn placed_objects(ctx: &LocateContext, arrangement: &Arrangement) -> Vec<Found> {
    arrangement
        .objects
        .iter()
        .filter_map(|o| {
            let model = ctx.objects.iter().position(|m| m.ids.contains(&o.id))?;
            Some(Found {
                model,
                id: o.id,
                object_to_world: o.object_to_world.to_rows(),
                score: 0.0,
                explained: 0,
            })
        })
        .collect()
}

/// The fit's arrangement `solved`, with each object put back at its pose in `initial` where the
/// panorama is then explained better by the object search's colour model ([`arrangement_error`] in
/// `view`, the panorama at the found `camera`: `object_view`), object by object in turn; such an object is marked `"initial_pose": true`. An object
/// standing on another is then seated on it (`seated_on_supporters`). The fit's photometric loss under
/// a changed light can drag an object that the search had placed well: on the office and living presets
/// it moved the bookshelf 3–12 cm.
pub fn keep_better_poses(
    ctx: &LocateContext,
    view: &SearchView,
    camera: &Pose,
    initial: &Arrangement,
    solved: Arrangement,
    config: &LocateConfig,
) -> Arrangement {
    let input = judging_input(ctx, view, *camera);
    let error =
        |a: &Arrangement| arrangement_error(&input, &placed_objects(ctx, a), &config.search);
    let kept = back_where_better(initial, solved.clone(), &error);
    let supporters = |id: u16| -> Vec<u16> {
        let model = ctx.objects.iter().find(|m| m.ids.contains(&id));
        match model.map(|m| &m.support) {
            Some(Support::On(supporter)) => ctx.objects[*supporter].ids.clone(),
            _ => Vec::new(),
        }
    };
    seated_on_supporters(initial, &solved, kept, &supporters)
}

/// The fit's arrangement `solved` of the panorama `image`, checked as `neuroom locate` checks its own fit
/// ([`keep_better_poses`]) against the initial arrangement `initial`, at `initial`'s camera: what
/// `neuroom fit --check` does, in the room and models of `ctx`.
pub fn check_fit(
    ctx: &LocateContext,
    image: &RgbImage,
    initial: &Arrangement,
    solved: Arrangement,
    config: &LocateConfig,
) -> anyhow::Result<Arrangement> {
    let sphere = QueryImage::Panorama(image.clone()).sphere();
    let (sphere, camera) = levelled_for_search(sphere, &initial.camera_to_world)?;
    let view = object_view(ctx, &sphere, &camera, config);
    Ok(keep_better_poses(
        ctx, &view, &camera, initial, solved, config,
    ))
}

/// `kept` (objects at their pose in `initial` or in `solved`) with each object that stands on another
/// (`supporters` gives the ids of the instances it may stand on) raised or lowered by the height its
/// supporter changed between the arrangement its own pose comes from and `kept`: it rests on the top
/// it rested on there, not a few millimetres inside or above it.
fn seated_on_supporters(
    initial: &Arrangement,
    solved: &Arrangement,
    mut kept: Arrangement,
    supporters: &dyn Fn(u16) -> Vec<u16>,
) -> Arrangement {
    let position = |a: &Arrangement, id: u16| {
        a.objects
            .iter()
            .find(|o| o.id == id)
            .map(|o| o.object_to_world.translation)
    };
    let settled = kept.clone();
    for o in &mut kept.objects {
        let source = if o.extra.contains_key("initial_pose") {
            initial
        } else {
            solved
        };
        let at = o.object_to_world.translation;
        let under = supporters(o.id)
            .into_iter()
            .filter_map(|s| Some((s, position(source, s)?)))
            .min_by(|(_, a), (_, b)| {
                let d = |p: &glam::DVec3| (p.x - at.x).hypot(p.y - at.y);
                d(a).total_cmp(&d(b))
            });
        if let Some((s, before)) = under
            && let Some(now) = position(&settled, s)
        {
            o.object_to_world.translation.z += now.z - before.z;
        }
    }
    kept
}

/// `solved` with each object, in turn, put back at its pose in `initial` where that lowers `error`
/// (marked `"initial_pose": true`).
fn back_where_better(
    initial: &Arrangement,
    mut solved: Arrangement,
    error: &dyn Fn(&Arrangement) -> f64,
) -> Arrangement {
    let mut best = error(&solved);
    for k in 0..solved.objects.len() {
        let id = solved.objects[k].id;
        let Some(start) = initial.objects.iter().find(|o| o.id == id) else {
            continue;
        };
        let mut candidate = solved.clone();
        candidate.objects[k].object_to_world = start.object_to_world;
        let e = error(&candidate);
        if e < best {
            candidate.objects[k]
                .extra
                .insert("initial_pose".into(), true.into());
            (best, solved) = (e, candidate);
        }
    }
    solved
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
    /// Mean rotation error of the found objects up to their shape symmetry (degrees).
    #[serde(default)]
    pub are_up_to_symmetry_deg: f64,
    /// Mean position error of the found objects (cm).
    pub ape_cm: f64,
    /// Mean share of the objects found within 20 cm of where they stand
    /// ([`ArrangementScore::placed_share`]).
    #[serde(default)]
    pub placed_share: f64,
    /// Mean seconds per panorama.
    pub seconds: f64,
    /// Mean IoU, ARE and APE of the initial poses, when the fit ran after them.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub initial: Option<[f64; 3]>,
}

/// `neuroom bench locate`: locates every test panorama of `room` (those with ground truth) and scores
/// camera, identification and initial poses, and with `fit` the poses the holistic fit solves from
/// them. With `effect`, each panorama is first turned into what a camera with that effect would have
/// delivered (and a tilt tilts its true camera). `each` sees every panorama's score as it is measured.
pub fn bench_locate(
    room: &Path,
    models: &Path,
    config: &LocateConfig,
    fit: Option<&FitConfig>,
    effect: Option<&CameraEffect>,
    each: &mut dyn FnMut(&PanoramaScore),
) -> anyhow::Result<(Vec<PanoramaScore>, LocateMean)> {
    let ctx = LocateContext::load(room, models, config)?;
    let symmetries = ShapeSymmetries::of_room(&ctx.room)?;
    let hints = crate::fit::relation_hints(&ctx.room);
    let mut scores = Vec::new();
    for (png, mut truth) in test_panoramas(room)? {
        let mut image = read_rgb(&png)?.image;
        if let Some(effect) = effect {
            let affected = effect
                .apply(&image, &truth.camera_to_world)
                .map_err(|e| anyhow::anyhow!("{}: {e}", png.display()))?;
            (image, truth.camera_to_world) = (affected.image, affected.camera_to_world);
        }
        let name = png
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let start = Instant::now();
        let (initial, located, view) = locate_image(
            &ctx,
            &QueryImage::Panorama(image.clone()),
            &name,
            config,
            &mut |_| {},
        )?;
        let initial_score = fit.map(|_| score_in_room(&ctx.room, &symmetries, &truth, &initial));
        let camera = located.search_pose();
        let arrangement = match fit {
            Some(fit) if !initial.objects.is_empty() => {
                let result = crate::fit::fit_arrangement(
                    models,
                    &image,
                    &initial,
                    &hints,
                    config.object_light.as_deref(),
                    fit,
                    &mut |_| {},
                )?;
                let solved = crate::fit::solved_arrangement(&initial, &result.report(), &name);
                keep_better_poses(&ctx, &view, &camera, &initial, solved, config)
            }
            _ => initial,
        };
        let seconds = start.elapsed().as_secs_f64();
        let objective = search_objective(&ctx, &view, &located, &truth, config);
        let sphere = QueryImage::Panorama(image.clone()).sphere();
        let correlation =
            |pose: &Pose| camera_correlation(&ctx.scene, &sphere, pose, &config.localize);
        let camera_objective = CameraObjective {
            found: correlation(&located.camera.pose()),
            truth: correlation(&truth.camera_to_world),
        };
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
            objects: score_in_room(&ctx.room, &symmetries, &truth, &arrangement),
            initial: initial_score,
            seconds,
            objective: Some(objective),
            camera_objective: Some(camera_objective),
            located,
        };
        each(&score);
        scores.push(score);
    }
    let mean = mean_scores(&scores);
    Ok((scores, mean))
}

/// Means over `scores`; IoU, ARE and APE over the images where they are defined (objects to find, and
/// found).
pub(crate) fn mean_scores(scores: &[PanoramaScore]) -> LocateMean {
    let n = scores.len().max(1) as f64;
    let mean = |f: &dyn Fn(&PanoramaScore) -> f64| scores.iter().map(f).sum::<f64>() / n;
    let max = |f: &dyn Fn(&PanoramaScore) -> f64| scores.iter().map(f).fold(0.0, f64::max);
    let defined = |f: &dyn Fn(&PanoramaScore) -> Option<f64>| {
        let values: Vec<f64> = scores.iter().filter_map(f).collect();
        values.iter().sum::<f64>() / values.len().max(1) as f64
    };
    LocateMean {
        panoramas: scores.len(),
        camera_position_error_cm: mean(&|s| s.camera_position_error_cm),
        camera_position_error_max_cm: max(&|s| s.camera_position_error_cm),
        camera_rotation_error_deg: mean(&|s| s.camera_rotation_error_deg),
        camera_rotation_error_max_deg: max(&|s| s.camera_rotation_error_deg),
        precision: mean(&|s| s.objects.precision),
        recall: mean(&|s| s.objects.recall),
        iou_percent: defined(&|s| s.objects.mean_iou_percent),
        are_deg: defined(&|s| s.objects.mean_rotation_error_deg),
        are_up_to_symmetry_deg: defined(&|s| s.objects.mean_rotation_error_up_to_symmetry_deg),
        ape_cm: defined(&|s| s.objects.mean_position_error_cm),
        placed_share: mean(&|s| s.objects.placed_share),
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

/// The test panoramas of a room folder: `panoramas/*.png` (or `.jpg`) with a ground-truth `*.json`
/// beside them; an error when there is none.
pub fn test_panoramas(room: &Path) -> anyhow::Result<Vec<(PathBuf, Arrangement)>> {
    let out = listed_test_panoramas(room)?;
    anyhow::ensure!(
        !out.is_empty(),
        "{}: no panorama with a ground-truth arrangement",
        room.join("panoramas").display()
    );
    Ok(out)
}

/// [`test_panoramas`], possibly none.
pub(crate) fn listed_test_panoramas(room: &Path) -> anyhow::Result<Vec<(PathBuf, Arrangement)>> {
    let dir = room.join("panoramas");
    let entries =
        std::fs::read_dir(&dir).with_context(|| format!("{}: cannot list", dir.display()))?;
    let mut paths: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| crate::inspect::is_panorama_image(&n.to_string_lossy()))
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
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn arrangement(xs: &[f64]) -> Arrangement {
        Arrangement {
            image: String::new(),
            camera_to_world: Pose::IDENTITY,
            objects: xs
                .iter()
                .enumerate()
                .map(|(k, &x)| ArrangedObject {
                    id: k as u16 + 1,
                    name: format!("object{k}"),
                    object_to_world: Pose::from_yaw_translation(0.0, DVec3::new(x, 0.0, 0.0)),
                    extra: Default::default(),
                })
                .collect(),
            lighting: serde_json::Value::Null,
            extra: Default::default(),
        }
    }

    /// Per object of `a`, whether the check put it back at its initial pose.
    fn marked_initial(a: &Arrangement) -> Vec<bool> {
        a.objects
            .iter()
            .map(|o| o.extra.contains_key("initial_pose"))
            .collect()
    }

    #[test]
    fn test_panoramas_are_png_or_jpeg_images_with_a_truth_beside_them() {
        let dir = tempfile::tempdir().unwrap();
        let panoramas = dir.path().join("panoramas");
        std::fs::create_dir_all(&panoramas).unwrap();
        let truth = Arrangement {
            image: "a.png".into(),
            ..arrangement(&[1.0])
        };
        for name in ["b.jpg", "a.png", "c.jpeg", "no_truth.jpg"] {
            std::fs::write(panoramas.join(name), b"").unwrap();
        }
        for stem in ["a", "b", "c"] {
            formats::write_arrangement(panoramas.join(format!("{stem}.json")), &truth).unwrap();
        }
        for side in ["a.depth.png", "a.mask.png"] {
            std::fs::write(panoramas.join(side), b"").unwrap();
        }
        let found: Vec<String> = test_panoramas(dir.path())
            .unwrap()
            .iter()
            .map(|(p, _)| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(found, ["a.png", "b.jpg", "c.jpeg"]);
    }

    #[test]
    fn the_object_search_sees_the_objects_under_the_light_code_it_names() {
        let room = neuroom_core::formats::parse_room(
            Path::new("room.json"),
            neuroom_testing::TINY_ROOM_JSON.as_bytes(),
        )
        .unwrap();
        let models = neuroom_testing::tiny_models();
        let colours = |light| {
            object_models(&room, &models, light).unwrap()[0]
                .coarse
                .colors
                .clone()
        };
        let capture = colours(None);
        assert!(!capture.is_empty());
        assert_eq!(capture, colours(Some("capture")));
        assert_ne!(capture, colours(Some("warm")));
        let message = format!(
            "{:#}",
            object_models(&room, &models, Some("sunset")).unwrap_err()
        );
        assert!(
            message.contains("`ball`")
                && message.contains("`sunset`")
                && message.contains("capture, warm, cold"),
            "{message}"
        );
    }

    #[test]
    fn an_object_goes_back_to_its_initial_pose_only_where_that_explains_better() {
        // The truth stands at x = 1, 2, 3; the error is the summed distance to it.
        let error = |a: &Arrangement| {
            a.objects
                .iter()
                .map(|o| (o.object_to_world.translation.x - o.id as f64).abs())
                .sum::<f64>()
        };
        let initial = arrangement(&[1.1, 2.5, 3.0]);
        let solved = arrangement(&[1.0, 2.9, 3.2]);
        let kept = back_where_better(&initial, solved, &error);
        let xs: Vec<f64> = kept
            .objects
            .iter()
            .map(|o| o.object_to_world.translation.x)
            .collect();
        assert_eq!(xs, [1.0, 2.5, 3.0]);
        assert_eq!(marked_initial(&kept), [false, true, true]);
    }

    #[test]
    fn the_fits_check_puts_back_an_object_the_fit_moved_off_what_the_panorama_shows() {
        use neuroom_testing::{TINY_ROOM_JSON, tiny_arrangement, write_tiny_models};
        let dir = tempfile::tempdir().unwrap();
        let (room, models) = (dir.path().join("room"), dir.path().join("models"));
        std::fs::create_dir_all(&room).unwrap();
        std::fs::write(room.join("room.json"), TINY_ROOM_JSON).unwrap();
        write_tiny_models(&models).unwrap();
        let truth = tiny_arrangement();
        let truth_path = dir.path().join("truth.json");
        formats::write_arrangement(&truth_path, &truth).unwrap();
        let camera = crate::view::ViewCamera::Panorama { width: 256 };
        let image = crate::view::render_arrangement(&models, &truth_path, &camera)
            .unwrap()
            .rgb;
        // The "fit" slid the stool 30 cm sideways and left the balls.
        let mut solved = truth.clone();
        solved.objects[2].object_to_world.translation.y += 0.3;
        let config = LocateConfig::default();
        let ctx = LocateContext::load(&room, &models, &config).unwrap();
        let checked = check_fit(&ctx, &image, &truth, solved, &config).unwrap();
        assert_eq!(marked_initial(&checked), [false, false, true]);
        let stool = checked.objects[2].object_to_world.translation;
        assert!(stool.distance(truth.objects[2].object_to_world.translation) < 1e-3);
    }

    #[test]
    fn an_object_rests_on_its_supporter_at_the_height_the_supporter_keeps() {
        // Object 1 is a cabinet, 2 and 3 stand on it; 4 stands on nothing.
        let supporters = |id: u16| if matches!(id, 2 | 3) { vec![1] } else { vec![] };
        let at = |zs: [f64; 4]| {
            let mut a = arrangement(&[0.0, 0.1, -0.1, 2.0]);
            for (o, z) in a.objects.iter_mut().zip(zs) {
                o.object_to_world.translation.z = z;
            }
            a
        };
        let initial = at([0.40, 0.90, 0.90, 0.3]);
        let solved = at([0.42, 0.91, 0.93, 0.5]);
        let mark = |a: &mut Arrangement, id: u16, z: f64| {
            let o = a.objects.iter_mut().find(|o| o.id == id).unwrap();
            o.object_to_world.translation.z = z;
            o.extra.insert("initial_pose".into(), true.into());
        };
        // The cabinet keeps the fit's height: object 2, put back, rises with it; 3 keeps the fit's.
        let mut kept = solved.clone();
        mark(&mut kept, 2, 0.90);
        mark(&mut kept, 4, 0.3);
        let seated = seated_on_supporters(&initial, &solved, kept, &supporters);
        let zs: Vec<f64> = seated
            .objects
            .iter()
            .map(|o| o.object_to_world.translation.z)
            .collect();
        let want = [0.42, 0.92, 0.93, 0.3];
        assert!(
            zs.iter().zip(want).all(|(z, w)| (z - w).abs() < 1e-12),
            "{zs:?}"
        );
        // The cabinet put back: object 3, at the fit's pose, comes down with it.
        let mut kept = solved.clone();
        mark(&mut kept, 1, 0.40);
        let seated = seated_on_supporters(&initial, &solved, kept, &supporters);
        let z3 = seated.objects[2].object_to_world.translation.z;
        assert!((z3 - 0.91).abs() < 1e-12, "{z3}");
    }
}

#[cfg(test)]
mod free_space_tests {
    use super::*;

    /// A copy of the tiny room whose first object's capture says `tracked_poses` and declares the
    /// depth noise `noise`, with that object.
    fn tiny_room_with(
        tracked: bool,
        noise: Option<formats::DepthNoise>,
    ) -> (tempfile::TempDir, Room) {
        let scratch = tempfile::tempdir().unwrap();
        let tiny = Path::new(env!("CARGO_MANIFEST_DIR")).join("../neuroom-core/tests/rooms/tiny");
        neuroom_testing::copy_folder(&tiny, scratch.path());
        let room = crate::read_room(scratch.path()).unwrap();
        let dir = room.capture_dir(&room.objects[0].capture);
        let mut capture = formats::read_capture(&dir).unwrap();
        capture.device.tracked_poses = tracked;
        capture.device.depth_noise = noise;
        formats::write_capture(&dir, &capture).unwrap();
        (scratch, room)
    }

    /// The capture's frames `indices` at their poses turned by `yaw` about the vertical.
    fn refined(room: &Room, indices: &[usize], yaw: f64) -> RefinedPoses {
        let capture = formats::read_capture(room.capture_dir(&room.objects[0].capture)).unwrap();
        let turn = Pose::from_yaw_translation(yaw, glam::DVec3::ZERO);
        RefinedPoses {
            frames: indices
                .iter()
                .map(|&index| formats::RefinedFrame {
                    index,
                    image: capture.frames[index].image.clone(),
                    camera_to_world: turn.compose(&capture.frames[index].camera_to_world),
                })
                .collect(),
        }
    }

    #[test]
    fn tracked_poses_carve_by_their_refined_poses_alone() {
        let (_scratch, room) = tiny_room_with(true, None);
        let object = &room.objects[0];
        let ids = [object.id];
        let free = |refined: Option<&RefinedPoses>| free_space(&room, object, &ids, refined);
        assert!(
            free(None).unwrap().is_empty(),
            "a tracker's poses carve nothing"
        );
        let refined = refined(&room, &[1], 0.1);
        let views = free(Some(&refined)).unwrap();
        assert_eq!(views.len(), 1, "the refined frames alone");
        let capture = formats::read_capture(room.capture_dir(&object.capture)).unwrap();
        let expected = object
            .capture_to_object
            .compose(&refined.frames[0].camera_to_world);
        let got = views[0].camera_to_model;
        assert!((got.translation - expected.translation).length() < 1e-9);
        assert!(capture.frames.len() > 1);
        let mut other = refined.clone();
        other.frames[0].image = "images/elsewhere.png".into();
        let err = free(Some(&other)).unwrap_err().to_string();
        assert!(err.contains("another recording"), "{err}");
    }

    #[test]
    fn exact_captures_carve_and_noisy_depth_frees_less() {
        let free = |tracked, noise| {
            let (_scratch, room) = tiny_room_with(tracked, noise);
            let object = &room.objects[0];
            free_space(&room, object, &[object.id], None).unwrap()
        };
        let exact = free(false, None);
        assert!(!exact.is_empty());
        let noisy = free(false, Some(formats::DepthNoise::PHONE_LIDAR));
        let surface = |views: &[FreeSpace]| -> Vec<f32> {
            views
                .iter()
                .flat_map(|v| v.free.iter().copied().filter(|f| f.is_finite() && *f > 0.0))
                .collect()
        };
        let (exact, noisy) = (surface(&exact), surface(&noisy));
        assert_eq!(exact.len(), noisy.len());
        for (e, n) in exact.iter().zip(&noisy) {
            let spread = 2.0 * formats::DepthNoise::PHONE_LIDAR.sigma_at(*e);
            assert!((e - n - spread).abs() < 1e-5, "{e} → {n}");
        }
    }
}

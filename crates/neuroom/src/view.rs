//! Rendering a trained room as an arrangement places it, from the panorama camera or any pinhole view.

use std::path::Path;

use glam::DVec3;
use neuroom_core::Pose;
use neuroom_core::camera::{Camera, Equirect, Pinhole, look_at};
use neuroom_core::formats::{self, Arrangement, read_arrangement};
use neuroom_core::image::{DepthImage, MaskImage, RgbImage};
use neuroom_export::lighting::{LitScene, SceneLight, fit_report_path};
pub use neuroom_render::RenderedShare;
use neuroom_render::{RenderConfig, render_image_reporting};

use crate::edit::{PlacedModels, place_models};

/// Which camera to render from.
#[derive(Clone, Debug)]
pub enum ViewCamera {
    /// An equirectangular panorama `width × width/2` at the arrangement's camera.
    Panorama {
        /// Width in pixels (even).
        width: u32,
    },
    /// A pinhole camera at `eye` looking at `target` (world z up) with a horizontal field of view.
    Pinhole {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Horizontal field of view, degrees.
        fov_deg: f64,
        /// Camera centre, world metres.
        eye: DVec3,
        /// Point looked at, world metres.
        target: DVec3,
    },
}

impl ViewCamera {
    /// A pinhole camera when both `eye` and `target` are given (height defaults to ¾ of the width), the
    /// arrangement's panorama otherwise: what every rendering command's `--eye/--look-at` options mean.
    pub fn from_options(
        eye: Option<DVec3>,
        target: Option<DVec3>,
        width: u32,
        height: Option<u32>,
        fov_deg: f64,
    ) -> Self {
        match (eye, target) {
            (Some(eye), Some(target)) => ViewCamera::Pinhole {
                width,
                height: height.unwrap_or(width * 3 / 4),
                fov_deg,
                eye,
                target,
            },
            _ => ViewCamera::Panorama { width },
        }
    }

    /// The camera model and its pose, given the arrangement's panorama camera.
    pub fn resolve(&self, panorama_pose: &Pose) -> anyhow::Result<(Camera, Pose)> {
        match *self {
            ViewCamera::Panorama { width } => {
                let camera = Equirect::new(width, width / 2).map_err(anyhow::Error::msg)?;
                Ok((Camera::Equirect(camera), *panorama_pose))
            }
            ViewCamera::Pinhole {
                width,
                height,
                fov_deg,
                eye,
                target,
            } => {
                anyhow::ensure!(width > 0 && height > 0, "image size must be positive");
                anyhow::ensure!(
                    fov_deg > 1.0 && fov_deg < 179.0,
                    "field of view must lie in (1°, 179°)"
                );
                anyhow::ensure!((target - eye).length() > 1e-6, "eye and target must differ");
                let f = 0.5 * width as f64 / (0.5 * fov_deg.to_radians()).tan();
                let camera =
                    Pinhole::new(width, height, f, f, 0.5 * width as f64, 0.5 * height as f64);
                Ok((Camera::Pinhole(camera), look_at(eye, target)))
            }
        }
    }
}

/// A rendered view: colour (sRGB), depth (pinhole z-depth or panorama ray distance) and instance ids.
pub struct RenderedView {
    /// Colour.
    pub rgb: RgbImage,
    /// Depth in metres, 0 where nothing was hit.
    pub depth: DepthImage,
    /// Instance ids, 0 for the background.
    pub mask: MaskImage,
}

/// A room's models placed by an arrangement, under the arrangement's solved lighting.
pub struct SolvedScene {
    /// The arrangement.
    pub arrangement: Arrangement,
    /// The scene; every layer owns a light code row, so lightings can be written into it.
    pub lit: LitScene,
    /// The lighting the fit solved (objects' codes and tones, the room's from the report beside the
    /// arrangement); empty for an arrangement that is not a fit's output.
    pub solved: SceneLight,
    /// What the scene's models are (names, light code names, boxes), by model index.
    pub placed: PlacedModels,
}

/// Places the models of `models` as the arrangement file says (objects an edit inserted from another
/// room's models included) and applies its solved lighting: the objects' `tone` and `light_code`, and
/// the room's from `<stem>.fit.json` beside it when that exists.
pub fn solved_scene(models: &Path, arrangement_path: &Path) -> anyhow::Result<SolvedScene> {
    let arrangement = read_arrangement(arrangement_path)?;
    let report = fit_report_path(arrangement_path);
    let report = report.exists().then_some(report.as_path());
    placed_scene(models, arrangement, arrangement_path, report)
}

/// Places the models of `models` as `arrangement` says under its solved lighting: the objects' `tone`
/// and `light_code`, and the room's from the fit report `fit_report` when given, else from the
/// arrangement's `background_light_code` and `background_tone`. Errors name `source`, the file the
/// arrangement came from (or stands for).
pub fn placed_scene(
    models: &Path,
    arrangement: Arrangement,
    source: &Path,
    fit_report: Option<&Path>,
) -> anyhow::Result<SolvedScene> {
    let (scene, placed) = place_models(models, &arrangement)?;
    let solved = SceneLight::solved(&arrangement, source, fit_report)?;
    let mut lit = LitScene::new(scene);
    lit.set(&solved)?;
    Ok(SolvedScene {
        arrangement,
        lit,
        solved,
        placed,
    })
}

/// Renders `scene` from `camera` (the panorama camera is the arrangement's).
pub fn render_view(scene: &SolvedScene, camera: &ViewCamera) -> anyhow::Result<RenderedView> {
    let (camera, pose) = camera.resolve(&scene.arrangement.camera_to_world)?;
    Ok(render_camera(scene, &camera, &pose, &|_| {}))
}

/// Renders `scene` from a camera model at `camera_to_world`, telling `progress` how far it is
/// ([`render_image_reporting`]).
pub fn render_camera(
    scene: &SolvedScene,
    camera: &Camera,
    camera_to_world: &Pose,
    progress: &(dyn Fn(RenderedShare) + Sync),
) -> RenderedView {
    let (rgb, depth, mask) = render_image_reporting(
        &scene.lit.scene,
        camera,
        camera_to_world,
        &RenderConfig::default(),
        progress,
    );
    RenderedView { rgb, depth, mask }
}

/// Renders the models in `models` (a room's model folder) placed as the arrangement file says, under
/// its solved lighting when it carries one.
pub fn render_arrangement(
    models: &Path,
    arrangement: &Path,
    camera: &ViewCamera,
) -> anyhow::Result<RenderedView> {
    render_view(&solved_scene(models, arrangement)?, camera)
}

/// Writes a view: colour to `rgb`, and depth (16-bit millimetres) and instance mask where asked.
pub fn write_view(
    view: &RenderedView,
    rgb: &Path,
    depth: Option<&Path>,
    mask: Option<&Path>,
) -> anyhow::Result<()> {
    formats::write_rgb(rgb, &view.rgb)?;
    if let Some(p) = depth {
        formats::write_depth(p, &view.depth, formats::transforms::DEFAULT_DEPTH_UNIT)?;
    }
    if let Some(p) = mask {
        formats::write_mask(p, &view.mask)?;
    }
    Ok(())
}

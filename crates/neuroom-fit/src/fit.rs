//! The holistic fit: stage 1 solves the object poses under the photometric, observation and physical
//! losses; stage 2 freezes the poses and adapts tone adjusters, light codes and appearance codes to the
//! panorama's lighting. One [`Fitter`] holds every buffer, so an iteration allocates nothing once grown.

use crate::alignment::alignment_loss;
use crate::codes::FitField;
use crate::config::FitConfig;
use crate::gravity::gravity_loss;
use crate::magnetic::magnetic_loss;
use crate::observation::{observation_loss, view_directions};
use crate::optim::ScalarAdam;
use crate::photometric::photometric_loss;
use crate::pose_grad::{self, PoseGrad};
use crate::probe::Probe;
use crate::relations::{Hint, Relation, RoomBox, generate_relations};
use crate::sampling::{PixelSampler, box_entry, dilate, object_mask};
use crate::search::search_poses;
use crate::surface::{SurfacePoints, sample_surface};
use crate::violation::violation_loss;
use glam::{Mat3, Vec3};
use neuroom_core::camera::{CameraModel, Equirect};
use neuroom_core::image::RgbImage;
use neuroom_core::rotation6d::rotation_to_6d_f32;
use neuroom_core::{Pose, Ray};
use neuroom_field::health::{Health, MAX_FAULTS_IN_A_ROW};
use neuroom_field::{Adam, AdamConfig, Group, NUM_GROUPS, Params};
use neuroom_render::volume::RayOutput;
use neuroom_render::{Renderer, Scene, Tone, render_image};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// The initial estimate of one object.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectInit {
    /// Its id (the scene object with this `instance_id`).
    pub id: u16,
    /// Its name (resolves `on:<name>` hints).
    pub name: String,
    /// Initial `object_to_world`.
    pub pose: Pose,
    /// Whether it stands upright (gravity loss, yaw-only rotation).
    pub upright: bool,
    /// Relation hints of room.json.
    pub hints: Vec<Hint>,
}

/// Why a fit could not start.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FitError(pub String);

impl std::fmt::Display for FitError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FitError {}

/// Which stage an iteration belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// Poses.
    Poses,
    /// Tone adjusters, light and appearance codes.
    Appearance,
}

/// The weighted losses of one iteration (0 for those switched off or not in the stage).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IterationLog {
    /// Iteration number, counted over both stages.
    pub iteration: usize,
    /// Stage.
    pub stage: Stage,
    /// Photometric loss.
    pub photometric: f32,
    /// Observation loss.
    pub observation: f32,
    /// Magnetic loss.
    pub magnetic: f32,
    /// Violation loss.
    pub violation: f32,
    /// Gravity loss.
    pub gravity: f32,
    /// Wall alignment loss.
    #[serde(default)]
    pub alignment: f32,
    /// Number of relations held.
    pub relations: usize,
}

impl IterationLog {
    /// Sum of the weighted losses.
    pub fn total(&self) -> f32 {
        self.photometric
            + self.observation
            + self.magnetic
            + self.violation
            + self.gravity
            + self.alignment
    }
}

/// Wall-clock time of a fit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FitTimings {
    /// Surface points, first relations and mask (seconds).
    pub setup_s: f64,
    /// Render-and-compare search (seconds).
    pub search_s: f64,
    /// Stage 1 (seconds).
    pub poses_s: f64,
    /// Stage 2 (seconds).
    pub appearance_s: f64,
    /// Before/after previews (seconds).
    pub previews_s: f64,
}

/// One solved object.
#[derive(Clone, Debug, PartialEq)]
pub struct FittedObject {
    /// Its id.
    pub id: u16,
    /// Solved `object_to_world`.
    pub pose: Pose,
    /// Solved tone adjuster.
    pub tone: Tone,
    /// Its light code row after adaptation (empty for fields without codes).
    pub light_code: Vec<f32>,
}

/// One solved object as written beside an arrangement (docs/formats.md lets outputs add fields).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FittedObjectReport {
    /// Its id.
    pub id: u16,
    /// Solved `object_to_world`, 4 rows of 4.
    pub object_to_world: [[f64; 4]; 4],
    /// Solved tone adjuster.
    pub tone: Tone,
    /// Light code row after adaptation.
    pub light_code: Vec<f32>,
}

/// The serialisable part of a [`FitResult`]: solution, relations, loss log and timings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// The solved objects.
    pub objects: Vec<FittedObjectReport>,
    /// Background tone adjuster.
    pub background_tone: Tone,
    /// Background light code row.
    pub background_light_code: Vec<f32>,
    /// Relations held at the end.
    pub relations: Vec<Relation>,
    /// Losses per iteration.
    pub log: Vec<IterationLog>,
    /// Time spent.
    pub timings: FitTimings,
    /// Steps skipped because their loss or gradient was not finite.
    #[serde(default)]
    pub faulty_steps: u64,
    /// Objects that left the room, and other things the user should know.
    #[serde(default)]
    pub warnings: Vec<String>,
}

/// What a fit returns.
#[derive(Clone, Debug)]
pub struct FitResult<F> {
    /// The solved objects, in the scene's order.
    pub objects: Vec<FittedObject>,
    /// Solved tone adjuster of the background.
    pub background_tone: Tone,
    /// Light code row of the background after adaptation.
    pub background_light_code: Vec<f32>,
    /// Relations held at the end.
    pub relations: Vec<Relation>,
    /// Losses per iteration.
    pub log: Vec<IterationLog>,
    /// Time spent.
    pub timings: FitTimings,
    /// Steps skipped because their loss or gradient was not finite.
    pub faulty_steps: u64,
    /// What the caller should be told: objects that left the room.
    pub warnings: Vec<String>,
    /// The panorama rendered at the initial estimate (if previews were asked for).
    pub before: Option<RgbImage>,
    /// The panorama rendered at the solution.
    pub after: Option<RgbImage>,
    /// The solved scene (poses, tones, adapted code rows).
    pub scene: Scene<F>,
}

impl<F> FitResult<F> {
    /// The solution, relations, log and timings as one serialisable report.
    pub fn report(&self) -> FitReport {
        FitReport {
            objects: self
                .objects
                .iter()
                .map(|o| FittedObjectReport {
                    id: o.id,
                    object_to_world: o.pose.to_rows(),
                    tone: o.tone,
                    light_code: o.light_code.clone(),
                })
                .collect(),
            background_tone: self.background_tone,
            background_light_code: self.background_light_code.clone(),
            relations: self.relations.clone(),
            log: self.log.clone(),
            timings: self.timings,
            faulty_steps: self.faulty_steps,
            warnings: self.warnings.clone(),
        }
    }
}

/// Renders a panorama of `scene` with `height` rows from `camera_to_world`.
pub fn render_panorama<F: FitField>(
    scene: &Scene<F>,
    camera_to_world: &Pose,
    height: u32,
    config: &FitConfig,
) -> RgbImage {
    let camera = Equirect {
        width: 2 * height,
        height,
    };
    render_image(scene, &camera, camera_to_world, &config.render).0
}

/// Fits the objects of `scene` to `panorama` seen from `camera_to_world` (known), starting from `init`
/// (one entry per scene object, matched by id), in the free space `room`. `progress` sees every
/// iteration's losses.
pub fn fit<F: FitField>(
    mut scene: Scene<F>,
    room: &RoomBox,
    panorama: &RgbImage,
    camera_to_world: &Pose,
    init: &[ObjectInit],
    config: &FitConfig,
    progress: &mut dyn FnMut(&IterationLog),
) -> Result<FitResult<F>, FitError> {
    let start = Instant::now();
    let camera = Equirect::new(panorama.width, panorama.height).map_err(FitError)?;
    let inits = place_objects(&mut scene, init)?;
    let mut fitter = Fitter::new(
        scene,
        room,
        panorama,
        camera,
        camera_to_world,
        inits,
        config,
    );
    let mut timings = FitTimings {
        setup_s: start.elapsed().as_secs_f64(),
        ..FitTimings::default()
    };
    let t = Instant::now();
    let before = config
        .preview_height
        .map(|h| render_panorama(&fitter.scene, camera_to_world, h, config));
    timings.previews_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    if config.pose_iterations > 0 {
        fitter.search();
    }
    timings.search_s = t.elapsed().as_secs_f64();
    let mut log = Vec::with_capacity(config.pose_iterations + config.appearance_iterations);
    let t = Instant::now();
    for it in 0..config.pose_iterations {
        log.push(fitter.pose_step(it));
        progress(log.last().expect("just pushed"));
        fitter.check_health(it)?;
    }
    timings.poses_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    for it in 0..config.appearance_iterations {
        log.push(fitter.appearance_step(config.pose_iterations + it));
        progress(log.last().expect("just pushed"));
        fitter.check_health(config.pose_iterations + it)?;
    }
    timings.appearance_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let after = config
        .preview_height
        .map(|h| render_panorama(&fitter.scene, camera_to_world, h, config));
    timings.previews_s += t.elapsed().as_secs_f64();
    Ok(fitter.finish(log, timings, before, after))
}

/// Sets every scene object's pose from its `init` entry; returns the entries in scene order.
fn place_objects<F>(
    scene: &mut Scene<F>,
    init: &[ObjectInit],
) -> Result<Vec<ObjectInit>, FitError> {
    scene
        .objects
        .iter_mut()
        .map(|o| {
            let entry = init.iter().find(|i| i.id == o.instance_id).ok_or_else(|| {
                FitError(format!("no initial pose for object id {}", o.instance_id))
            })?;
            o.set_pose(&entry.pose);
            Ok(entry.clone())
        })
        .collect()
}

/// The state of a running fit.
pub struct Fitter<'a, F: FitField> {
    scene: Scene<F>,
    room: RoomBox,
    panorama: &'a RgbImage,
    camera: Equirect,
    camera_to_world: Pose,
    config: FitConfig,
    names: Vec<String>,
    hints: Vec<Vec<Hint>>,
    upright: Vec<bool>,
    initial_dirs: Vec<Vec3>,
    surfaces: Vec<SurfacePoints>,
    relations: Vec<Relation>,
    sampler: PixelSampler,
    renderer: Renderer<F>,
    rng: Pcg64Mcg,
    pixels: Vec<u32>,
    rays: Vec<Ray>,
    targets: Vec<[f32; 3]>,
    d_out: Vec<RayOutput<f32>>,
    model_grads: Vec<Params<f32>>,
    pose_grads: Vec<PoseGrad>,
    probe: Probe,
    d_sdf: Vec<f32>,
    pose_adam: ScalarAdam,
    /// Non-finite steps skipped and the step-size scale they left.
    health: Health,
    pose_params: Vec<f32>,
    pose_flat_grads: Vec<f32>,
    pose_lr: Vec<f32>,
    tone_adam: ScalarAdam,
    code_adams: Vec<Option<Adam>>,
}

/// Scalars per object pose: translation (3) and 6D rotation (6).
const POSE_SCALARS: usize = 9;
/// Scalars per tone adjuster: shift (3) and scale (3).
const TONE_SCALARS: usize = 6;

impl<'a, F: FitField> Fitter<'a, F> {
    /// Sets up a fit of `scene` (objects at their initial poses, `init` in scene order).
    pub fn new(
        scene: Scene<F>,
        room: &RoomBox,
        panorama: &'a RgbImage,
        camera: Equirect,
        camera_to_world: &Pose,
        init: Vec<ObjectInit>,
        config: &FitConfig,
    ) -> Self {
        let n = scene.objects.len();
        let camera_pos = camera_to_world.translation.as_vec3();
        let surfaces = scene
            .objects
            .iter()
            .enumerate()
            .map(|(k, o)| {
                let field = &scene.models[o.model].field;
                sample_surface(
                    field,
                    o.half_extents,
                    config.surface_points,
                    config.seed + k as u64,
                )
            })
            .collect();
        let pose_lr = (0..n * POSE_SCALARS)
            .map(|i| {
                if i % POSE_SCALARS < 3 {
                    config.lr_translation
                } else {
                    config.lr_rotation
                }
            })
            .collect();
        let mut fitter = Self {
            room: *room,
            panorama,
            camera,
            camera_to_world: *camera_to_world,
            config: *config,
            names: init.iter().map(|i| i.name.clone()).collect(),
            hints: init.iter().map(|i| i.hints.clone()).collect(),
            upright: init.iter().map(|i| i.upright).collect(),
            initial_dirs: view_directions(&scene.objects, camera_pos),
            surfaces,
            relations: Vec::new(),
            sampler: PixelSampler::default(),
            renderer: Renderer::new(config.render),
            rng: Pcg64Mcg::seed_from_u64(config.seed),
            pixels: Vec::new(),
            rays: Vec::new(),
            targets: Vec::new(),
            d_out: Vec::new(),
            model_grads: scene.models.iter().map(|m| m.field.zero_grads()).collect(),
            pose_grads: Vec::new(),
            probe: Probe::default(),
            d_sdf: Vec::new(),
            pose_adam: ScalarAdam::new(n * POSE_SCALARS),
            health: Health::default(),
            pose_params: vec![0.0; n * POSE_SCALARS],
            pose_flat_grads: vec![0.0; n * POSE_SCALARS],
            pose_lr,
            tone_adam: ScalarAdam::new((n + 1) * TONE_SCALARS),
            code_adams: scene.models.iter().map(|_| None).collect(),
            scene,
        };
        if fitter.config.yaw_only_upright {
            fitter.project_upright();
        }
        fitter.refresh();
        fitter
    }

    /// The scene as it stands.
    pub fn scene(&self) -> &Scene<F> {
        &self.scene
    }

    /// Regenerates the relations and the object mask from the current poses.
    fn refresh(&mut self) {
        self.relations = generate_relations(
            &self.scene.objects,
            &self.room,
            &self.hints,
            &self.names,
            &self.config.rules,
        );
        let mask = object_mask(
            &self.camera,
            &self.camera_to_world,
            &self.scene.objects,
            self.config.render.box_padding,
        );
        let mask = dilate(
            &mask,
            self.camera.width() as usize,
            self.config.mask_dilation,
        );
        self.sampler = PixelSampler::new(&self.camera, &mask);
    }

    /// Draws this iteration's pixels into rays and target colours.
    fn draw_rays(&mut self) {
        let n_bg = (self.config.rays as f32 * self.config.background_fraction).round() as usize;
        self.sampler
            .draw(self.config.rays, n_bg, &mut self.rng, &mut self.pixels);
        let w = self.camera.width();
        self.rays.clear();
        self.targets.clear();
        for &p in &self.pixels {
            let (u, v) = (p % w, p / w);
            self.rays
                .push(self.camera.pixel_ray(&self.camera_to_world, u, v));
            self.targets.push(self.panorama.data[p as usize]);
        }
    }

    /// Renders the drawn rays and back-propagates the photometric loss; returns the loss and the scene
    /// gradient. Code gradients land in `model_grads`, zeroed first only when `codes` are wanted (stage
    /// 1 leaves them to accumulate unread: zeroing a room's hash-table gradient costs more per iteration
    /// than the losses).
    fn photometric(&mut self, iteration: usize, codes: bool) -> (f32, neuroom_render::SceneGrad) {
        self.draw_rays();
        self.renderer.config_mut().seed = iteration as u64;
        let out = self.renderer.render(&self.scene, &self.rays);
        let loss = photometric_loss(
            out,
            &self.targets,
            self.config.weights.photometric,
            &mut self.d_out,
        );
        if codes {
            self.model_grads.iter_mut().for_each(Params::fill_zero);
        }
        let grad = self
            .renderer
            .backward(&self.scene, &self.d_out, &mut self.model_grads);
        (loss, grad)
    }

    /// The render-and-compare search of positions and yaws ([`crate::search`]), if configured; the
    /// relations and the object mask are regenerated after it.
    pub fn search(&mut self) {
        let Some(search) = self.config.search else {
            return;
        };
        search_poses(
            &mut self.scene,
            &mut self.renderer,
            &self.surfaces,
            &self.room,
            &self.camera,
            &self.camera_to_world,
            self.panorama,
            &search,
            &mut self.rng,
        );
        if self.config.yaw_only_upright {
            self.project_upright();
        }
        self.refresh();
    }

    /// One iteration of stage 1 (poses).
    pub fn pose_step(&mut self, iteration: usize) -> IterationLog {
        if iteration > 0 && iteration.is_multiple_of(self.config.relation_interval.max(1)) {
            self.refresh();
        }
        let mut log = self.empty_log(iteration, Stage::Poses);
        pose_grad::reset(&mut self.pose_grads, self.scene.objects.len());
        let render_grad = if self.config.losses.photometric {
            let (loss, grad) = self.photometric(iteration, false);
            log.photometric = loss;
            Some(grad)
        } else {
            None
        };
        self.geometric_losses(&mut log);
        self.flatten_pose_grads(render_grad.as_ref());
        let finite = log.total().is_finite() && self.pose_flat_grads.iter().all(|g| g.is_finite());
        if !self.health.admit_finite(finite) {
            return log;
        }
        if let (true, Some(grad)) = (self.config.tone_in_pose_stage, &render_grad) {
            self.step_tones(grad);
        }
        let progress = iteration as f32 / self.config.pose_iterations.max(1) as f32;
        self.apply_pose_step(self.config.lr_final_factor.powf(progress) * self.health.lr_scale);
        log
    }

    /// Observation and physical losses into `pose_grads`.
    fn geometric_losses(&mut self, log: &mut IterationLog) {
        let (w, on) = (self.config.weights, self.config.losses);
        let objects = &self.scene.objects;
        if on.observation {
            let camera = self.camera_to_world.translation.as_vec3();
            log.observation = observation_loss(
                objects,
                camera,
                &self.initial_dirs,
                self.config.observation_tolerance_deg.to_radians(),
                w.observation,
                &mut self.pose_grads,
            );
        }
        if !on.physical {
            return;
        }
        log.gravity = gravity_loss(objects, &self.upright, w.gravity, &mut self.pose_grads);
        log.alignment = alignment_loss(objects, &self.relations, w.alignment, &mut self.pose_grads);
        log.violation = violation_loss(
            &self.scene,
            &self.surfaces,
            &self.relations,
            self.config.epsilon,
            w.violation,
            &mut self.probe,
            &mut self.d_sdf,
            &mut self.pose_grads,
        );
        log.magnetic = magnetic_loss(
            &self.scene,
            &self.room,
            &self.surfaces,
            &self.relations,
            w.magnetic,
            self.config.wall_gap,
            &mut self.probe,
            &mut self.d_sdf,
            &mut self.pose_grads,
        );
    }

    /// Gathers poses and their total gradients into flat vectors.
    fn flatten_pose_grads(&mut self, render: Option<&neuroom_render::SceneGrad>) {
        for (k, o) in self.scene.objects.iter().enumerate() {
            let g = &self.pose_grads[k];
            let mut gt = g.translation.to_array();
            let mut gr = g.rotation6d(o);
            if let Some(r) = render {
                let rg = &r.objects[k];
                (0..3).for_each(|a| gt[a] += rg.translation[a]);
                (0..6).for_each(|a| gr[a] += rg.rotation6d[a]);
            }
            let base = k * POSE_SCALARS;
            self.pose_params[base..base + 3].copy_from_slice(&o.translation.to_array());
            self.pose_params[base + 3..base + POSE_SCALARS].copy_from_slice(&o.rotation6d);
            self.pose_flat_grads[base..base + 3].copy_from_slice(&gt);
            self.pose_flat_grads[base + 3..base + POSE_SCALARS].copy_from_slice(&gr);
        }
    }

    /// One Adam step on the poses at `factor` times their rates, written back (re-orthonormalised 6D,
    /// upright projection if asked).
    fn apply_pose_step(&mut self, factor: f32) {
        self.pose_adam.step(
            &mut self.pose_params,
            &self.pose_flat_grads,
            &self.pose_lr,
            factor,
        );
        for (k, o) in self.scene.objects.iter_mut().enumerate() {
            let base = k * POSE_SCALARS;
            o.translation = Vec3::from_slice(&self.pose_params[base..base + 3]);
            let mut r6 = [0.0; 6];
            r6.copy_from_slice(&self.pose_params[base + 3..base + POSE_SCALARS]);
            o.rotation6d = rotation_to_6d_f32(neuroom_core::rotation6d::rotation_from_6d_f32(r6));
        }
        if self.config.yaw_only_upright {
            self.project_upright();
        }
    }

    /// Replaces the rotation of every upright object by the yaw-only rotation nearest in heading.
    fn project_upright(&mut self) {
        for (o, &upright) in self.scene.objects.iter_mut().zip(&self.upright) {
            if upright {
                let x = o.rotation().x_axis;
                let heading = Vec3::new(x.x, x.y, 0.0).normalize_or(Vec3::X);
                let r = Mat3::from_cols(heading, Vec3::Z.cross(heading), Vec3::Z);
                o.rotation6d = rotation_to_6d_f32(r);
            }
        }
    }

    /// One iteration of stage 2 (tone adjusters and code rows; poses frozen).
    pub fn appearance_step(&mut self, iteration: usize) -> IterationLog {
        let mut log = self.empty_log(iteration, Stage::Appearance);
        let adapt = self.config.adapt;
        let (loss, grad) = self.photometric(iteration, adapt.codes);
        log.photometric = loss;
        if !self.health.admit_finite(loss.is_finite()) {
            return log;
        }
        if adapt.tone {
            self.step_tones(&grad);
        }
        if adapt.codes {
            self.step_codes();
        }
        log
    }

    /// One Adam step on every tone adjuster (the background's last).
    fn step_tones(&mut self, grad: &neuroom_render::SceneGrad) {
        let flat = |t: &Tone| [t.shift.to_array(), t.scale.to_array()].concat();
        let mut params: Vec<f32> = self
            .scene
            .objects
            .iter()
            .flat_map(|o| flat(&o.tone))
            .collect();
        params.extend(flat(&self.scene.background.tone));
        let mut grads: Vec<f32> = grad.objects.iter().flat_map(|g| flat(&g.tone)).collect();
        grads.extend(flat(&grad.background_tone));
        let lr = vec![self.config.lr_tone; params.len()];
        self.tone_adam.step(&mut params, &grads, &lr, 1.0);
        let tones = params.chunks(TONE_SCALARS).map(|c| Tone {
            shift: Vec3::from_slice(&c[..3]),
            scale: Vec3::from_slice(&c[3..]).max(Vec3::splat(0.05)),
        });
        let targets = self
            .scene
            .objects
            .iter_mut()
            .map(|o| &mut o.tone)
            .chain(std::iter::once(&mut self.scene.background.tone));
        for (dst, t) in targets.zip(tones) {
            *dst = t;
        }
    }

    /// One Adam step on the light and appearance code rows of every model that has them.
    fn step_codes(&mut self) {
        let mut lr = [0.0; NUM_GROUPS];
        lr[Group::Light as usize] = self.config.lr_codes;
        lr[Group::Appearance as usize] = self.config.lr_codes;
        for ((model, adam), grads) in self
            .scene
            .models
            .iter_mut()
            .zip(&mut self.code_adams)
            .zip(&mut self.model_grads)
        {
            if let Some(params) = model.field.params_mut() {
                adam.get_or_insert_with(|| Adam::new(AdamConfig::default(), params))
                    .step(params, grads, &lr);
            }
        }
    }

    /// An error once [`MAX_FAULTS_IN_A_ROW`] steps in a row had non-finite losses or gradients.
    fn check_health(&self, iteration: usize) -> Result<(), FitError> {
        let h = self.health;
        if h.in_a_row < MAX_FAULTS_IN_A_ROW {
            return Ok(());
        }
        Err(FitError(format!(
            "the fit diverged at iteration {iteration}: {} steps in a row with non-finite losses or \
             gradients (step size scaled down to {:e})",
            h.in_a_row, h.lr_scale
        )))
    }

    /// Objects whose centre has left the room's box, to report rather than silently keep.
    fn outside_room(&self) -> Vec<String> {
        self.scene
            .objects
            .iter()
            .filter(|o| {
                let c = o.translation;
                c.cmplt(self.room.min).any() || c.cmpgt(self.room.max).any()
            })
            .map(|o| {
                let c = o.translation;
                format!(
                    "object id {} left the room: its centre is at ({:.2}, {:.2}, {:.2}) m",
                    o.instance_id, c.x, c.y, c.z
                )
            })
            .collect()
    }

    /// Objects the camera cannot see: every surface point is behind another object's box, or the
    /// object lies outside the room. Their photometric loss has no pixels, so their poses are unsupported.
    fn unseen(&self) -> Vec<String> {
        let origin = self.camera_to_world.translation.as_vec3();
        let objects = &self.scene.objects;
        let visible = |k: usize, p: Vec3| {
            let (d, dist) = ((p - origin).normalize_or_zero(), (p - origin).length());
            let inside = p.cmpge(self.room.min).all() && p.cmple(self.room.max).all();
            inside
                && objects.iter().enumerate().all(|(j, other)| {
                    j == k || box_entry(other, origin, d, 0.0).is_none_or(|t| t >= dist)
                })
        };
        objects
            .iter()
            .enumerate()
            .filter(|(k, o)| {
                let rotation = o.rotation();
                !self.surfaces[*k]
                    .points
                    .iter()
                    .any(|q| visible(*k, o.translation + rotation * *q))
            })
            .map(|(_, o)| {
                format!(
                    "object id {} has no pixels in the panorama (hidden behind other objects or \
                     outside the room)",
                    o.instance_id
                )
            })
            .collect()
    }

    fn empty_log(&self, iteration: usize, stage: Stage) -> IterationLog {
        IterationLog {
            iteration,
            stage,
            photometric: 0.0,
            observation: 0.0,
            magnetic: 0.0,
            violation: 0.0,
            gravity: 0.0,
            alignment: 0.0,
            relations: self.relations.len(),
        }
    }

    /// The result of the fit so far.
    pub fn finish(
        self,
        log: Vec<IterationLog>,
        timings: FitTimings,
        before: Option<RgbImage>,
        after: Option<RgbImage>,
    ) -> FitResult<F> {
        let mut warnings = self.outside_room();
        warnings.extend(self.unseen());
        let faulty_steps = self.health.faults;
        let scene = self.scene;
        let light = |model: usize, row: u32| scene.models[model].field.light_code(row);
        FitResult {
            objects: scene
                .objects
                .iter()
                .map(|o| FittedObject {
                    id: o.instance_id,
                    pose: o.pose(),
                    tone: o.tone,
                    light_code: light(o.model, o.codes.light),
                })
                .collect(),
            background_tone: scene.background.tone,
            background_light_code: light(scene.background.model, scene.background.codes.light),
            relations: self.relations,
            log,
            timings,
            faulty_steps,
            warnings,
            before,
            after,
            scene,
        }
    }
}

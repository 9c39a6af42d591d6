//! Training rays from an RGB-D capture, in the frame of the model being learned.
//!
//! Every pixel of every training frame becomes at most one ray: origin (shared per frame), unit direction,
//! target colour (sRGB in `[0, 1]`, stored as `u16`), target distance along the ray (pinhole z-depth turned
//! into the distance from the camera centre; 0 = unknown), the surface normal estimated from depth
//! ([`crate::normals`]) and a class:
//! - background model: pixels with instance 0 are [`PixelClass::Surface`]; pixels of movable objects
//!   (instance ≠ 0) and alpha 0 are ignored;
//! - object model: pixels whose instance is one of the model's ids are `Surface`; alpha 0 and instance 0
//!   teach "empty" ([`PixelClass::Empty`]: opacity 0, SDF positive along the ray); pixels of *other* objects
//!   are ignored, because such an object may hide this one.
//!
//! Object captures go through `capture_to_object`, so rays live in the object's canonical frame; the
//! background stays in the world frame. Every `holdout`-th frame (index 0, h, 2h, …) is held out whole for
//! evaluation ([`FrameView`]). Storage is structure-of-arrays with compact types (≈ 32 bytes a ray).

use crate::normals::normals_from_depth;
use glam::{DVec2, Vec3};
use neuroom_core::camera::{CameraModel, Pinhole};
use neuroom_core::formats::{Capture, CaptureDevice, Frame, read_depth, read_mask, read_rgba};
use neuroom_core::{FormatError, Pose};
use rayon::prelude::*;

/// What a pixel teaches the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PixelClass {
    /// The model's surface: colour, depth and opacity 1.
    Surface,
    /// No surface of the model along the ray: opacity 0.
    Empty,
    /// Not used (another object, or a movable object in a background capture).
    Ignored,
}

/// Which model a capture trains, deciding the pixel classes and the frame.
#[derive(Clone, Debug, PartialEq)]
pub enum Role {
    /// The empty room, world frame.
    Background,
    /// A movable object: its instance ids in the capture and the capture-to-object transform.
    Object {
        /// Instance ids that belong to this model.
        ids: Vec<u16>,
        /// Maps the capture frame to the object's canonical frame.
        capture_to_object: Pose,
    },
}

impl Role {
    fn classify(&self, instance: u16, alpha: f32) -> PixelClass {
        match self {
            Role::Background if instance == 0 && alpha > 0.0 => PixelClass::Surface,
            Role::Background => PixelClass::Ignored,
            Role::Object { .. } if alpha <= 0.0 || instance == 0 => PixelClass::Empty,
            Role::Object { ids, .. } if ids.contains(&instance) => PixelClass::Surface,
            Role::Object { .. } => PixelClass::Ignored,
        }
    }

    /// Maps the capture's frame into the model's: the object's canonical frame, or the world.
    pub(crate) fn capture_to_model(&self) -> Pose {
        match self {
            Role::Background => Pose::IDENTITY,
            Role::Object {
                capture_to_object, ..
            } => *capture_to_object,
        }
    }
}

/// An axis-aligned box in the model frame.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Aabb {
    /// Lower corner.
    pub min: [f32; 3],
    /// Upper corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// Entry and exit distances of the ray `o + t d` (t ≥ 0) through the box, if it meets it.
    pub fn intersect(&self, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
        let (mut near, mut far) = (0.0f32, f32::INFINITY);
        for a in 0..3 {
            let inv = 1.0 / d[a];
            let (t0, t1) = ((self.min[a] - o[a]) * inv, (self.max[a] - o[a]) * inv);
            near = near.max(t0.min(t1));
            far = far.min(t0.max(t1));
        }
        (far > near).then_some((near, far))
    }

    /// Whether `p` lies inside (borders included).
    pub fn contains(&self, p: Vec3) -> bool {
        (0..3).all(|a| p[a] >= self.min[a] && p[a] <= self.max[a])
    }

    /// Half extents of the smallest box centred at the origin that holds this one.
    pub fn centred_half_extents(&self) -> [f32; 3] {
        std::array::from_fn(|a| self.max[a].abs().max(self.min[a].abs()))
    }
}

/// One frame's pixels in the model frame: a held-out view, or a training frame before it becomes rays.
#[derive(Clone, Debug)]
pub struct FrameView {
    /// Index of the frame in the capture.
    pub index: usize,
    /// Intrinsics.
    pub camera: Pinhole,
    /// Camera (OpenGL convention) to model frame.
    pub camera_to_model: Pose,
    /// Light code of the frame (see [`Dataset::light_names`]).
    pub light: u16,
    /// sRGB colour per pixel.
    pub rgb: Vec<[f32; 3]>,
    /// Distance along the ray to the surface, 0 = unknown.
    pub distance: Vec<f32>,
    /// Pixel classes.
    pub class: Vec<PixelClass>,
    /// Unit surface normal in the model frame (zero where unknown), facing the camera.
    pub normal: Vec<[f32; 3]>,
}

impl FrameView {
    /// Moves the view by `motion` (model frame): its camera and its normals, which are in the
    /// model frame; distances along the rays stay.
    pub fn move_by(&mut self, motion: &Pose) {
        self.camera_to_model = motion.compose(&self.camera_to_model);
        let turn = motion.rotation.as_mat3();
        for n in &mut self.normal {
            *n = (turn * Vec3::from(*n)).to_array();
        }
    }

    /// Camera centre in the model frame.
    pub fn origin(&self) -> Vec3 {
        self.camera_to_model.translation.as_vec3()
    }

    /// Unit direction (model frame) of the ray through the centre of pixel `i` (row-major).
    pub fn direction(&self, i: usize) -> Vec3 {
        let w = self.camera.width as usize;
        let px = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
        self.camera_to_model
            .transform_vector(self.camera.direction(px))
            .as_vec3()
    }

    /// The back-projected surface point of pixel `i` (model frame), when its depth is known.
    pub fn surface_point(&self, i: usize) -> Option<Vec3> {
        (self.distance[i] > 0.0).then(|| self.origin() + self.distance[i] * self.direction(i))
    }
}

/// Training rays, structure of arrays.
#[derive(Clone, Debug, Default)]
pub struct Rays {
    /// Training frame of each ray (index into [`Dataset::origins`]; also its appearance code).
    pub frame: Vec<u16>,
    /// Unit direction, model frame.
    pub dir: Vec<[f32; 3]>,
    /// sRGB colour × 65535.
    pub rgb: Vec<[u16; 3]>,
    /// Distance to the surface along the ray, 0 = unknown (and always 0 for empty rays).
    pub distance: Vec<f32>,
    /// Unit normal × 32767 (model frame, facing the camera), zero where unknown.
    pub normal: Vec<[i16; 3]>,
    /// Whether the ray is [`PixelClass::Empty`] (else `Surface`).
    pub empty: Vec<bool>,
}

impl Rays {
    /// Number of rays.
    pub fn len(&self) -> usize {
        self.frame.len()
    }

    /// Whether there are no rays.
    pub fn is_empty(&self) -> bool {
        self.frame.is_empty()
    }

    /// Colour of ray `i` in `[0, 1]`.
    pub fn color(&self, i: usize) -> [f32; 3] {
        self.rgb[i].map(|c| c as f32 / 65535.0)
    }

    /// Normal of ray `i` (zero when unknown).
    pub fn normal(&self, i: usize) -> Vec3 {
        Vec3::from(self.normal[i].map(|c| c as f32 / 32767.0))
    }

    fn push_view(&mut self, view: &FrameView, frame: u16, keep: &dyn Fn(Vec3, Vec3) -> bool) {
        for i in 0..view.rgb.len() {
            let empty = match view.class[i] {
                PixelClass::Ignored => continue,
                PixelClass::Empty => true,
                PixelClass::Surface => false,
            };
            let d = view.direction(i);
            if !keep(view.origin(), d) {
                continue;
            }
            self.frame.push(frame);
            self.dir.push(d.to_array());
            self.rgb
                .push(view.rgb[i].map(|c| (c.clamp(0.0, 1.0) * 65535.0).round() as u16));
            self.distance
                .push(if empty { 0.0 } else { view.distance[i] });
            self.normal
                .push(view.normal[i].map(|c| (c.clamp(-1.0, 1.0) * 32767.0).round() as i16));
            self.empty.push(empty);
        }
    }
}

/// A capture turned into training rays and held-out views.
#[derive(Clone, Debug)]
pub struct Dataset {
    /// Training rays.
    pub rays: Rays,
    /// Camera centre (model frame) of each training frame.
    pub origins: Vec<[f32; 3]>,
    /// Light code of each training frame.
    pub frame_light: Vec<u16>,
    /// Capture frame index of each training frame.
    pub frame_index: Vec<usize>,
    /// Held-out views, whole.
    pub held_out: Vec<FrameView>,
    /// Names of the capture's lightings, in light-code order (`capture` when frames name none).
    pub light_names: Vec<String>,
    /// Bounds of the back-projected surface points and camera centres of all frames (model frame).
    pub observed: Aabb,
    /// What the capture's camera did on its own (auto-exposure, tracked poses).
    pub device: CaptureDevice,
}

/// Options of [`Dataset::load`].
#[derive(Clone, Debug)]
pub struct LoadOptions {
    /// Every `holdout`-th frame is held out (0 = none).
    pub holdout: usize,
    /// Only rays meeting this box are kept (the model's box), when given.
    pub bounds: Option<Aabb>,
}

impl Dataset {
    /// Reads every frame of `capture` (in parallel) and builds the rays of `role`.
    pub fn load(
        capture: &Capture,
        role: &Role,
        options: &LoadOptions,
    ) -> Result<Self, FormatError> {
        let light_names = light_names(capture);
        let views = load_views(capture, role)?;
        let observed = observed_bounds(&views);
        let keep = |o: Vec3, d: Vec3| options.bounds.is_none_or(|b| b.intersect(o, d).is_some());
        let mut data = Dataset {
            rays: Rays::default(),
            origins: Vec::new(),
            frame_light: Vec::new(),
            frame_index: Vec::new(),
            held_out: Vec::new(),
            light_names,
            observed,
            device: capture.device,
        };
        for view in views {
            if options.holdout > 0 && view.index % options.holdout == 0 {
                data.held_out.push(view);
                continue;
            }
            let frame = data.origins.len() as u16;
            data.rays.push_view(&view, frame, &keep);
            data.origins.push(view.origin().to_array());
            data.frame_light.push(view.light);
            data.frame_index.push(view.index);
        }
        Ok(data)
    }

    /// Origin of training ray `i`.
    pub fn origin(&self, i: usize) -> Vec3 {
        Vec3::from(self.origins[self.rays.frame[i] as usize])
    }
}

/// Reads every frame of `capture` (in parallel) as a whole view of `role`'s model.
pub fn load_views(capture: &Capture, role: &Role) -> Result<Vec<FrameView>, FormatError> {
    let light_names = light_names(capture);
    capture
        .frames
        .par_iter()
        .enumerate()
        .map(|(i, f)| load_view(capture, f, i, role, &light_names))
        .collect()
}

/// The distinct lighting names of a capture's frames in order of first appearance (`capture` for frames
/// that name none).
fn light_names(capture: &Capture) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for f in &capture.frames {
        let name = f.light.clone().unwrap_or_else(|| "capture".into());
        if !names.contains(&name) {
            names.push(name);
        }
    }
    names
}

/// Reads one frame's images and converts them to the model frame.
fn load_view(
    capture: &Capture,
    frame: &Frame,
    index: usize,
    role: &Role,
    light_names: &[String],
) -> Result<FrameView, FormatError> {
    let image_path = capture.resolve(&frame.image);
    let rgba = read_rgba(&image_path)?.image;
    let cam = frame.camera;
    let n = cam.width as usize * cam.height as usize;
    if rgba.data.len() != n {
        return Err(FormatError::file(
            &image_path,
            format!(
                "image is {}×{}, the capture says {}×{}",
                rgba.width, rgba.height, cam.width, cam.height
            ),
        ));
    }
    let z = match &frame.depth {
        Some(p) => sized(
            read_depth(capture.resolve(p), capture.depth_unit_scale_factor)?.data,
            n,
            &capture.resolve(p),
        )?,
        None => vec![0.0; n],
    };
    let instance = match &frame.instance {
        Some(p) => sized(read_mask(capture.resolve(p))?.data, n, &capture.resolve(p))?,
        None => vec![0; n],
    };
    let default_id = match role {
        Role::Object { ids, .. } if frame.instance.is_none() => ids[0],
        _ => 0,
    };
    let class: Vec<PixelClass> = (0..n)
        .map(|i| {
            let inst = if frame.instance.is_some() {
                instance[i]
            } else {
                default_id
            };
            role.classify(inst, rgba.data[i][3])
        })
        .collect();
    let camera_to_model = role.capture_to_model().compose(&frame.camera_to_world);
    let surface: Vec<bool> = class.iter().map(|c| *c == PixelClass::Surface).collect();
    let normal_cam = normals_from_depth(&cam, &z, &surface, capture.device.depth_noise);
    let distance = (0..n)
        .map(|i| {
            let px = DVec2::new(
                (i % cam.width as usize) as f64 + 0.5,
                (i / cam.width as usize) as f64 + 0.5,
            );
            if surface[i] && z[i] > 0.0 {
                cam.unproject(px, z[i] as f64).length() as f32
            } else {
                0.0
            }
        })
        .collect();
    let rot = camera_to_model.rotation.as_mat3();
    let light_name = frame.light.as_deref().unwrap_or("capture");
    Ok(FrameView {
        index,
        camera: cam,
        camera_to_model,
        light: light_names
            .iter()
            .position(|l| l == light_name)
            .unwrap_or(0) as u16,
        rgb: rgba.data.iter().map(|p| [p[0], p[1], p[2]]).collect(),
        distance,
        class,
        normal: normal_cam
            .iter()
            .map(|nc| (rot * Vec3::from(*nc)).to_array())
            .collect(),
    })
}

fn sized<T>(data: Vec<T>, n: usize, path: &std::path::Path) -> Result<Vec<T>, FormatError> {
    if data.len() != n {
        return Err(FormatError::file(
            path,
            format!("has {} pixels, the colour image {n}", data.len()),
        ));
    }
    Ok(data)
}

/// Bounds of every view's surface points and camera centre.
fn observed_bounds(views: &[FrameView]) -> Aabb {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for v in views {
        lo = lo.min(v.origin());
        hi = hi.max(v.origin());
        for p in (0..v.rgb.len()).filter_map(|i| v.surface_point(i)) {
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    Aabb {
        min: lo.to_array(),
        max: hi.to_array(),
    }
}

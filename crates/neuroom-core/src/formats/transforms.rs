//! `transforms.json`: a pinhole RGB-D capture, nerfstudio-compatible (docs/formats.md, "Pinhole captures").
//!
//! Intrinsics may be given at the top level, in each frame, or both; a frame's own value wins. Only the
//! `OPENCV` (k1, k2, p1, p2) and `PINHOLE` camera models exist here; `camera_model` may also be absent.

use super::json::{
    JsonObject, as_bool, as_integer_in, as_nonempty_str, as_number, as_pose, as_positive, as_str,
    is_positive, number_value, parse_json, pose_value, write_json,
};
use super::room::path_string;
use crate::camera::Pinhole;
use crate::error::{FormatError, FormatResult};
use crate::pose::Pose;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

/// Name of the capture file inside a capture folder.
pub const TRANSFORMS_FILE: &str = "transforms.json";

/// Depth unit when `depth_unit_scale_factor` is absent: millimetres.
pub const DEFAULT_DEPTH_UNIT: f64 = 0.001;

/// Intrinsic keys, in the order of [`Pinhole`]'s fields as held by [`Intrinsics`].
const INTRINSIC_KEYS: [&str; 10] = ["w", "h", "fl_x", "fl_y", "cx", "cy", "k1", "k2", "p1", "p2"];

/// Distortion coefficients of other nerfstudio models, rejected when non-zero.
const UNSUPPORTED_DISTORTION: [&str; 2] = ["k3", "k4"];

/// Keys of a frame this module reads itself (the rest is kept in [`Frame::extra`]).
const FRAME_KEYS: [&str; 6] = [
    "file_path",
    "depth_file_path",
    "instance_file_path",
    "transform_matrix",
    "light",
    "camera_model",
];

/// One pinhole capture: its folder and its frames.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    /// The capture folder; frame paths are relative to it.
    pub dir: PathBuf,
    /// The frames, in file order (never empty).
    pub frames: Vec<Frame>,
    /// Metres per depth PNG unit.
    pub depth_unit_scale_factor: f64,
    /// What the camera did on its own while capturing (auto-exposure, tracked poses).
    pub device: CaptureDevice,
    /// Top-level fields this reader does not know (e.g. `lighting`), written back unchanged.
    pub extra: Map<String, Value>,
}

/// What a capture's camera did on its own, which training learns to undo per frame, and how far its
/// depth can be trusted. A rendered or tripod capture has none of it; a phone app's recording has all.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CaptureDevice {
    /// The camera exposed and white-balanced every frame itself (`auto_exposure`): colours differ
    /// between frames by a gain per channel.
    pub auto_exposure: bool,
    /// The poses were tracked or reconstructed (`tracked_poses`: visual-inertial odometry, COLMAP),
    /// so they are off by the tracker's drift.
    pub tracked_poses: bool,
    /// How noisy the depth maps are (`depth_noise`); `None`: exact, as a renderer writes them.
    pub depth_noise: Option<DepthNoise>,
}

/// The standard deviation of a depth sample, growing with its distance: `at_0m + per_m · d` metres
/// (`"depth_noise": {"at_0m": …, "per_m": …}` in `transforms.json`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthNoise {
    /// Standard deviation at distance 0 (metres).
    pub at_0m: f64,
    /// Growth of the standard deviation per metre of distance.
    pub per_m: f64,
}

impl DepthNoise {
    /// A phone's LiDAR (iPhone / iPad Pro, ARKit scene depth): about 1 cm at 1 m, 1.5 cm at 2 m.
    pub const PHONE_LIDAR: DepthNoise = DepthNoise {
        at_0m: 0.005,
        per_m: 0.005,
    };

    /// The standard deviation of a sample at distance `d` (metres).
    pub fn sigma_at(&self, d: f32) -> f32 {
        (self.at_0m + self.per_m * d as f64) as f32
    }
}

/// One view of a capture.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Colour image, relative to the capture folder.
    pub image: PathBuf,
    /// 16-bit depth PNG, relative to the capture folder.
    pub depth: Option<PathBuf>,
    /// Instance mask PNG, relative to the capture folder.
    pub instance: Option<PathBuf>,
    /// Intrinsics of this frame (top-level values overridden by the frame's own).
    pub camera: Pinhole,
    /// Camera-to-capture-frame pose as in the file: OpenGL camera convention (looks along −z, +y up).
    pub camera_to_world: Pose,
    /// Name of the lighting this frame was taken under, for captures with several lightings.
    pub light: Option<String>,
    /// Frame fields this reader does not know, written back unchanged.
    pub extra: Map<String, Value>,
}

impl Capture {
    /// A path named in the capture, resolved against the capture folder.
    pub fn resolve(&self, relative: &Path) -> PathBuf {
        self.dir.join(relative)
    }
}

/// Reads `dir/transforms.json` (or the file itself when `path` names a file).
pub fn read_capture(path: impl AsRef<Path>) -> FormatResult<Capture> {
    let path = path.as_ref();
    let file = if path.is_dir() {
        path.join(TRANSFORMS_FILE)
    } else {
        path.to_path_buf()
    };
    let bytes =
        std::fs::read(&file).map_err(|e| FormatError::file(&file, format!("cannot read: {e}")))?;
    parse_capture(&file, &bytes)
}

/// Parses the bytes of the capture file `file` (its folder becomes [`Capture::dir`]), validating as
/// [`read_capture`] does.
pub fn parse_capture(file: &Path, bytes: &[u8]) -> FormatResult<Capture> {
    let value = parse_json(file, bytes)?;
    let top = JsonObject::root(file, &value)?;
    check_camera_model(&top)?;
    let defaults = read_intrinsics(&top)?;
    let frames = top.objects("frames")?;
    if frames.is_empty() {
        return Err(top.error("frames", "a capture needs at least one frame"));
    }
    let mut known: Vec<&str> = vec![
        "frames",
        "depth_unit_scale_factor",
        "camera_model",
        "auto_exposure",
        "tracked_poses",
        "depth_noise",
    ];
    known.extend(INTRINSIC_KEYS.iter().chain(&UNSUPPORTED_DISTORTION));
    Ok(Capture {
        dir: file.parent().map(Path::to_path_buf).unwrap_or_default(),
        frames: frames
            .iter()
            .map(|f| read_frame(f, &defaults))
            .collect::<FormatResult<_>>()?,
        depth_unit_scale_factor: top
            .optional("depth_unit_scale_factor", as_positive)?
            .unwrap_or(DEFAULT_DEPTH_UNIT),
        device: CaptureDevice {
            auto_exposure: top.optional("auto_exposure", as_bool)?.unwrap_or(false),
            tracked_poses: top.optional("tracked_poses", as_bool)?.unwrap_or(false),
            depth_noise: read_depth_noise(&top)?,
        },
        extra: top.unknown_fields(&known),
    })
}

/// The optional `depth_noise` object: `{"at_0m": σ₀, "per_m": σ₁}`, both finite and ≥ 0.
fn read_depth_noise(top: &JsonObject) -> FormatResult<Option<DepthNoise>> {
    let Some(noise) = top.optional("depth_noise", Ok)? else {
        return Ok(None);
    };
    let part = |key: &str| {
        noise
            .get(key)
            .and_then(|v| as_number(v).ok())
            .filter(|&x| x >= 0.0)
            .ok_or_else(|| {
                top.error(
                    "depth_noise",
                    format!("needs `{key}`, a number of metres ≥ 0 (e.g. {{\"at_0m\": 0.005, \"per_m\": 0.005}})"),
                )
            })
    };
    Ok(Some(DepthNoise {
        at_0m: part("at_0m")?,
        per_m: part("per_m")?,
    }))
}

/// Reads the intrinsics of a photo: a JSON object with `transforms.json`'s top-level camera keys
/// (`w`, `h`, `fl_x`, `fl_y`, `cx`, `cy`, optional OPENCV distortion, optional `camera_model`), e.g.
/// `{"w": 640, "h": 480, "fl_x": 500, "fl_y": 500, "cx": 320, "cy": 240}`. Other keys are ignored, so
/// a `transforms.json` whose intrinsics are given at its top level serves as well.
pub fn read_intrinsics_file(path: impl AsRef<Path>) -> FormatResult<Pinhole> {
    let file = path.as_ref();
    let bytes =
        std::fs::read(file).map_err(|e| FormatError::file(file, format!("cannot read: {e}")))?;
    parse_intrinsics(file, &bytes)
}

/// Parses the bytes of the intrinsics file `file`, validating as [`read_intrinsics_file`] does.
pub fn parse_intrinsics(file: &Path, bytes: &[u8]) -> FormatResult<Pinhole> {
    let value = parse_json(file, bytes)?;
    let top = JsonObject::root(file, &value)?;
    read_camera(&top, &[None; 10], "missing: a photo's intrinsics need it")
}

/// Intrinsic values of one JSON object, each present or not, in [`INTRINSIC_KEYS`] order.
type Intrinsics = [Option<f64>; 10];

/// Reads whichever intrinsics `o` holds, checking each one's type and range.
fn read_intrinsics(o: &JsonObject) -> FormatResult<Intrinsics> {
    let mut out = [None; 10];
    for (slot, key) in out.iter_mut().zip(INTRINSIC_KEYS) {
        *slot = match key {
            "w" | "h" => o
                .optional(key, as_integer_in(1, super::MAX_IMAGE_SIDE as u64))?
                .map(|x| x as f64),
            "fl_x" | "fl_y" => o.optional(key, as_positive)?,
            _ => o.optional(key, as_number)?,
        };
    }
    for key in UNSUPPORTED_DISTORTION {
        if o.optional(key, as_number)?.is_some_and(|x| x != 0.0) {
            return Err(o.error(
                key,
                "only the OPENCV distortion k1, k2, p1, p2 is supported; this must be 0",
            ));
        }
    }
    Ok(out)
}

/// Checks `camera_model` (absent, `OPENCV` or `PINHOLE`); `PINHOLE` must come without distortion.
fn check_camera_model(o: &JsonObject) -> FormatResult<()> {
    match o.optional("camera_model", as_str)? {
        None | Some("OPENCV") => Ok(()),
        Some("PINHOLE") => {
            let distorted = ["k1", "k2", "p1", "p2"]
                .into_iter()
                .find(|k| o.get(k).and_then(Value::as_f64).is_some_and(|x| x != 0.0));
            match distorted {
                Some(k) => Err(o.error(
                    k,
                    "camera_model PINHOLE has no distortion; use OPENCV or set this to 0",
                )),
                None => Ok(()),
            }
        }
        Some(other) => Err(o.error(
            "camera_model",
            format!("unsupported camera model \"{other}\" (expected OPENCV or PINHOLE)"),
        )),
    }
}

/// Reads `o`'s camera model and intrinsics, filling those it does not give from `defaults`
/// (distortion defaults to none); `missing` says where a missing value belongs.
fn read_camera(o: &JsonObject, defaults: &Intrinsics, missing: &str) -> FormatResult<Pinhole> {
    check_camera_model(o)?;
    let own = read_intrinsics(o)?;
    let mut v = [0.0; 10];
    for (i, key) in INTRINSIC_KEYS.iter().enumerate() {
        v[i] = match (own[i], defaults[i], i >= 6) {
            (Some(x), _, _) | (None, Some(x), _) => x,
            (None, None, true) => 0.0,
            (None, None, false) => return Err(o.error(key, missing)),
        };
    }
    Ok(Pinhole {
        width: v[0] as u32,
        height: v[1] as u32,
        fx: v[2],
        fy: v[3],
        cx: v[4],
        cy: v[5],
        k1: v[6],
        k2: v[7],
        p1: v[8],
        p2: v[9],
    })
}

/// Reads one frame, filling intrinsics it does not give from the top-level `defaults`.
fn read_frame(f: &JsonObject, defaults: &Intrinsics) -> FormatResult<Frame> {
    let camera = read_camera(
        f,
        defaults,
        "missing: give it at the top level or in the frame",
    )?;
    let path = |key| {
        f.optional(key, as_nonempty_str)
            .map(|p| p.map(PathBuf::from))
    };
    Ok(Frame {
        image: f.required("file_path", as_nonempty_str)?.into(),
        depth: path("depth_file_path")?,
        instance: path("instance_file_path")?,
        camera,
        camera_to_world: f.required("transform_matrix", as_pose)?,
        light: f.optional("light", as_str)?.map(str::to_string),
        extra: f.unknown_fields(&[&FRAME_KEYS[..], &INTRINSIC_KEYS[..]].concat()),
    })
}

/// The intrinsics of `c` in [`INTRINSIC_KEYS`] order.
fn intrinsic_values(c: &Pinhole) -> [f64; 10] {
    [
        c.width as f64,
        c.height as f64,
        c.fx,
        c.fy,
        c.cx,
        c.cy,
        c.k1,
        c.k2,
        c.p1,
        c.p2,
    ]
}

/// Writes `dir/transforms.json` for `capture` (its own `dir` is not consulted), atomically. The first
/// frame's intrinsics go to the top level; a frame whose intrinsics differ carries its own.
pub fn write_capture(dir: impl AsRef<Path>, capture: &Capture) -> FormatResult<()> {
    let file = dir.as_ref().join(TRANSFORMS_FILE);
    let first = capture
        .frames
        .first()
        .ok_or_else(|| FormatError::field(&file, "frames", "a capture needs at least one frame"))?;
    let mut top = Map::new();
    top.insert("camera_model".into(), "OPENCV".into());
    insert_intrinsics(&file, "", &mut top, &first.camera)?;
    if !is_positive(capture.depth_unit_scale_factor) {
        return Err(FormatError::field(
            &file,
            "depth_unit_scale_factor",
            "must be a positive number",
        ));
    }
    top.insert(
        "depth_unit_scale_factor".into(),
        number_value(
            &file,
            "depth_unit_scale_factor",
            capture.depth_unit_scale_factor,
        )?,
    );
    let frames = capture
        .frames
        .iter()
        .enumerate()
        .map(|(i, f)| frame_value(&file, i, f, &first.camera))
        .collect::<FormatResult<Vec<_>>>()?;
    top.insert("frames".into(), frames.into());
    let device = capture.device;
    for (key, on) in [
        ("auto_exposure", device.auto_exposure),
        ("tracked_poses", device.tracked_poses),
    ] {
        if on {
            top.insert(key.into(), true.into());
        }
    }
    if let Some(noise) = device.depth_noise {
        top.insert(
            "depth_noise".into(),
            serde_json::json!({"at_0m": noise.at_0m, "per_m": noise.per_m}),
        );
    }
    for (k, v) in &capture.extra {
        top.entry(k.clone()).or_insert_with(|| v.clone());
    }
    write_json(&file, &Value::Object(top))
}

/// Writes the ten intrinsics of `c` into `map`, checking them as the reader would.
fn insert_intrinsics(
    file: &Path,
    at: &str,
    map: &mut Map<String, Value>,
    c: &Pinhole,
) -> FormatResult<()> {
    for (key, x) in INTRINSIC_KEYS.iter().zip(intrinsic_values(c)) {
        let field = format!("{at}{key}");
        let bad_size =
            matches!(*key, "w" | "h") && !(1.0..=super::MAX_IMAGE_SIDE as f64).contains(&x);
        let bad_focal = matches!(*key, "fl_x" | "fl_y") && !is_positive(x);
        if bad_size || bad_focal {
            return Err(FormatError::field(
                file,
                field,
                format!("invalid value {x}"),
            ));
        }
        let value = if matches!(*key, "w" | "h") {
            Value::from(x as u32)
        } else {
            number_value(file, &field, x)?
        };
        map.insert(key.to_string(), value);
    }
    Ok(())
}

/// One frame, for writing; intrinsics are written only when they differ from the top-level `shared` ones.
fn frame_value(file: &Path, i: usize, f: &Frame, shared: &Pinhole) -> FormatResult<Value> {
    let at = format!("frames[{i}].");
    let mut m = Map::new();
    m.insert(
        "file_path".into(),
        path_string(file, &format!("{at}file_path"), &f.image)?.into(),
    );
    for (key, p) in [
        ("depth_file_path", &f.depth),
        ("instance_file_path", &f.instance),
    ] {
        if let Some(p) = p {
            m.insert(
                key.into(),
                path_string(file, &format!("{at}{key}"), p)?.into(),
            );
        }
    }
    if f.camera != *shared {
        insert_intrinsics(file, &at, &mut m, &f.camera)?;
    }
    m.insert(
        "transform_matrix".into(),
        pose_value(file, &format!("{at}transform_matrix"), &f.camera_to_world)?,
    );
    if let Some(light) = &f.light {
        m.insert("light".into(), light.clone().into());
    }
    for (k, v) in &f.extra {
        m.entry(k.clone()).or_insert_with(|| v.clone());
    }
    Ok(Value::Object(m))
}

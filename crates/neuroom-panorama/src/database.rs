//! The localization database: small colour + depth panoramas of the empty room, rendered from the
//! background model at upright cameras over the floor at a few heights, all looking along +x (yaw 0).
//! Built once per trained room and stored beside the model manifest as `locate.safetensors`:
//! `positions` (`N × 3` f32, metres), `rgb` (`N × H × W × 3` u8, sRGB) and `depth` (`N × H × W` u16,
//! millimetres of ray distance, 0 = none), with the format tag and size in the metadata.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat3, Vec3};
use neuroom_core::FormatError;
use neuroom_core::camera::Equirect;
use neuroom_core::formats::{atomic_write, canonical_safetensors};
use neuroom_core::image::RgbImage;
use neuroom_core::pose::Pose;
use neuroom_field::Field;
use neuroom_render::{RenderConfig, Sampling, Scene, render_image};
use safetensors::tensor::{Dtype, TensorView};
use serde::{Deserialize, Serialize};

/// File name of the database inside a model folder.
pub const DATABASE_FILE: &str = "locate.safetensors";

/// Format tag stored in the file's metadata.
pub const DATABASE_FORMAT: &str = "neuroom.locate-db/1";

/// Where database panoramas are taken and how they are rendered.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DatabaseConfig {
    /// Panorama width in pixels (height is half).
    pub width: usize,
    /// Grid spacing over the floor (metres).
    pub spacing: f32,
    /// Camera heights above the floor (metres).
    pub heights: Vec<f32>,
    /// Least distance from a camera to any surface of the room (metres).
    pub clearance: f32,
    /// Least fraction of the pixels below the horizon with a depth: cameras outside the room see too
    /// little (the half above is not asked: captures rarely see the ceiling).
    pub min_coverage: f32,
    /// Sampling of the renders (a light safe region: colour detail matters little at this size).
    pub render: RenderConfig,
}

/// Rendering for the small panoramas localization compares: half the safe-region samples of the default
/// (4 coarse + 8 fine), as the database and the keyframes need colour and depth, not fine detail.
pub fn low_resolution_render() -> RenderConfig {
    RenderConfig {
        sampling: Sampling::SafeRegion {
            coarse: 4,
            fine: 8,
            before: 0.05,
            after: 0.1,
        },
        ..RenderConfig::default()
    }
}

impl Default for DatabaseConfig {
    fn default() -> Self {
        Self {
            width: 128,
            spacing: 0.4,
            heights: vec![1.2, 1.6],
            clearance: 0.3,
            min_coverage: 0.9,
            render: low_resolution_render(),
        }
    }
}

/// One database panorama, at an upright camera with yaw 0.
#[derive(Clone, Debug, PartialEq)]
pub struct DatabaseEntry {
    /// Camera position (world, metres).
    pub position: Vec3,
    /// Colour, sRGB in [0, 1].
    pub rgb: RgbImage,
    /// Ray distance per pixel (metres, 0 = none), row-major.
    pub depth: Vec<f32>,
}

impl DatabaseEntry {
    /// The camera of this panorama.
    pub fn camera_to_world(&self) -> Pose {
        Pose::new(DMat3::IDENTITY, self.position.as_dvec3())
    }
}

/// All database panoramas of a room (same size).
#[derive(Clone, Debug, PartialEq)]
pub struct Database {
    /// Panorama width.
    pub width: usize,
    /// Panorama height.
    pub height: usize,
    /// The panoramas.
    pub entries: Vec<DatabaseEntry>,
}

/// Renders the database of the empty room `scene` (a scene without objects) inside its background
/// bounds. `progress` gets (done, total) after each panorama.
pub fn build_database<F: Field>(
    empty: &Scene<F>,
    config: &DatabaseConfig,
    progress: &mut dyn FnMut(usize, usize),
) -> Database {
    let positions = candidate_positions(empty, config);
    let (w, h) = (config.width, config.width / 2);
    let camera = Equirect {
        width: w as u32,
        height: h as u32,
    };
    let mut entries = Vec::new();
    for (k, position) in positions.iter().enumerate() {
        let pose = Pose::new(DMat3::IDENTITY, position.as_dvec3());
        let (rgb, depth, _) = render_image(empty, &camera, &pose, &config.render);
        let lower = &depth.data[w * h / 2..];
        let covered = lower.iter().filter(|d| **d > 0.0).count();
        if covered as f32 >= config.min_coverage * lower.len() as f32 {
            entries.push(DatabaseEntry {
                position: *position,
                rgb,
                depth: depth.data,
            });
        }
        progress(k + 1, positions.len());
    }
    Database {
        width: w,
        height: h,
        entries,
    }
}

/// Grid points over the background's box, lifted to each height above the floor found below them, kept
/// where the room's SDF leaves the clearance.
fn candidate_positions<F: Field>(scene: &Scene<F>, config: &DatabaseConfig) -> Vec<Vec3> {
    let field = &scene.models[scene.background.model].field;
    let (lo, hi) = (scene.background.bounds_min, scene.background.bounds_max);
    let steps = |a: f32, b: f32| {
        let n = ((b - a - 2.0 * config.clearance) / config.spacing)
            .floor()
            .max(0.0) as usize
            + 1;
        let start = 0.5 * (a + b) - 0.5 * (n - 1) as f32 * config.spacing;
        (0..n).map(move |i| start + i as f32 * config.spacing)
    };
    let mut out = Vec::new();
    for x in steps(lo.x, hi.x) {
        for y in steps(lo.y, hi.y) {
            let Some(floor) = floor_below(field, Vec3::new(x, y, 0.5 * (lo.z + hi.z)), lo.z) else {
                continue;
            };
            for &height in &config.heights {
                let p = Vec3::new(x, y, floor + height);
                let mut sdf = [0.0f32];
                field.sdf(&[p], &mut sdf);
                if sdf[0] > config.clearance && p.z < hi.z {
                    out.push(p);
                }
            }
        }
    }
    out
}

/// Height of the first surface straight below `start` (sphere tracing down to `bottom`).
pub fn floor_below<F: Field>(field: &F, start: Vec3, bottom: f32) -> Option<f32> {
    let mut p = start;
    let mut sdf = [0.0f32];
    field.sdf(&[p], &mut sdf);
    if sdf[0] <= 0.0 {
        return None;
    }
    for _ in 0..200 {
        field.sdf(&[p], &mut sdf);
        if !sdf[0].is_finite() || p.z < bottom {
            return None;
        }
        if sdf[0] < 1e-3 {
            return Some(p.z);
        }
        p.z -= (0.9 * sdf[0]).max(1e-3);
    }
    None
}

impl Database {
    /// Writes the database to `path` (safetensors, through a temporary file).
    pub fn write(&self, path: &Path) -> Result<(), FormatError> {
        let n = self.entries.len();
        let positions: Vec<u8> = self
            .entries
            .iter()
            .flat_map(|e| e.position.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let rgb: Vec<u8> = self
            .entries
            .iter()
            .flat_map(|e| e.rgb.data.iter().flatten())
            .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
            .collect();
        let depth: Vec<u8> = self
            .entries
            .iter()
            .flat_map(|e| e.depth.iter())
            .map(|d| (d * 1000.0).round().clamp(0.0, 65535.0) as u16)
            .flat_map(u16::to_le_bytes)
            .collect();
        let (w, h) = (self.width, self.height);
        let err = |e: safetensors::SafeTensorError| FormatError::file(path, e.to_string());
        let views = vec![
            (
                "positions",
                TensorView::new(Dtype::F32, vec![n, 3], &positions).map_err(err)?,
            ),
            (
                "rgb",
                TensorView::new(Dtype::U8, vec![n, h, w, 3], &rgb).map_err(err)?,
            ),
            (
                "depth",
                TensorView::new(Dtype::U16, vec![n, h, w], &depth).map_err(err)?,
            ),
        ];
        let meta = HashMap::from([
            ("format".to_string(), DATABASE_FORMAT.to_string()),
            ("width".to_string(), w.to_string()),
        ]);
        let bytes = safetensors::serialize(views, Some(meta)).map_err(err)?;
        let bytes = canonical_safetensors(&bytes).map_err(|e| FormatError::file(path, e))?;
        atomic_write(path, &bytes)
    }

    /// Reads a database written by [`Database::write`]; errors name the file and the problem.
    pub fn read(path: &Path) -> Result<Database, FormatError> {
        let bytes = std::fs::read(path)
            .map_err(|e| FormatError::file(path, format!("cannot read: {e}")))?;
        let err = |m: String| FormatError::file(path, m);
        let (_, meta) = safetensors::SafeTensors::read_metadata(&bytes)
            .map_err(|e| err(format!("not a safetensors file: {e}")))?;
        let format = meta.metadata().as_ref().and_then(|m| m.get("format"));
        if format.map(String::as_str) != Some(DATABASE_FORMAT) {
            return Err(err(format!(
                "format {format:?}, expected {DATABASE_FORMAT:?}"
            )));
        }
        let tensors = safetensors::SafeTensors::deserialize(&bytes)
            .map_err(|e| err(format!("not a safetensors file: {e}")))?;
        let get = |name: &str, dtype: Dtype| {
            let t = tensors
                .tensor(name)
                .map_err(|e| err(format!("tensor {name}: {e}")))?;
            if t.dtype() != dtype {
                return Err(err(format!(
                    "tensor {name}: dtype {:?}, expected {dtype:?}",
                    t.dtype()
                )));
            }
            Ok(t)
        };
        let (positions, rgb, depth) = (
            get("positions", Dtype::F32)?,
            get("rgb", Dtype::U8)?,
            get("depth", Dtype::U16)?,
        );
        let n = positions.shape().first().copied().unwrap_or(0);
        let shape_ok = positions.shape() == [n, 3]
            && rgb.shape().len() == 4
            && rgb.shape()[0] == n
            && rgb.shape()[3] == 3
            && depth.shape() == &rgb.shape()[..3];
        let (h, w) = if shape_ok {
            (rgb.shape()[1], rgb.shape()[2])
        } else {
            (0, 0)
        };
        if !shape_ok || w != 2 * h || h == 0 {
            return Err(err(format!(
                "inconsistent shapes: positions {:?}, rgb {:?}, depth {:?}",
                positions.shape(),
                rgb.shape(),
                depth.shape()
            )));
        }
        Ok(Database {
            width: w,
            height: h,
            entries: (0..n)
                .map(|k| decode_entry(k, w, h, positions.data(), rgb.data(), depth.data()))
                .collect(),
        })
    }
}

fn decode_entry(
    k: usize,
    w: usize,
    h: usize,
    pos: &[u8],
    rgb: &[u8],
    depth: &[u8],
) -> DatabaseEntry {
    let f = |i: usize| f32::from_le_bytes(pos[4 * i..4 * i + 4].try_into().expect("4 bytes"));
    let px = w * h;
    let rgb_data = rgb[3 * px * k..3 * px * (k + 1)]
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]].map(|x| x as f32 / 255.0))
        .collect();
    let depth = depth[2 * px * k..2 * px * (k + 1)]
        .chunks_exact(2)
        .map(|b| u16::from_le_bytes([b[0], b[1]]) as f32 / 1000.0)
        .collect();
    DatabaseEntry {
        position: Vec3::new(f(3 * k), f(3 * k + 1), f(3 * k + 2)),
        rgb: RgbImage {
            width: w as u32,
            height: h as u32,
            data: rgb_data,
        },
        depth,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A database of two 8 × 4 panoramas with distinct colours and depths.
    fn small() -> Database {
        let (w, h) = (8, 4);
        let entry = |k: usize| DatabaseEntry {
            position: Vec3::new(k as f32, 0.5, 1.2),
            rgb: RgbImage {
                width: w as u32,
                height: h as u32,
                data: (0..w * h)
                    .map(|i| [0.1 * k as f32, i as f32 / 32.0, 0.5])
                    .collect(),
            },
            depth: (0..w * h).map(|i| 1.0 + i as f32 * 0.01).collect(),
        };
        Database {
            width: w,
            height: h,
            entries: vec![entry(0), entry(1)],
        }
    }

    #[test]
    fn a_database_round_trips_and_is_written_with_the_same_bytes_every_time() {
        let dir = tempfile::tempdir().unwrap();
        let db = small();
        let paths = [
            dir.path().join("a.safetensors"),
            dir.path().join("b.safetensors"),
        ];
        for p in &paths {
            db.write(p).unwrap();
        }
        let bytes = paths.each_ref().map(|p| std::fs::read(p).unwrap());
        assert_eq!(bytes[0], bytes[1]);
        assert_eq!(canonical_safetensors(&bytes[0]).unwrap(), bytes[0]);
        let back = Database::read(&paths[0]).unwrap();
        assert_eq!((back.width, back.height), (8, 4));
        assert_eq!(back.entries.len(), 2);
        assert_eq!(back.entries[1].position, db.entries[1].position);
        assert!((back.entries[1].depth[5] - db.entries[1].depth[5]).abs() < 1e-3);
    }
}

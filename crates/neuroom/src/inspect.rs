//! `neuroom info`: decode and check every file of a room, so a bad file is found in seconds, before any
//! training starts.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use neuroom_core::camera::Equirect;
use neuroom_core::formats::{self, Capture, Room};
use neuroom_core::mesh::read_ply;
use neuroom_core::{FormatError, FormatResult};
use rayon::prelude::*;
use serde::Serialize;

/// What was found in a room folder.
#[derive(Clone, Debug, Serialize)]
pub struct RoomReport {
    /// Room name from room.json.
    pub name: String,
    /// The room folder.
    pub root: PathBuf,
    /// The background capture.
    pub background: CaptureReport,
    /// One entry per movable object.
    pub objects: Vec<ObjectReport>,
    /// One entry per distinct object capture (instances of one model share one).
    pub object_captures: Vec<CaptureReport>,
    /// Test panoramas found in `panoramas/`.
    pub panoramas: Vec<PanoramaReport>,
    /// Things that are allowed but worth knowing (conversions made, meshes that disagree with sizes…).
    pub notes: Vec<String>,
}

/// One movable object of room.json.
#[derive(Clone, Debug, Serialize)]
pub struct ObjectReport {
    /// Instance id.
    pub id: u16,
    /// Unique name.
    pub name: String,
    /// Category.
    pub category: String,
    /// Capture folder, relative to the room.
    pub capture: PathBuf,
    /// Box extents in metres.
    pub size: [f64; 3],
    /// Triangles of the ground-truth mesh, when `meshes/<name>.ply` exists.
    pub mesh_triangles: Option<usize>,
}

/// One decoded capture.
#[derive(Clone, Debug, Serialize)]
pub struct CaptureReport {
    /// Capture folder.
    pub dir: PathBuf,
    /// Number of frames.
    pub frames: usize,
    /// Frames with a depth image.
    pub with_depth: usize,
    /// Frames with an instance mask.
    pub with_mask: usize,
    /// Distinct image sizes (width, height).
    pub sizes: Vec<(u32, u32)>,
    /// Instance ids seen in the masks.
    pub instance_ids: Vec<u16>,
    /// Fraction of depth pixels that hold a value, over frames with depth.
    pub depth_coverage: f64,
}

/// One test panorama.
#[derive(Clone, Debug, Serialize)]
pub struct PanoramaReport {
    /// File name.
    pub name: String,
    /// Width and height.
    pub size: (u32, u32),
    /// A ground-truth arrangement is present.
    pub ground_truth: bool,
    /// A ground-truth ray-depth image is present.
    pub depth: bool,
    /// A ground-truth instance mask is present.
    pub mask: bool,
}

/// Reads room.json and decodes every file it names and every panorama, checking sizes and ids.
pub fn inspect_room(path: &Path) -> FormatResult<RoomReport> {
    let room = formats::read_room(path)?;
    let mut notes = Vec::new();
    let known: BTreeSet<u16> = room.objects.iter().map(|o| o.id).collect();
    let background = inspect_capture(
        &room.capture_dir(&room.background.capture),
        &known,
        &mut notes,
    )?;
    let mut object_captures = Vec::new();
    for (capture, _) in room.objects_by_capture() {
        object_captures.push(inspect_capture(
            &room.capture_dir(capture),
            &known,
            &mut notes,
        )?);
    }
    let objects = room
        .objects
        .iter()
        .map(|o| inspect_object(&room, o, &mut notes))
        .collect::<FormatResult<Vec<_>>>()?;
    let panoramas = inspect_panoramas(&room, &known)?;
    Ok(RoomReport {
        name: room.name.clone(),
        root: room.root.clone(),
        background,
        objects,
        object_captures,
        panoramas,
        notes,
    })
}

fn inspect_object(
    room: &Room,
    o: &formats::RoomObject,
    notes: &mut Vec<String>,
) -> FormatResult<ObjectReport> {
    let mesh_path = room.root.join("meshes").join(format!("{}.ply", o.name));
    let mesh_triangles = if mesh_path.exists() {
        let mesh = read_ply(&mesh_path)?;
        if let Some((lo, hi)) = mesh.bounds() {
            let extent = (hi - lo).as_dvec3();
            let worst = ((extent - o.size).abs() / o.size).max_element();
            if worst > 0.05 {
                notes.push(format!(
                    "{}: mesh extents {:.3?} differ from room.json size {:.3?} by {:.0} %",
                    mesh_path.display(),
                    extent.to_array(),
                    o.size.to_array(),
                    worst * 100.0
                ));
            }
        }
        Some(mesh.triangles.len())
    } else {
        None
    };
    Ok(ObjectReport {
        id: o.id,
        name: o.name.clone(),
        category: o.category.clone(),
        capture: o.capture.clone(),
        size: o.size.to_array(),
        mesh_triangles,
    })
}

/// What decoding one frame found.
struct FrameFacts {
    size: (u32, u32),
    ids: BTreeSet<u16>,
    depth_valid: Option<f64>,
    conversions: Vec<String>,
}

fn inspect_capture(
    dir: &Path,
    known: &BTreeSet<u16>,
    notes: &mut Vec<String>,
) -> FormatResult<CaptureReport> {
    let capture = formats::read_capture(dir)?;
    let facts: Vec<FrameFacts> = capture
        .frames
        .par_iter()
        .map(|f| inspect_frame(&capture, f))
        .collect::<FormatResult<_>>()?;
    let mut ids = BTreeSet::new();
    let mut sizes = BTreeSet::new();
    let mut conversions: BTreeMap<String, usize> = BTreeMap::new();
    for fact in &facts {
        ids.extend(fact.ids.iter().copied());
        sizes.insert(fact.size);
        for c in &fact.conversions {
            *conversions.entry(c.clone()).or_default() += 1;
        }
    }
    for (what, count) in conversions {
        notes.push(format!("{}: {count} images: {what}", dir.display()));
    }
    if let Some(bad) = ids.iter().find(|id| **id != 0 && !known.contains(id)) {
        return Err(FormatError::file(
            dir,
            format!("instance masks hold id {bad}, which room.json does not list"),
        ));
    }
    let with_depth: Vec<f64> = facts.iter().filter_map(|f| f.depth_valid).collect();
    Ok(CaptureReport {
        dir: dir.to_path_buf(),
        frames: capture.frames.len(),
        with_depth: with_depth.len(),
        with_mask: capture
            .frames
            .iter()
            .filter(|f| f.instance.is_some())
            .count(),
        sizes: sizes.into_iter().collect(),
        instance_ids: ids.into_iter().collect(),
        depth_coverage: with_depth.iter().sum::<f64>() / with_depth.len().max(1) as f64,
    })
}

fn inspect_frame(capture: &Capture, frame: &formats::Frame) -> FormatResult<FrameFacts> {
    let image_path = capture.resolve(&frame.image);
    let decoded = formats::read_rgba(&image_path)?;
    let size = (decoded.image.width, decoded.image.height);
    formats::check_same_size(
        &capture.dir.join("transforms.json"),
        (frame.camera.width, frame.camera.height),
        &image_path,
        size,
    )?;
    // RGB files read as RGBA get an opaque alpha: expected (background captures), not worth a note.
    let conversions = decoded
        .conversions
        .iter()
        .filter(|c| **c != formats::Conversion::OpaqueAlphaAdded)
        .map(|c| c.to_string())
        .collect();
    let depth_valid = match &frame.depth {
        Some(p) => {
            let path = capture.resolve(p);
            let depth = formats::read_depth(&path, capture.depth_unit_scale_factor)?;
            formats::check_same_size(&image_path, size, &path, (depth.width, depth.height))?;
            Some(depth.data.iter().filter(|d| **d > 0.0).count() as f64 / depth.data.len() as f64)
        }
        None => None,
    };
    let ids = match &frame.instance {
        Some(p) => {
            let path = capture.resolve(p);
            let mask = formats::read_mask(&path)?;
            formats::check_same_size(&image_path, size, &path, (mask.width, mask.height))?;
            mask.data.iter().copied().collect()
        }
        None => BTreeSet::new(),
    };
    Ok(FrameFacts {
        size,
        ids,
        depth_valid,
        conversions,
    })
}

fn inspect_panoramas(room: &Room, known: &BTreeSet<u16>) -> FormatResult<Vec<PanoramaReport>> {
    let dir = room.root.join("panoramas");
    let Ok(entries) = std::fs::read_dir(&dir) else {
        return Ok(Vec::new());
    };
    let mut names: Vec<String> = entries
        .filter_map(|e| e.ok().map(|e| e.file_name().to_string_lossy().into_owned()))
        .filter(|n| is_panorama_image(n))
        .collect();
    names.sort();
    names
        .par_iter()
        .map(|n| inspect_panorama(&dir, n, known))
        .collect()
}

/// A panorama is a colour image that is not one of the ground-truth side files.
fn is_panorama_image(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    let image = lower.ends_with(".png") || lower.ends_with(".jpg") || lower.ends_with(".jpeg");
    image && !lower.ends_with(".depth.png") && !lower.ends_with(".mask.png")
}

fn inspect_panorama(dir: &Path, name: &str, known: &BTreeSet<u16>) -> FormatResult<PanoramaReport> {
    let path = dir.join(name);
    let image = formats::read_rgb(&path)?.image;
    Equirect::new(image.width, image.height).map_err(|e| FormatError::file(&path, e))?;
    let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
    let size = (image.width, image.height);
    let gt = dir.join(format!("{stem}.json"));
    if gt.exists() {
        let arrangement = formats::read_arrangement(&gt)?;
        if let Some(o) = arrangement.objects.iter().find(|o| !known.contains(&o.id)) {
            return Err(FormatError::field(
                &gt,
                "objects",
                format!("id {} is not in room.json", o.id),
            ));
        }
    }
    let depth = dir.join(format!("{stem}.depth.png"));
    if depth.exists() {
        let d = formats::read_depth(&depth, 0.001)?;
        formats::check_same_size(&path, size, &depth, (d.width, d.height))?;
    }
    let mask = dir.join(format!("{stem}.mask.png"));
    if mask.exists() {
        let m = formats::read_mask(&mask)?;
        formats::check_same_size(&path, size, &mask, (m.width, m.height))?;
        if let Some(bad) = m.data.iter().find(|id| **id != 0 && !known.contains(id)) {
            return Err(FormatError::file(
                &mask,
                format!("holds id {bad}, which room.json does not list"),
            ));
        }
    }
    Ok(PanoramaReport {
        name: name.to_string(),
        size,
        ground_truth: gt.exists(),
        depth: depth.exists(),
        mask: mask.exists(),
    })
}

impl std::fmt::Display for RoomReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "room `{}` at {}", self.name, self.root.display())?;
        writeln!(f, "  background: {}", self.background)?;
        for o in &self.objects {
            let mesh = o
                .mesh_triangles
                .map_or("no mesh".to_string(), |t| format!("mesh {t} triangles"));
            writeln!(
                f,
                "  object {:>3} {:<16} {:<14} size {:.3} × {:.3} × {:.3} m, capture {}, {mesh}",
                o.id,
                o.name,
                o.category,
                o.size[0],
                o.size[1],
                o.size[2],
                o.capture.display()
            )?;
        }
        for c in &self.object_captures {
            writeln!(f, "  capture {c}")?;
        }
        for p in &self.panoramas {
            writeln!(
                f,
                "  panorama {} {}×{}{}{}{}",
                p.name,
                p.size.0,
                p.size.1,
                if p.ground_truth { ", ground truth" } else { "" },
                if p.depth { ", depth" } else { "" },
                if p.mask { ", mask" } else { "" }
            )?;
        }
        for n in &self.notes {
            writeln!(f, "  note: {n}")?;
        }
        Ok(())
    }
}

impl std::fmt::Display for CaptureReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let sizes: Vec<String> = self.sizes.iter().map(|(w, h)| format!("{w}×{h}")).collect();
        write!(
            f,
            "{}: {} frames ({}), {} with depth ({:.0} % valid), {} with masks, ids {:?}",
            self.dir.display(),
            self.frames,
            sizes.join(", "),
            self.with_depth,
            self.depth_coverage * 100.0,
            self.with_mask,
            self.instance_ids
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BLENDER_LITE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/blender-lite"
    );

    #[test]
    fn reads_the_blender_room_without_complaint() {
        let root = Path::new(BLENDER_LITE);
        if !root.exists() {
            eprintln!("skipped: {BLENDER_LITE} is absent");
            return;
        }
        let report = inspect_room(root).unwrap();
        assert_eq!(report.objects.len(), 3);
        assert_eq!(report.background.frames, 60);
        assert_eq!(report.background.instance_ids, vec![0]);
        assert_eq!(report.object_captures.len(), 3);
        assert!(
            report
                .object_captures
                .iter()
                .all(|c| c.frames == 80 && c.with_depth == 80)
        );
        assert_eq!(report.panoramas.len(), 4);
        assert!(
            report
                .panoramas
                .iter()
                .all(|p| p.ground_truth && p.depth && p.mask && p.size == (512, 256))
        );
        assert!(report.objects.iter().all(|o| o.mesh_triangles.is_some()));
        assert!(report.notes.is_empty(), "{:?}", report.notes);
    }

    #[test]
    fn a_mask_with_an_unknown_id_is_named() {
        let root = Path::new(BLENDER_LITE);
        if !root.exists() {
            eprintln!("skipped: {BLENDER_LITE} is absent");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        std::os::unix::fs::symlink(root.join("captures"), dir.path().join("captures")).unwrap();
        let room_json = std::fs::read_to_string(root.join("room.json")).unwrap();
        // Keep only the stool, drawn from the mixer's capture: its masks then hold an id room.json lacks.
        let mut value: serde_json::Value = serde_json::from_str(&room_json).unwrap();
        let objects = value["objects"].as_array_mut().unwrap();
        objects.retain(|o| o["name"] == "stool");
        objects[0]["capture"] = serde_json::json!("captures/mixer");
        std::fs::write(dir.path().join("room.json"), value.to_string()).unwrap();
        let err = inspect_room(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("captures/mixer") && err.contains("id 3"),
            "{err}"
        );
    }
}

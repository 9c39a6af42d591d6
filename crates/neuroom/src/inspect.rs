//! `neuroom info`: decode and check every file of a room, so a bad file is found in seconds, before any
//! training starts.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use neuroom_core::camera::Equirect;
use neuroom_core::formats::{self, Capture, Room};
use neuroom_core::mesh::read_ply;
use neuroom_core::metrics::Symmetry;
use neuroom_core::{FormatError, FormatResult};
use neuroom_train::symmetry::shape_symmetry;
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
    /// The environment maps training relights the captures with.
    pub env_maps: Vec<EnvMapReport>,
    /// Warnings: things that are allowed but worth knowing (conversions made, meshes that disagree with
    /// sizes, files nothing refers to…).
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
    /// The turns about its up axis its mesh's shape does not show (which headings the rotation error
    /// up to symmetry does not count), when it has a mesh.
    pub symmetry: Option<Symmetry>,
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
    /// Fraction of mask pixels on an object (a nonzero id), over frames with masks.
    pub mask_coverage: f64,
    /// The camera exposed every frame itself (training learns a colour gain per frame).
    pub auto_exposure: bool,
    /// The poses were tracked (training refines them).
    pub tracked_poses: bool,
    /// Standard deviation of a depth sample at 1 m (metres), when the capture declares its noise.
    pub depth_noise_at_1m: Option<f64>,
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

/// One decoded environment map.
#[derive(Clone, Debug, Serialize)]
pub struct EnvMapReport {
    /// The file.
    pub path: PathBuf,
    /// Width and height.
    pub size: (u32, u32),
}

/// Reads room.json and decodes every file it names, every panorama with its side files, every mesh and
/// the environment maps training uses by default, checking sizes and ids. The first bad file ends the
/// check with an error naming it.
pub fn inspect_room(path: &Path) -> FormatResult<RoomReport> {
    inspect_room_with(path, &neuroom_train::augment::vendored_env_maps())
}

/// [`inspect_room`] with the environment maps `env_maps` (those a training run will use).
pub fn inspect_room_with(path: &Path, env_maps: &[PathBuf]) -> FormatResult<RoomReport> {
    let room = formats::read_room(path)?;
    let mut notes = Vec::new();
    let known: BTreeMap<u16, &str> = room
        .objects
        .iter()
        .map(|o| (o.id, o.name.as_str()))
        .collect();
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
    check_stray_meshes(&room, &mut notes)?;
    let panoramas = inspect_panoramas(&room, &known, &mut notes)?;
    let env_maps = inspect_env_maps(env_maps)?;
    Ok(RoomReport {
        name: room.name.clone(),
        root: room.root.clone(),
        background,
        objects,
        object_captures,
        panoramas,
        env_maps,
        notes,
    })
}

/// Decodes every environment map in `paths` (in parallel).
pub fn inspect_env_maps(paths: &[PathBuf]) -> FormatResult<Vec<EnvMapReport>> {
    paths
        .par_iter()
        .map(|p| {
            let map = formats::read_envmap(p)?;
            Ok(EnvMapReport {
                path: p.clone(),
                size: (map.width, map.height),
            })
        })
        .collect()
}

fn inspect_object(
    room: &Room,
    o: &formats::RoomObject,
    notes: &mut Vec<String>,
) -> FormatResult<ObjectReport> {
    let mesh_path = room.truth_mesh_path(o);
    let (mesh_triangles, symmetry) = if mesh_path.exists() {
        let mesh = read_ply(&mesh_path)?;
        if mesh.triangles.is_empty() {
            return Err(FormatError::file(&mesh_path, "mesh has no triangles"));
        }
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
        (Some(mesh.triangles.len()), Some(shape_symmetry(&mesh)))
    } else {
        (None, None)
    };
    Ok(ObjectReport {
        id: o.id,
        name: o.name.clone(),
        category: o.category.clone(),
        capture: o.capture.clone(),
        size: o.size.to_array(),
        mesh_triangles,
        symmetry,
    })
}

/// Decodes the meshes of `meshes/` that no object of room.json names, and notes each one.
fn check_stray_meshes(room: &Room, notes: &mut Vec<String>) -> FormatResult<()> {
    let dir = room.root.join("meshes");
    for path in files_in(&dir) {
        let name = path
            .file_name()
            .map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let Some(stem) = name.strip_suffix(".ply") else {
            continue;
        };
        if room.object_by_name(stem).is_none() {
            read_ply(&path)?;
            notes.push(format!(
                "{}: no object of room.json is called `{stem}`",
                path.display()
            ));
        }
    }
    Ok(())
}

/// The files of `dir`, sorted; none when it does not exist.
fn files_in(dir: &Path) -> Vec<PathBuf> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    files
}

/// What decoding one frame found.
struct FrameFacts {
    size: (u32, u32),
    mask: Option<MaskFacts>,
    depth_valid: Option<f64>,
    conversions: Vec<String>,
}

fn inspect_capture(
    dir: &Path,
    known: &BTreeMap<u16, &str>,
    notes: &mut Vec<String>,
) -> FormatResult<CaptureReport> {
    let capture = formats::read_capture(dir)?;
    let facts: Vec<FrameFacts> = capture
        .frames
        .par_iter()
        .map(|f| inspect_frame(&capture, f, known))
        .collect::<FormatResult<_>>()?;
    let mut ids = BTreeSet::new();
    let mut sizes = BTreeSet::new();
    let mut conversions: BTreeMap<String, usize> = BTreeMap::new();
    for fact in &facts {
        if let Some(mask) = &fact.mask {
            ids.extend(mask.ids.iter().copied());
        }
        sizes.insert(fact.size);
        for c in &fact.conversions {
            *conversions.entry(c.clone()).or_default() += 1;
        }
    }
    for (what, count) in conversions {
        notes.push(format!("{}: {count} images: {what}", dir.display()));
    }
    let with_depth: Vec<f64> = facts.iter().filter_map(|f| f.depth_valid).collect();
    let masked: Vec<f64> = facts
        .iter()
        .filter_map(|f| f.mask.as_ref().map(|m| m.on_objects))
        .collect();
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
        // An empty sum of floats is −0, which would print as "-0 %".
        depth_coverage: match with_depth.len() {
            0 => 0.0,
            n => with_depth.iter().sum::<f64>() / n as f64,
        },
        mask_coverage: match masked.len() {
            0 => 0.0,
            n => masked.iter().sum::<f64>() / n as f64,
        },
        auto_exposure: capture.device.auto_exposure,
        tracked_poses: capture.device.tracked_poses,
        depth_noise_at_1m: capture
            .device
            .depth_noise
            .map(|n| f64::from(n.sigma_at(1.0))),
    })
}

fn inspect_frame(
    capture: &Capture,
    frame: &formats::Frame,
    known: &BTreeMap<u16, &str>,
) -> FormatResult<FrameFacts> {
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
    let mask = match &frame.instance {
        Some(p) => Some(read_checked_mask(
            &capture.resolve(p),
            &image_path,
            size,
            known,
        )?),
        None => None,
    };
    Ok(FrameFacts {
        size,
        mask,
        depth_valid,
        conversions,
    })
}

/// What an instance mask holds.
struct MaskFacts {
    /// The ids in it.
    ids: BTreeSet<u16>,
    /// The share of its pixels on an object (a nonzero id).
    on_objects: f64,
}

/// Reads the instance mask at `path`, checks that it is the size of its image and holds only ids that
/// room.json lists, and says what it holds.
fn read_checked_mask(
    path: &Path,
    image: &Path,
    size: (u32, u32),
    known: &BTreeMap<u16, &str>,
) -> FormatResult<MaskFacts> {
    let mask = formats::read_mask(path)?;
    formats::check_same_size(image, size, path, (mask.width, mask.height))?;
    let ids: BTreeSet<u16> = mask.data.iter().copied().collect();
    if let Some(bad) = ids.iter().find(|id| **id != 0 && !known.contains_key(id)) {
        return Err(FormatError::file(
            path,
            format!("holds instance id {bad}, which room.json does not list"),
        ));
    }
    let on_objects =
        mask.data.iter().filter(|id| **id != 0).count() as f64 / mask.data.len().max(1) as f64;
    Ok(MaskFacts { ids, on_objects })
}

fn inspect_panoramas(
    room: &Room,
    known: &BTreeMap<u16, &str>,
    notes: &mut Vec<String>,
) -> FormatResult<Vec<PanoramaReport>> {
    let dir = room.root.join("panoramas");
    let names: Vec<String> = files_in(&dir)
        .iter()
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .collect();
    let panoramas: Vec<&String> = names.iter().filter(|n| is_panorama_image(n)).collect();
    for n in &names {
        let stem = side_file_stem(n);
        if !is_panorama_image(n) && !panoramas.iter().any(|p| image_stem(p) == stem) {
            notes.push(format!(
                "{}: no panorama image `{stem}.png` for it",
                dir.join(n).display()
            ));
        }
    }
    let checked: Vec<(PanoramaReport, Vec<String>)> = panoramas
        .par_iter()
        .map(|n| inspect_panorama(&dir, n, known))
        .collect::<FormatResult<_>>()?;
    Ok(checked
        .into_iter()
        .map(|(report, conversions)| {
            notes.extend(conversions);
            report
        })
        .collect())
}

/// A panorama is a colour image (PNG or JPEG) that is not one of the ground-truth side files.
pub(crate) fn is_panorama_image(name: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    let image = lower.ends_with(".png") || lower.ends_with(".jpg") || lower.ends_with(".jpeg");
    image && !lower.ends_with(".depth.png") && !lower.ends_with(".mask.png")
}

/// `bedroom_a0` for `bedroom_a0.png`.
pub(crate) fn image_stem(name: &str) -> &str {
    name.rsplit_once('.').map_or(name, |(s, _)| s)
}

/// `bedroom_a0` for `bedroom_a0.json`, `bedroom_a0.depth.png` and `bedroom_a0.mask.png`.
fn side_file_stem(name: &str) -> &str {
    [".depth.png", ".mask.png", ".json"]
        .iter()
        .find_map(|s| name.strip_suffix(s))
        .unwrap_or_else(|| image_stem(name))
}

/// Checks one panorama and its side files; returns its report and a note per conversion made.
fn inspect_panorama(
    dir: &Path,
    name: &str,
    known: &BTreeMap<u16, &str>,
) -> FormatResult<(PanoramaReport, Vec<String>)> {
    let path = dir.join(name);
    let decoded = formats::read_rgb(&path)?;
    let image = decoded.image;
    Equirect::new(image.width, image.height).map_err(|e| FormatError::file(&path, e))?;
    let notes = decoded
        .conversions
        .iter()
        .map(|c| format!("{}: {c}", path.display()))
        .collect();
    let stem = image_stem(name);
    let size = (image.width, image.height);
    drop(image);
    let gt = dir.join(format!("{stem}.json"));
    if gt.exists() {
        check_arrangement_ids(&gt, known)?;
    }
    let depth = dir.join(format!("{stem}.depth.png"));
    if depth.exists() {
        let d = formats::read_depth(&depth, 0.001)?;
        formats::check_same_size(&path, size, &depth, (d.width, d.height))?;
    }
    let mask = dir.join(format!("{stem}.mask.png"));
    if mask.exists() {
        read_checked_mask(&mask, &path, size, known)?;
    }
    let report = PanoramaReport {
        name: name.to_string(),
        size,
        ground_truth: gt.exists(),
        depth: depth.exists(),
        mask: mask.exists(),
    };
    Ok((report, notes))
}

/// Reads a ground-truth arrangement and checks that every object is one of room.json, by id and name.
fn check_arrangement_ids(path: &Path, known: &BTreeMap<u16, &str>) -> FormatResult<()> {
    let arrangement = formats::read_arrangement(path)?;
    for (i, o) in arrangement.objects.iter().enumerate() {
        match known.get(&o.id) {
            None => {
                return Err(FormatError::field(
                    path,
                    format!("objects[{i}].id"),
                    format!("id {} is not in room.json", o.id),
                ));
            }
            Some(name) if *name != o.name => {
                return Err(FormatError::field(
                    path,
                    format!("objects[{i}].name"),
                    format!("id {} is `{name}` in room.json, not `{}`", o.id, o.name),
                ));
            }
            Some(_) => {}
        }
    }
    Ok(())
}

/// A shape symmetry in words.
fn describe_symmetry(symmetry: Symmetry) -> String {
    match symmetry {
        Symmetry::None => "every heading shows".into(),
        Symmetry::Turns(n) => format!("looks alike turned by 1/{n} turn"),
        Symmetry::Continuous => "looks alike turned by any angle".into(),
    }
}

impl std::fmt::Display for RoomReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "room `{}` at {}", self.name, self.root.display())?;
        writeln!(f, "  background: {}", self.background)?;
        for o in &self.objects {
            let mesh = match (o.mesh_triangles, o.symmetry) {
                (Some(t), Some(symmetry)) => {
                    format!("mesh {t} triangles, {}", describe_symmetry(symmetry))
                }
                (Some(t), None) => format!("mesh {t} triangles"),
                _ => "no mesh".to_string(),
            };
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
        for m in &self.env_maps {
            writeln!(
                f,
                "  environment map {} {}×{}",
                m.path.display(),
                m.size.0,
                m.size.1
            )?;
        }
        for n in &self.notes {
            writeln!(f, "  warning: {n}")?;
        }
        Ok(())
    }
}

impl std::fmt::Display for CaptureReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let sizes: Vec<String> = self.sizes.iter().map(|(w, h)| format!("{w}×{h}")).collect();
        write!(
            f,
            "{}: {} frames ({}), {} with depth ({:.0} % valid), {} with masks ({:.1} % on objects), ids {:?}",
            self.dir.display(),
            self.frames,
            sizes.join(", "),
            self.with_depth,
            self.depth_coverage * 100.0,
            self.with_mask,
            self.mask_coverage * 100.0,
            self.instance_ids
        )?;
        let device: Vec<&str> = [
            (self.auto_exposure, "auto-exposed"),
            (self.tracked_poses, "tracked poses"),
        ]
        .iter()
        .filter_map(|&(on, what)| on.then_some(what))
        .collect();
        if !device.is_empty() {
            write!(f, ", {}", device.join(", "))?;
        }
        if let Some(sigma) = self.depth_noise_at_1m {
            write!(f, ", depth noise {:.1} mm at 1 m", sigma * 1000.0)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TINY: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../neuroom-core/tests/rooms/tiny"
    );
    const CORPUS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../neuroom-core/tests/corpus");

    /// A copy of the tiny test room in a temporary folder.
    fn tiny_copy() -> tempfile::TempDir {
        fn copy(from: &Path, to: &Path) {
            std::fs::create_dir_all(to).unwrap();
            for e in std::fs::read_dir(from).unwrap() {
                let e = e.unwrap();
                if e.file_type().unwrap().is_dir() {
                    copy(&e.path(), &to.join(e.file_name()));
                } else {
                    std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
                }
            }
        }
        let dir = tempfile::tempdir().unwrap();
        copy(Path::new(TINY), dir.path());
        dir
    }

    #[test]
    fn the_tiny_room_passes_without_warnings() {
        let report = inspect_room_with(Path::new(TINY), &[]).unwrap();
        assert_eq!(report.background.frames, 2);
        assert_eq!(report.object_captures[0].instance_ids, vec![0, 1]);
        assert_eq!(report.panoramas.len(), 1);
        assert!(report.panoramas[0].ground_truth && report.panoramas[0].mask);
        assert_eq!(report.objects[0].mesh_triangles, Some(12));
        assert!(report.notes.is_empty(), "{:?}", report.notes);
    }

    #[test]
    fn a_grayscale_panorama_is_read_with_a_warning() {
        let room = tiny_copy();
        let pano = room.path().join("panoramas");
        std::fs::copy(Path::new(CORPUS).join("gen_gray8.png"), pano.join("p0.png")).unwrap();
        std::fs::remove_file(pano.join("p0.depth.png")).unwrap();
        std::fs::remove_file(pano.join("p0.mask.png")).unwrap();
        let report = inspect_room_with(room.path(), &[]).unwrap();
        assert_eq!(report.panoramas[0].size, (8, 4));
        assert!(
            report
                .notes
                .iter()
                .any(|n| n.contains("p0.png") && n.contains("grayscale converted to RGB")),
            "{:?}",
            report.notes
        );
    }

    #[test]
    fn an_arrangement_that_misnames_an_object_is_rejected() {
        let room = tiny_copy();
        let path = room.path().join("panoramas/p0.json");
        let text = std::fs::read_to_string(&path).unwrap();
        std::fs::write(&path, text.replace("\"box\"", "\"crate\"")).unwrap();
        let err = inspect_room_with(room.path(), &[]).unwrap_err();
        assert_eq!(err.path, path);
        assert_eq!(err.field.as_deref(), Some("objects[0].name"));
        assert!(err.to_string().contains("`box` in room.json"), "{err}");
    }

    #[test]
    fn stray_side_files_and_meshes_are_noted() {
        let room = tiny_copy();
        let root = room.path();
        std::fs::copy(
            root.join("panoramas/p0.json"),
            root.join("panoramas/q1.json"),
        )
        .unwrap();
        std::fs::copy(root.join("meshes/box.ply"), root.join("meshes/ghost.ply")).unwrap();
        let notes = inspect_room_with(root, &[]).unwrap().notes;
        assert!(notes.iter().any(|n| n.contains("q1.json")), "{notes:?}");
        assert!(notes.iter().any(|n| n.contains("`ghost`")), "{notes:?}");
    }

    #[test]
    fn a_bad_environment_map_is_named() {
        let bad = Path::new(CORPUS).join("gen_envmap_square.hdr");
        let err = inspect_room_with(Path::new(TINY), std::slice::from_ref(&bad)).unwrap_err();
        assert_eq!(err.path, bad);
        let ok = inspect_env_maps(&neuroom_train::augment::vendored_env_maps()).unwrap();
        assert!(ok.iter().all(|m| m.size.0 == 2 * m.size.1));
    }

    const BLENDER_LITE: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../shared/data/blender-lite"
    );

    #[test]
    #[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
    fn shared_data_reads_the_blender_room_without_complaint() {
        let root = Path::new(BLENDER_LITE);
        assert!(
            root.exists(),
            "{BLENDER_LITE} is absent: this test needs the shared data"
        );
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
    #[ignore = "needs ../shared/data/blender-lite: .ci/run runs it where that folder exists"]
    fn shared_data_a_mask_with_an_unknown_id_is_named() {
        let root = Path::new(BLENDER_LITE);
        assert!(
            root.exists(),
            "{BLENDER_LITE} is absent: this test needs the shared data"
        );
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

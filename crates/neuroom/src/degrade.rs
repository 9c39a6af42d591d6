//! `neuroom degrade ROOM --phone --out DIR`: a copy of a room whose captures look as a phone
//! delivers them ([`neuroom_synth::phone::PhoneModel`]): coarse, noisy LiDAR depth with holes,
//! poses off by a centimetre or two and about a degree, every frame exposed and white-balanced on
//! its own, some blurred, all through JPEG. Panoramas, ground truth and meshes are copied
//! unchanged, so the degraded room is scored against the same truth.

use std::path::{Component, Path, PathBuf};

use anyhow::Context as _;
use neuroom_core::formats::{self, Capture, CaptureDevice, Frame};
use neuroom_synth::phone::PhoneModel;

use crate::staging::StagedFolder;

/// What [`degrade_room`] wrote.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DegradedRoom {
    /// The degraded room's folder.
    pub room: PathBuf,
    /// Captures degraded.
    pub captures: usize,
    /// Frames degraded.
    pub frames: usize,
}

/// Copies `room` to `out` with every capture degraded as a phone would have taken it, drawn from
/// `seed` (the same seed writes the same files). `progress` is told `(frames done, frames)`.
pub fn degrade_room(
    room: &Path,
    out: &Path,
    seed: u64,
    progress: &mut dyn FnMut(usize, usize),
) -> anyhow::Result<DegradedRoom> {
    let spec = formats::read_room(room.join("room.json"))?;
    anyhow::ensure!(
        !out.join("room.json").exists(),
        "{}: already holds a room; degrade into a new folder",
        out.display()
    );
    let mut captures: Vec<PathBuf> = vec![spec.background.capture.clone()];
    for (capture, _) in spec.objects_by_capture() {
        captures.push(capture.to_path_buf());
    }
    // A capture outside the room folder would be degraded outside `out`.
    if let Some(outside) = captures.iter().find(|c| !stays_inside(c)) {
        anyhow::bail!(
            "{}: the capture {} lies outside the room folder; degrade copies only the folder",
            room.join("room.json").display(),
            outside.display()
        );
    }
    let read: Vec<Capture> = captures
        .iter()
        .map(|c| formats::read_capture(room.join(c)))
        .collect::<Result<_, _>>()?;
    // An interrupted run leaves no room that looks whole.
    let staged = StagedFolder::new(out)?;
    let partial = staged.path();
    copy_except(room, partial, &captures)?;
    let total: usize = read.iter().map(|c| c.frames.len()).sum();
    let model = PhoneModel::default();
    let mut done = 0;
    for (k, (relative, capture)) in captures.iter().zip(&read).enumerate() {
        let dir = partial.join(relative);
        let mut frames = Vec::with_capacity(capture.frames.len());
        for (i, frame) in capture.frames.iter().enumerate() {
            let frame_seed = seed ^ ((k as u64) << 32) ^ i as u64;
            frames.push(degrade_frame(&model, capture, frame, &dir, frame_seed)?);
            done += 1;
            progress(done, total);
        }
        let degraded = Capture {
            dir: dir.clone(),
            frames,
            device: CaptureDevice {
                auto_exposure: true,
                tracked_poses: true,
                depth_noise: Some(model.depth_noise),
            },
            ..capture.clone()
        };
        formats::write_capture(&dir, &degraded)?;
    }
    staged.finish()?;
    Ok(DegradedRoom {
        room: out.to_path_buf(),
        captures: captures.len(),
        frames: total,
    })
}

/// Copies the link `relative` of `from` into `to`. A relative link that stays inside `from` (a
/// suite room's `in_room/captures/background` names the room's own background) becomes the same link
/// in the copy, so it names the copy's degraded capture; any other link is copied as what it names.
fn copy_link(from: &Path, to: &Path, relative: &Path) -> anyhow::Result<()> {
    let source = from.join(relative);
    let target = std::fs::read_link(&source)
        .with_context(|| format!("{}: cannot read", source.display()))?;
    let parent = relative.parent().unwrap_or(Path::new(""));
    if cfg!(unix) && target.is_relative() && lexically_inside(&parent.join(&target)) {
        #[cfg(unix)]
        std::os::unix::fs::symlink(&target, to.join(relative))
            .with_context(|| format!("{}: cannot link", to.join(relative).display()))?;
        return Ok(());
    }
    let followed = std::fs::metadata(&source)
        .with_context(|| format!("{}: names nothing that can be read", source.display()))?;
    if followed.is_dir() {
        copy_tree(&source, &to.join(relative), &|_| false, Path::new(""))
    } else {
        std::fs::copy(&source, to.join(relative))
            .map(|_| ())
            .with_context(|| format!("{}: cannot copy", source.display()))
    }
}

/// Whether the relative path `path`, its `..` taken back, stays inside its folder.
fn lexically_inside(path: &Path) -> bool {
    let mut depth = 0usize;
    for c in path.components() {
        match c {
            Component::Normal(_) => depth += 1,
            Component::CurDir => {}
            Component::ParentDir if depth > 0 => depth -= 1,
            _ => return false,
        }
    }
    true
}

/// Whether the relative path `path` names something inside its folder (no `..`, not absolute).
fn stays_inside(path: &Path) -> bool {
    path.components()
        .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

/// One frame of `capture` degraded into the capture folder `dir` (same file names; masks copied).
fn degrade_frame(
    model: &PhoneModel,
    capture: &Capture,
    frame: &Frame,
    dir: &Path,
    seed: u64,
) -> anyhow::Result<Frame> {
    let rgba = formats::read_rgba(capture.resolve(&frame.image))?.image;
    let depth = match &frame.depth {
        Some(d) => Some(formats::read_depth(
            capture.resolve(d),
            capture.depth_unit_scale_factor,
        )?),
        None => None,
    };
    let phone = model
        .degrade_frame(&rgba, depth.as_ref(), &frame.camera_to_world, seed)
        .map_err(|e| anyhow::anyhow!("{}: {e}", capture.resolve(&frame.image).display()))?;
    let target = |relative: &Path| -> anyhow::Result<PathBuf> {
        let path = dir.join(relative);
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("{}: cannot create", parent.display()))?;
        }
        Ok(path)
    };
    formats::write_rgba(target(&frame.image)?, &phone.rgba)?;
    if let (Some(relative), Some(depth)) = (&frame.depth, &phone.depth) {
        formats::write_depth(target(relative)?, depth, capture.depth_unit_scale_factor)?;
    }
    if let Some(mask) = &frame.instance {
        let to = target(mask)?;
        std::fs::copy(capture.resolve(mask), &to)
            .with_context(|| format!("{}: cannot write", to.display()))?;
    }
    Ok(Frame {
        camera_to_world: phone.camera_to_world,
        ..frame.clone()
    })
}

/// Copies the folder `from` into `to`, leaving out the capture folders `skipped` (relative to it).
fn copy_except(from: &Path, to: &Path, skipped: &[PathBuf]) -> anyhow::Result<()> {
    copy_tree(
        from,
        to,
        &|relative| skipped.iter().any(|s| s == relative),
        Path::new(""),
    )
}

fn copy_tree(
    from: &Path,
    to: &Path,
    skip: &dyn Fn(&Path) -> bool,
    relative: &Path,
) -> anyhow::Result<()> {
    let here = from.join(relative);
    std::fs::create_dir_all(to.join(relative))
        .with_context(|| format!("{}: cannot create", to.join(relative).display()))?;
    let entries =
        std::fs::read_dir(&here).with_context(|| format!("{}: cannot list", here.display()))?;
    for entry in entries {
        let entry = entry?;
        let name = relative.join(entry.file_name());
        if skip(&name) {
            continue;
        }
        let kind = entry.file_type()?;
        if kind.is_symlink() {
            copy_link(from, to, &name)?;
        } else if kind.is_dir() {
            copy_tree(from, to, skip, &name)?;
        } else {
            std::fs::copy(entry.path(), to.join(&name))
                .with_context(|| format!("{}: cannot copy", entry.path().display()))?;
        }
    }
    Ok(())
}

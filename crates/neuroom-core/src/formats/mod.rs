//! The on-disk formats of `docs/formats.md`: rooms, captures, arrangements, refined capture poses, images
//! and environment maps.
//!
//! Every reader validates what it reads and fails with a [`FormatError`] naming the
//! file and the field at fault; readers ignore fields they do not know. Every writer goes through
//! [`atomic_write`], so a crash never leaves a half-written file behind.

pub mod arrangement;
pub mod base64;
pub mod envmap;
pub mod images;
pub mod json;
pub mod refined_poses;
pub mod room;
pub mod tensor_file;
pub mod transforms;

pub use arrangement::{
    ArrangedObject, Arrangement, arrangement_value, parse_arrangement, read_arrangement,
    write_arrangement,
};
pub use envmap::{EnvMap, decode_envmap, read_envmap};
pub use images::{
    Conversion, Decoded, MAX_IMAGE_SIDE, check_same_size, decode_depth, decode_image_size,
    decode_mask, decode_rgb, decode_rgba, read_colour_photo, read_depth, read_image_size,
    read_mask, read_panorama, read_rgb, read_rgba, write_depth, write_mask, write_rgb, write_rgba,
};
pub use refined_poses::{
    REFINED_POSES_FILE, RefinedFrame, RefinedPoses, read_refined_poses, write_refined_poses,
};
pub use room::{BackgroundSpec, Room, RoomObject, parse_room, read_room, write_room};
pub use tensor_file::canonical_safetensors;
pub use transforms::{
    Capture, CaptureDevice, DepthNoise, Frame, parse_capture, parse_intrinsics, read_capture,
    read_intrinsics_file, write_capture,
};

use crate::error::{FormatError, FormatResult};
use std::collections::HashSet;
use std::fs::{self, File};
use std::io::Write;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `bytes` to `path` atomically: the bytes go to a temporary file in the same folder, which is
/// flushed to disk and then renamed over `path`. Readers therefore see either the old file or the new one,
/// never a torn one. Missing parent folders are created.
pub fn atomic_write(path: impl AsRef<Path>, bytes: &[u8]) -> FormatResult<()> {
    let path = path.as_ref();
    let io = |what: &str, e: std::io::Error| FormatError::file(path, format!("cannot {what}: {e}"));
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    fs::create_dir_all(dir).map_err(|e| io("create the parent folder", e))?;
    let tmp = dir.join(temp_name(path));
    let result = write_synced(&tmp, bytes).and_then(|()| fs::rename(&tmp, path));
    if let Err(e) = result {
        let _ = fs::remove_file(&tmp);
        return Err(io("write", e));
    }
    // Persist the rename itself; not every file system lets a folder be synced, so this is best effort.
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

/// Rejects a repeated id or name among `objects`, naming the second occurrence (`objects[i].id`).
fn check_unique<'a>(
    file: &Path,
    objects: impl IntoIterator<Item = (u16, &'a str)>,
) -> FormatResult<()> {
    let (mut ids, mut names) = (HashSet::new(), HashSet::new());
    for (i, (id, name)) in objects.into_iter().enumerate() {
        if !ids.insert(id) {
            return Err(FormatError::field(
                file,
                format!("objects[{i}].id"),
                format!("duplicate id {id}"),
            ));
        }
        if !names.insert(name) {
            return Err(FormatError::field(
                file,
                format!("objects[{i}].name"),
                format!("duplicate name \"{name}\""),
            ));
        }
    }
    Ok(())
}

/// A temporary file name unique within this process, hidden, next to `path`.
fn temp_name(path: &Path) -> String {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    format!(".{name}.{}.{n}.tmp", std::process::id())
}

/// Creates `path`, writes `bytes` and flushes them to the disk.
fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = File::create(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_write_replaces_and_leaves_no_temp_files() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/a.txt");
        atomic_write(&path, b"first").unwrap();
        atomic_write(&path, b"second").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        let names: Vec<_> = fs::read_dir(path.parent().unwrap())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(names, vec![std::ffi::OsString::from("a.txt")]);
    }

    #[test]
    fn atomic_write_names_the_file_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let blocker = dir.path().join("file");
        fs::write(&blocker, b"x").unwrap();
        let err = atomic_write(blocker.join("inner.txt"), b"y").unwrap_err();
        assert!(err.to_string().contains("inner.txt"), "{err}");
    }
}

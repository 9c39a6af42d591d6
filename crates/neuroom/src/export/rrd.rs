//! The Rerun recording of a solved room: the same meshes as the glTF binary, the solved boxes (room.json's
//! sizes, or the extent of each model's surface) and, given a ground truth, its boxes, the panorama camera
//! and the input panorama; the layout is `neuroom_export::rrd`'s.

use std::path::Path;

use neuroom_core::formats::{atomic_write, read_arrangement};
use neuroom_export::mesh::SceneMeshes;
use neuroom_export::rrd::{EncodedFile, RrdScene, room_rrd};

use super::{ExportOptions, file_figure, find_panorama, find_room, map_boxes, object_sizes};
use crate::view::SolvedScene;

/// Records `scene` with its `meshes` into `path`; `arrangement` is the solved arrangement's file (the
/// panorama is looked for beside it).
pub(super) fn write_rrd(
    scene: &SolvedScene,
    meshes: &SceneMeshes,
    arrangement: &Path,
    options: &ExportOptions,
    path: &Path,
) -> anyhow::Result<()> {
    let solved = &scene.arrangement;
    let truth = options.truth.as_deref().map(read_arrangement).transpose()?;
    let sizes = object_sizes(scene, find_room(options).as_deref())?;
    let panorama = find_panorama(options, arrangement, solved, truth.as_ref())
        .map(|p| file_figure(&p, String::new()))
        .transpose()?;
    let truth_boxes = truth
        .as_ref()
        .map_or_else(Vec::new, |t| map_boxes(t, &sizes));
    let bytes = room_rrd(&RrdScene {
        meshes,
        camera_to_world: solved.camera_to_world,
        panorama: panorama.as_ref().map(|f| EncodedFile {
            media_type: f.mime,
            bytes: &f.bytes,
        }),
        solved: &map_boxes(solved, &sizes),
        truth: &truth_boxes,
    })?;
    atomic_write(path, &bytes)?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use neuroom_core::formats::{write_arrangement, write_rgb};
    use neuroom_core::image::Image;
    use neuroom_export::mesh::MeshDetail;
    use neuroom_export::rrd::RRD_MAGIC;
    use neuroom_testing::{tiny_arrangement, write_tiny_models};

    use super::super::{ExportOptions, export};

    #[test]
    fn exports_a_recording_with_the_truth_and_the_panorama() {
        let dir = tempfile::tempdir().unwrap();
        let models = dir.path().join("models");
        write_tiny_models(&models).unwrap();
        let arrangement = dir.path().join("solved.json");
        write_arrangement(&arrangement, &tiny_arrangement()).unwrap();
        write_rgb(
            dir.path().join("tiny.png"),
            &Image::filled(64, 32, [0.3f32; 3]),
        )
        .unwrap();
        let options = ExportOptions {
            rrd: Some(dir.path().join("room.rrd")),
            truth: Some(arrangement.clone()),
            detail: MeshDetail {
                object_cell_m: 0.05,
                room_cell_m: 0.2,
                ..MeshDetail::default()
            },
            ..ExportOptions::default()
        };
        let summary = export(&models, &arrangement, &options, &mut |_| {}).unwrap();
        assert!(summary.gltf.is_none() && summary.report.is_none());
        let bytes = std::fs::read(summary.rrd.unwrap()).unwrap();
        assert_eq!(&bytes[..4], RRD_MAGIC);
        assert!(bytes.len() > 64 * 32 / 8, "{} bytes", bytes.len());
    }
}

//! A solved room as a Rerun recording (`.rrd`, read by `rerun-sdk` 0.36): the room and every object as
//! coloured meshes placed by their poses (the glTF export's meshes), the solved and ground-truth boxes
//! labelled with the objects' names, the panorama camera's frame as axes, and the input panorama as a
//! 2D image (Rerun has no equirectangular camera, so the image stands beside the 3D view).
//!
//! Everything is logged once, as static data, in the world frame of docs/formats.md (right-handed, z up,
//! metres), which `world` declares as its view coordinates so that the viewer shows the room upright.
//! Entity paths:
//!
//! | path | what |
//! |---|---|
//! | `world` | view coordinates: right-handed, z up |
//! | `world/meshes/<layer>` | `room` or an object: its pose (Transform3D) and its mesh (Mesh3D) |
//! | `world/boxes/solved`, `world/boxes/truth` | oriented boxes (Boxes3D) labelled with object names |
//! | `world/camera` | the panorama camera's pose (Transform3D) drawn as axes: x forward, y left, z up |
//! | `panorama` | the input panorama (EncodedImage) |

use glam::DQuat;
use neuroom_core::Pose;
use rerun::{
    Boxes3D, Color, EncodedImage, EntityPath, EntityPathPart, Mesh3D, Quaternion, RecordingStream,
    RecordingStreamBuilder, Transform3D, TransformAxes3D, ViewCoordinates,
};

use crate::mesh::{LayerMesh, SceneMeshes};
use crate::topdown::MapBox;

/// Application id of the recordings, shown by the viewer.
pub const APPLICATION_ID: &str = "neuroom";
/// The first four bytes of every `.rrd` file.
pub const RRD_MAGIC: &[u8; 4] = b"RRF2";
/// Colour of the solved boxes (orange).
const SOLVED_COLOR: [u8; 3] = [255, 140, 0];
/// Colour of the ground-truth boxes (green).
const TRUTH_COLOR: [u8; 3] = [40, 200, 80];
/// Length of the camera's axes, metres.
const CAMERA_AXIS_M: f32 = 0.3;

/// An encoded image file: what a PNG or JPEG panorama is logged as, untouched.
#[derive(Clone, Copy, Debug)]
pub struct EncodedFile<'a> {
    /// `image/png` or `image/jpeg`.
    pub media_type: &'a str,
    /// The file's bytes.
    pub bytes: &'a [u8],
}

/// What a recording shows.
#[derive(Clone, Copy, Debug)]
pub struct RrdScene<'a> {
    /// The room's and the objects' meshes, as [`crate::mesh::scene_meshes`] extracts them.
    pub meshes: &'a SceneMeshes,
    /// The panorama camera's pose (docs/formats.md panorama frame: +x forward, +y left, +z up).
    pub camera_to_world: Pose,
    /// The input panorama, when known.
    pub panorama: Option<EncodedFile<'a>>,
    /// The solved objects' boxes.
    pub solved: &'a [MapBox],
    /// The ground truth's boxes; empty without a ground truth.
    pub truth: &'a [MapBox],
}

/// Records `scene` and returns the `.rrd` file's bytes.
pub fn room_rrd(scene: &RrdScene) -> anyhow::Result<Vec<u8>> {
    let (rec, storage) = RecordingStreamBuilder::new(APPLICATION_ID).memory()?;
    rec.log_static("world", &ViewCoordinates::RIGHT_HAND_Z_UP())?;
    for layer in &scene.meshes.layers {
        log_layer(&rec, scene.meshes, layer)?;
    }
    log_boxes(&rec, "solved", scene.solved, SOLVED_COLOR)?;
    log_boxes(&rec, "truth", scene.truth, TRUTH_COLOR)?;
    rec.log_static(
        "world/camera",
        &[
            &transform(&scene.camera_to_world) as &dyn rerun::AsComponents,
            &TransformAxes3D::new(CAMERA_AXIS_M),
        ],
    )?;
    if let Some(image) = scene.panorama {
        let encoded = EncodedImage::new(image.bytes.to_vec()).with_media_type(image.media_type);
        rec.log_static("panorama", &encoded)?;
    }
    Ok(storage.drain_as_bytes()?)
}

/// `world/<group>/<name>`, with `name` escaped as one part whatever characters it holds.
fn entity(group: &str, name: &str) -> EntityPath {
    EntityPath::new(vec![
        EntityPathPart::from("world"),
        EntityPathPart::from(group),
        EntityPathPart::new(name),
    ])
}

/// A rigid pose as a Transform3D (parent from child).
fn transform(pose: &Pose) -> Transform3D {
    let q = DQuat::from_mat3(&pose.rotation).normalize().as_quat();
    Transform3D::from_translation_rotation(
        pose.translation.as_vec3().to_array(),
        Quaternion::from_xyzw(q.to_array()),
    )
}

/// Logs one layer's pose and its mesh (model frame, sRGB vertex colours, unit normals).
fn log_layer(rec: &RecordingStream, meshes: &SceneMeshes, layer: &LayerMesh) -> anyhow::Result<()> {
    let g = &meshes.geometries[layer.geometry];
    let colors = layer
        .colors
        .iter()
        .map(|c| Color::from_rgb(unorm8(c[0]), unorm8(c[1]), unorm8(c[2])));
    let mesh = Mesh3D::new(g.positions.iter().map(|p| p.to_array()))
        .with_vertex_normals(g.normals.iter().map(|n| n.to_array()))
        .with_vertex_colors(colors)
        .with_triangle_indices(g.triangles.iter().copied());
    rec.log_static(
        entity("meshes", &layer.name),
        &[&transform(&layer.pose) as &dyn rerun::AsComponents, &mesh],
    )?;
    Ok(())
}

/// A value in [0, 1] as an 8-bit channel.
fn unorm8(c: f32) -> u8 {
    (c.clamp(0.0, 1.0) * 255.0).round() as u8
}

/// Logs `boxes` as one Boxes3D at `world/boxes/<group>` in `color`, labelled by name; nothing if empty.
fn log_boxes(
    rec: &RecordingStream,
    group: &str,
    boxes: &[MapBox],
    color: [u8; 3],
) -> anyhow::Result<()> {
    if boxes.is_empty() {
        return Ok(());
    }
    let centers = boxes
        .iter()
        .map(|b| b.obb.pose.translation.as_vec3().to_array());
    let half_sizes = boxes
        .iter()
        .map(|b| (0.5 * b.obb.size).as_vec3().to_array());
    let rotations = boxes.iter().map(|b| {
        let q = DQuat::from_mat3(&b.obb.pose.rotation).normalize().as_quat();
        Quaternion::from_xyzw(q.to_array())
    });
    let [r, g, b] = color;
    let archetype = Boxes3D::from_centers_and_half_sizes(centers, half_sizes)
        .with_quaternions(rotations)
        .with_colors(boxes.iter().map(|_| Color::from_rgb(r, g, b)))
        .with_labels(boxes.iter().map(|b| b.label.clone()));
    rec.log_static(
        EntityPath::new(vec!["world".into(), "boxes".into(), group.into()]),
        &archetype,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::tiny_meshes;
    use glam::DVec3;
    use neuroom_core::obb::OrientedBox;
    use neuroom_testing::tiny_arrangement;

    fn boxes(offset: f64) -> Vec<MapBox> {
        tiny_arrangement()
            .objects
            .iter()
            .map(|o| {
                let mut pose = o.object_to_world;
                pose.translation.x += offset;
                MapBox {
                    label: o.name.clone(),
                    id: o.id,
                    obb: OrientedBox::new(pose, DVec3::splat(0.4)),
                }
            })
            .collect()
    }

    #[test]
    fn a_tiny_room_records_as_an_rrd_file() {
        let meshes = tiny_meshes(0.05, 0.2);
        let png =
            crate::report::encode_png(&neuroom_core::image::Image::filled(8, 4, [0.5; 3])).unwrap();
        let (solved, truth) = (boxes(0.0), boxes(0.05));
        let scene = RrdScene {
            meshes: &meshes,
            camera_to_world: tiny_arrangement().camera_to_world,
            panorama: Some(EncodedFile {
                media_type: "image/png",
                bytes: &png,
            }),
            solved: &solved,
            truth: &truth,
        };
        let bytes = room_rrd(&scene).unwrap();
        assert!(bytes.len() > 1000, "{} bytes", bytes.len());
        assert_eq!(&bytes[..4], RRD_MAGIC);
        let without = room_rrd(&RrdScene {
            panorama: None,
            truth: &[],
            ..scene
        })
        .unwrap();
        assert_eq!(&without[..4], RRD_MAGIC);
        assert!(
            without.len() + png.len() < bytes.len(),
            "the image and truth are in"
        );
    }
}

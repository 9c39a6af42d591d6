//! A solved room as one glTF 2.0 binary: the room's mesh and one node per object placed by its pose,
//! vertex colours baked from the colour network (unlit, so viewers show them as they are), and the
//! panorama camera as a perspective camera looking along its forward axis.
//!
//! The room's surface faces into the room and has a single-sided material of its own, so a viewer
//! outside the room sees in through the walls and the ceiling nearest to it (a doll's house); the
//! objects' material is double-sided.
//!
//! glTF is y-up and the room is z-up: every node hangs under a root node that turns +z into +y, so the
//! positions and poses inside keep the room's own coordinates.

use glam::{DMat3, DQuat, DVec3, Vec3};
use neuroom_core::Pose;
use neuroom_core::image::srgb_to_linear;
use serde_json::{Value, json};

use crate::glb::GlbBuilder;
use crate::mesh::SceneMeshes;

/// The exported camera: where it stands and its lens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ExportCamera {
    /// The panorama camera's pose (docs/formats.md panorama frame: +x forward, +y left, +z up).
    pub camera_to_world: Pose,
    /// Vertical field of view, radians.
    pub yfov: f64,
    /// Width over height.
    pub aspect_ratio: f64,
}

impl ExportCamera {
    /// A 60° × 90° view along the panorama camera's forward axis.
    pub fn from_panorama(camera_to_world: Pose) -> Self {
        Self {
            camera_to_world,
            yfov: 60f64.to_radians(),
            aspect_ratio: 1.5,
        }
    }

    /// The glTF camera frame (looks along −z, +y up) in the world: forward = panorama +x, up = +z.
    fn gltf_pose(&self) -> Pose {
        let pano_to_gltf_camera = DMat3::from_cols(-DVec3::Y, DVec3::Z, -DVec3::X);
        Pose::new(
            self.camera_to_world.rotation * pano_to_gltf_camera,
            self.camera_to_world.translation,
        )
    }
}

/// A node's `translation` and unit `rotation` quaternion (`[x, y, z, w]`) for a rigid pose.
fn trs(pose: &Pose) -> (Value, Value) {
    let q = DQuat::from_mat3(&pose.rotation).normalize();
    let q = [q.x as f32, q.y as f32, q.z as f32, q.w as f32];
    let n = q.iter().map(|c| c * c).sum::<f32>().sqrt();
    (
        json!(pose.translation.as_vec3().to_array()),
        json!(q.map(|c| c / n)),
    )
}

/// Writes `meshes` and `camera` as a `.glb` (bytes).
pub fn room_glb(meshes: &SceneMeshes, camera: &ExportCamera) -> Vec<u8> {
    let mut builder = GlbBuilder::new();
    let shared: Vec<(usize, usize, usize)> = meshes
        .geometries
        .iter()
        .map(|g| {
            if g.is_empty() {
                return (usize::MAX, usize::MAX, usize::MAX);
            }
            (
                builder.vec3(&g.positions, true),
                builder.vec3(&g.normals, false),
                builder.indices(&g.triangles),
            )
        })
        .collect();
    let mut gltf_meshes = Vec::new();
    let mut nodes = vec![Value::Null];
    for layer in &meshes.layers {
        let (position, normal, indices) = shared[layer.geometry];
        let linear: Vec<Vec3> = layer
            .colors
            .iter()
            .map(|c| Vec3::from(c.map(srgb_to_linear)))
            .collect();
        let color = builder.vec3(&linear, false);
        gltf_meshes.push(json!({
            "name": layer.name,
            "primitives": [{
                "attributes": { "POSITION": position, "NORMAL": normal, "COLOR_0": color },
                "indices": indices,
                "material": usize::from(layer.room),
                "mode": 4,
            }],
        }));
        let (t, r) = trs(&layer.pose);
        nodes.push(json!({
            "name": layer.name,
            "mesh": gltf_meshes.len() - 1,
            "translation": t,
            "rotation": r,
        }));
    }
    let (t, r) = trs(&camera.gltf_pose());
    nodes.push(json!({ "name": "camera", "camera": 0, "translation": t, "rotation": r }));
    let half = std::f32::consts::FRAC_1_SQRT_2;
    nodes[0] = json!({
        "name": "room (z up)",
        "rotation": [-half, 0.0, 0.0, half],
        "children": (1..nodes.len()).collect::<Vec<_>>(),
    });
    let mut document = json!({
        "asset": { "version": "2.0", "generator": "neuroom" },
        "scene": 0,
        "scenes": [{ "name": "solved room", "nodes": [0] }],
        "nodes": nodes,
        "cameras": [{
            "name": "panorama camera",
            "type": "perspective",
            "perspective": {
                "yfov": camera.yfov,
                "aspectRatio": camera.aspect_ratio,
                "znear": 0.05,
                "zfar": 100.0,
            },
        }],
    });
    if !gltf_meshes.is_empty() {
        document["meshes"] = Value::Array(gltf_meshes);
        document["materials"] = json!([
            baked_radiance("objects: baked radiance", true),
            baked_radiance("room: baked radiance, seen from inside", false),
        ]);
        document["extensionsUsed"] = json!(["KHR_materials_unlit"]);
    }
    builder.finish(document)
}

/// An unlit material showing the vertex colours as they are: material 0 for the objects, 1 for the room.
fn baked_radiance(name: &str, double_sided: bool) -> Value {
    json!({
        "name": name,
        "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 1.0,
        },
        "doubleSided": double_sided,
        "extensions": { "KHR_materials_unlit": {} },
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::glb::split_glb;
    use crate::mesh::tiny_meshes;
    use neuroom_testing::tiny_arrangement;

    fn tiny_glb() -> (SceneMeshes, Vec<u8>) {
        let meshes = tiny_meshes(0.04, 0.15);
        let camera = ExportCamera::from_panorama(tiny_arrangement().camera_to_world);
        let bytes = room_glb(&meshes, &camera);
        (meshes, bytes)
    }

    #[test]
    fn accessors_match_the_meshes_and_the_buffer() {
        let (meshes, bytes) = tiny_glb();
        let (doc, bin) = split_glb(&bytes).unwrap();
        assert_eq!(doc["buffers"][0]["byteLength"], bin.len());
        let accessors = doc["accessors"].as_array().unwrap();
        let views = doc["bufferViews"].as_array().unwrap();
        for a in accessors {
            let view = &views[a["bufferView"].as_u64().unwrap() as usize];
            let width = if a["type"] == "VEC3" { 12 } else { 4 };
            assert_eq!(
                view["byteLength"].as_u64().unwrap(),
                a["count"].as_u64().unwrap() * width
            );
        }
        let mesh_nodes: Vec<&Value> = doc["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|n| n.get("mesh").is_some())
            .collect();
        assert_eq!(mesh_nodes.len(), meshes.layers.len());
        for (node, layer) in mesh_nodes.iter().zip(&meshes.layers) {
            assert_eq!(node["name"], layer.name.as_str());
            let prim = &doc["meshes"][node["mesh"].as_u64().unwrap() as usize]["primitives"][0];
            let pos = &accessors[prim["attributes"]["POSITION"].as_u64().unwrap() as usize];
            let g = &meshes.geometries[layer.geometry];
            assert_eq!(pos["count"], g.positions.len());
            let (lo, hi) = g.bounds().unwrap();
            // serde_json's default parser may be off by an ulp of f64: compare as f32.
            let as_f32 = |v: &Value| -> Vec<f32> {
                v.as_array()
                    .unwrap()
                    .iter()
                    .map(|x| x.as_f64().unwrap() as f32)
                    .collect()
            };
            assert_eq!(as_f32(&pos["min"]), lo.to_array());
            assert_eq!(as_f32(&pos["max"]), hi.to_array());
            let idx = &accessors[prim["indices"].as_u64().unwrap() as usize];
            assert_eq!(idx["count"], 3 * g.triangles.len());
        }
    }

    #[test]
    fn round_trips_through_the_gltf_crate() {
        let (meshes, bytes) = tiny_glb();
        let gltf = gltf::Gltf::from_slice(&bytes).expect("a valid glTF binary");
        let blob = gltf.blob.as_deref().expect("a BIN chunk");
        let document = &gltf.document;
        let scene = document.default_scene().unwrap();
        let root = scene.nodes().next().unwrap();
        assert_eq!(root.children().count(), meshes.layers.len() + 1);
        let mut placed = 0;
        for node in root.children() {
            if let Some(mesh) = node.mesh() {
                let layer = &meshes.layers[placed];
                placed += 1;
                let (t, r, _) = node.transform().decomposed();
                let pose = layer.pose;
                assert!((Vec3::from(t) - pose.translation.as_vec3()).length() < 1e-5);
                let q = glam::Quat::from_array(r);
                let expected = DQuat::from_mat3(&pose.rotation).as_quat();
                assert!(q.dot(expected).abs() > 1.0 - 1e-6);
                let prim = mesh.primitives().next().unwrap();
                assert_eq!(
                    prim.material().double_sided(),
                    !layer.room,
                    "only the room is seen from one side"
                );
                let reader = prim.reader(|_| Some(blob));
                let positions: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
                let g = &meshes.geometries[layer.geometry];
                assert_eq!(positions.len(), g.positions.len());
                assert_eq!(positions[0], g.positions[0].to_array());
                let indices: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
                assert_eq!(indices.len(), 3 * g.triangles.len());
                assert!(indices.iter().all(|&i| (i as usize) < positions.len()));
                let colors: Vec<[f32; 3]> = reader.read_colors(0).unwrap().into_rgb_f32().collect();
                let expected = layer.colors[0].map(srgb_to_linear);
                assert!((Vec3::from(colors[0]) - Vec3::from(expected)).length() < 1e-6);
            } else {
                let camera = node.camera().expect("the other child is the camera");
                assert!(matches!(
                    camera.projection(),
                    gltf::camera::Projection::Perspective(_)
                ));
            }
        }
        assert_eq!(placed, meshes.layers.len());
    }

    #[test]
    fn the_camera_looks_along_the_panorama_forward_axis() {
        let pose = Pose::from_yaw_translation(0.7, DVec3::new(1.0, 2.0, 1.5));
        let c = ExportCamera::from_panorama(pose).gltf_pose();
        let forward = c.transform_vector(-DVec3::Z);
        assert!((forward - pose.transform_vector(DVec3::X)).length() < 1e-12);
        assert!((c.transform_vector(DVec3::Y) - DVec3::Z).length() < 1e-12);
        assert!((c.rotation.determinant() - 1.0).abs() < 1e-12);
    }
}

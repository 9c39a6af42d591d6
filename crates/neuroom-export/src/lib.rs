//! What a solved room becomes outside the program: a glTF 2.0 binary of meshes extracted from the SDFs
//! with vertex colours under the solved lighting, animated GIFs of rendered sequences, a self-contained
//! HTML report with a top-down map and, with the `rerun` feature, a Rerun recording (`rrd`) of the same
//! meshes with the boxes, the camera and the panorama. It also holds the lighting state ([`lighting`])
//! that touring, relighting and exporting share: the fit's solved light codes and tones, trained codes by
//! name, and blends between them.
//!
//! ```no_run
//! use neuroom_export::mesh::{MeshDetail, scene_meshes};
//! use neuroom_export::room_gltf::{ExportCamera, room_glb};
//! let scene = neuroom_testing::tiny_scene();
//! let names = vec!["ball_1".to_string(), "ball_2".into(), "stool_3".into()];
//! let meshes = scene_meshes(&scene, &names, &MeshDetail::default());
//! let camera = ExportCamera::from_panorama(neuroom_testing::tiny_arrangement().camera_to_world);
//! std::fs::write("room.glb", room_glb(&meshes, &camera)).unwrap();
//! ```

pub mod animation;
pub mod glb;
pub mod lighting;
pub mod mesh;
pub mod report;
pub mod room_gltf;
#[cfg(feature = "rerun")]
pub mod rrd;
pub mod topdown;

//! The Khronos glTF validator on an exported room. Needs Node.js and the validator installed by
//! `npm install --prefix tools`; run with `cargo test -p neuroom-export -- --ignored`.

use std::path::Path;
use std::process::Command;

use neuroom_export::mesh::{MeshDetail, scene_meshes};
use neuroom_export::room_gltf::{ExportCamera, room_glb};
use neuroom_testing::{tiny_arrangement, tiny_scene};

#[test]
#[ignore = "needs node and `npm install --prefix tools`"]
fn an_exported_room_passes_the_khronos_validator() {
    let scene = tiny_scene();
    let arrangement = tiny_arrangement();
    let names: Vec<String> = arrangement.objects.iter().map(|o| o.name.clone()).collect();
    let detail = MeshDetail {
        object_cell_m: 0.03,
        room_cell_m: 0.1,
        ..MeshDetail::default()
    };
    let meshes = scene_meshes(&scene, &names, &detail);
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("tiny.glb");
    std::fs::write(
        &glb,
        room_glb(
            &meshes,
            &ExportCamera::from_panorama(arrangement.camera_to_world),
        ),
    )
    .unwrap();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tools/validate_gltf.mjs");
    let out = Command::new("node")
        .arg(&script)
        .arg(&glb)
        .output()
        .expect("node runs");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "validator failed: {report}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_str(report.trim()).unwrap();
    assert_eq!(v["errors"], 0, "{report}");
    assert_eq!(v["warnings"], 0, "{report}");
}

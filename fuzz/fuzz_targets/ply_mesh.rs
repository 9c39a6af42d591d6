//! PLY meshes: any bytes either parse into a mesh with finite vertices and in-range triangle indices, or
//! give an error naming the file.
#![no_main]

use libfuzzer_sys::fuzz_target;
use neuroom_core::mesh::parse_ply;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let file = Path::new("fuzz/mesh.ply");
    match parse_ply(file, data) {
        Ok(mesh) => {
            let n = mesh.positions.len();
            assert!(mesh.positions.iter().all(|p| p.is_finite()));
            assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
        }
        Err(e) => assert_eq!(e.path, file),
    }
});

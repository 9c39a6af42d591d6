//! Ground-truth mesh export as binary little-endian PLY (positions in metres and triangle faces),
//! which MeshLab, Open3D and trimesh read.

use std::path::Path;

use neuroom_core::FormatResult;
use neuroom_core::formats::atomic_write;

use crate::mesh::Mesh;

/// Encodes `mesh` as a binary PLY: `vertex` with float x, y, z and `face` with a uchar-counted
/// list of uint indices.
pub fn encode_ply(mesh: &Mesh) -> Vec<u8> {
    let header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment neuroom-synth ground truth, metres, canonical object frame\n\
         element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        mesh.positions.len(),
        mesh.triangles.len()
    );
    let mut out = header.into_bytes();
    out.reserve(mesh.positions.len() * 12 + mesh.triangles.len() * 13);
    for p in &mesh.positions {
        for c in p.to_array() {
            out.extend_from_slice(&c.to_le_bytes());
        }
    }
    for t in &mesh.triangles {
        out.push(3);
        for i in t {
            out.extend_from_slice(&i.to_le_bytes());
        }
    }
    out
}

/// Writes `mesh` to `path` as binary PLY, atomically.
pub fn write_ply(path: &Path, mesh: &Mesh) -> FormatResult<()> {
    atomic_write(path, &encode_ply(mesh))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn header_counts_and_payload_size() {
        let mut m = Mesh::default();
        m.add_box(Vec3::ZERO, Vec3::ONE, 0);
        let bytes = encode_ply(&m);
        let text = String::from_utf8_lossy(&bytes);
        let end = text.find("end_header\n").unwrap() + "end_header\n".len();
        assert!(text.contains("element vertex 24\n") && text.contains("element face 12\n"));
        assert_eq!(bytes.len() - end, 24 * 12 + 12 * 13);
        let x = f32::from_le_bytes(bytes[end + 12..end + 16].try_into().unwrap());
        assert_eq!(x, m.positions[1].x);
    }
}

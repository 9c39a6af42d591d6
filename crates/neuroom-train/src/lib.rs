//! The offline stage: learning one neural field per object and one for the empty room from RGB-D captures,
//! with lighting augmentation, and the geometry checks (mesh extraction, Chamfer distance) on the result.

pub mod lighting;
pub mod mesh_extract;

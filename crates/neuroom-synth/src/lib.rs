//! Ground-truth synthetic rooms for neuroom: procedural and OBJ furniture, room shells, lights, an
//! exact ray tracer (binned-SAH BVH per mesh plus a top-level BVH over instances), an arrangement
//! sampler that follows room logic, and writers for every file of `FORMAT.md`.

pub mod bvh;
pub mod material;
pub mod mesh;
pub mod scene;
pub mod texture;

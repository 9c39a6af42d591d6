//! Ground-truth synthetic rooms for neuroom: procedural and OBJ furniture, room shells, lights, an
//! exact ray tracer (binned-SAH BVH per mesh plus a top-level BVH over instances), an arrangement
//! sampler that follows room logic, and writers for every file of `docs/formats.md`.
//!
//! Entry point: [`generate()`] with a [`Preset`] (see [`PRESET_NAMES`]).

pub mod bench;
pub mod bvh;
pub mod catalog;
pub mod furniture;
pub mod generate;
pub mod illumination;
pub mod lighting;
pub mod material;
pub mod mesh;
pub mod obj;
pub mod phone;
pub mod ply;
pub mod preset;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod sh3d;
pub mod shell;
pub mod texture;
pub mod views;

pub use bench::{SynthBenchReport, bench_panorama};
pub use generate::{StageProgress, Summary, SynthError, generate};
pub use preset::{PRESET_NAMES, Preset};

//! neuroom as a library: the pipelines a Rust user (and the `neuroom` command) calls, each composing the
//! stage crates — core formats, synthetic rooms, training, perception and fitting — without the stages
//! importing one another.

pub mod baseline;
pub mod bench;
pub mod bench_fit;
pub mod bench_level;
pub mod bench_phone;
pub mod degrade;
pub mod demo;
pub mod edit;
pub mod eval;
pub mod export;
pub mod figures;
pub mod fit;
pub mod identify;
pub mod import;
pub mod inspect;
pub mod locate;
pub mod locate_photos;
pub mod masks;
pub mod overrides;
pub mod relight;
pub mod scene;
pub mod score;
mod staging;
pub mod suite;
pub mod synth;
pub mod tour;
pub mod train;
pub mod training_figures;
pub mod view;

pub use inspect::{RoomReport, inspect_room};
/// What a real camera does to a panorama (`neuroom bench locate --camera-effect`).
pub use neuroom_core::camera_effects::CameraEffect;
/// room.json, for callers that name objects (`neuroom bench locate --objects`).
pub use neuroom_core::formats::{Room, read_room};
/// The geometry, cameras, images and file formats the pipelines take and return, for callers
/// outside the workspace (the Python package).
pub use neuroom_core::{Pose, camera, formats, image};

//! The offline stage: learning one neural field per object and one for the empty room from RGB-D captures,
//! with lighting augmentation, and the geometry checks (mesh extraction, Chamfer distance) on the result.
//!
//! - [`dataset`]: rays, targets and pixel classes from a capture; [`normals`]: normals from depth.
//! - [`losses`]: colour, depth, mask, SDF-from-depth terms; [`trainer`]: the loop of one model, resumable.
//! - [`augment`] + [`lighting`]: HDR lighting augmentation and light codes.
//! - [`room`]: `train_room` and the model directory of a room with its reader; [`lanes`]: its models
//!   trained side by side.
//! - [`ray_choice`]: which rays a step trains on (uniform or guided by the colour error).
//! - [`frame_corrections`]: per-frame colour gains and pose corrections (phone captures).
//! - [`eval`]: held-out PSNR, depth error, Chamfer, light-code check; [`mod@bench`]: timed runs with reports.

pub mod augment;
pub mod bench;
pub mod config;
pub mod dataset;
mod draws;
pub mod eval;
pub mod frame_corrections;
pub mod lanes;
pub mod lighting;
pub mod losses;
pub mod normals;
pub mod progress;
pub mod ray_choice;
mod reuse;
pub mod rng;
pub mod room;
pub mod symmetry;
pub mod trainer;

pub use config::{BudgetClock, ModelBudget, ObjectStart, TrainConfig, UnobservedSamples};
pub use reuse::{NOISY_DEPTH_REVISION, TRAINING_REVISION};
pub use room::{
    MANIFEST_FILE, Manifest, ModelEntry, RoomModels, TrainError, TrainSummary, load_room_models,
    read_manifest, train_room,
};
pub use trainer::{ModelKind, Trainer};

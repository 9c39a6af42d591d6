//! Object identification for "Neural Rendering in a Room": a network that finds every known object in
//! a panorama and names its model, trained on panoramas composed from the trained room itself (the
//! paper's data augmentation), so the labels come for free.
//!
//! - [`compose`](mod@compose): training panoramas from the localization database's empty-room panoramas and the
//!   object models' surface clouds, under random light and tone, with per-pixel labels; [`place`] puts
//!   the objects where the room's rules allow (floor, wall, on a support, no collision).
//! - [`net`]: the small fully convolutional segmentation network (burn, pure-Rust CPU backend) over
//!   the panorama and the empty room at the same camera; [`infer`] runs it.
//! - [`train`](mod@train): weighted pixel-wise cross-entropy, Adam, a time budget, checkpoints to resume from.
//! - [`store`]: the network and the checkpoint on disk (safetensors, written atomically).
//! - [`detect`]: the network as a detector of named object regions, with a confidence threshold.

pub mod compose;
pub mod detect;
pub mod infer;
pub mod net;
pub mod place;
pub mod store;
pub mod train;

pub use compose::{ComposeConfig, RoomSource, Sample, compose};
pub use detect::{DetectConfig, DetectorView, NetworkDetector};
pub use net::NetConfig;
pub use store::{CHECKPOINT_FILE, NETWORK_FILE, Network};
pub use train::{TrainReport, TrainSettings, train};

/// What can go wrong building or reading the network.
#[derive(Debug, thiserror::Error)]
pub enum IdentifyError {
    /// A file is missing, unreadable or malformed (the message names it).
    #[error(transparent)]
    Format(#[from] neuroom_core::FormatError),
    /// The settings describe no network that can be built.
    #[error("{0}")]
    Config(String),
}

//! The base of neuroom: geometry, cameras, images, metrics and every on-disk format of `docs/formats.md`.
//!
//! Everything here is plain data and exact maths; nothing here learns or renders. Later crates build on
//! these types so that the conventions (z-up world, OpenGL pinhole frames, the equirectangular panorama
//! frame) live in exactly one place.

pub mod camera;
pub mod camera_effects;
pub mod depth_upsample;
pub mod error;
pub mod formats;
pub mod image;
pub mod mesh;
pub mod metrics;
pub mod nearest;
pub mod obb;
pub mod pose;
pub mod ray;
pub mod rotation6d;
pub mod sh;
pub mod stats;
pub mod surface;
pub mod winding;

pub use error::{FormatError, FormatResult};
pub use image::Image;
pub use pose::Pose;
pub use ray::Ray;

//! The trained room on the sphere, shared by the online stage (`neuroom-locate`) and the identification
//! network's training panoramas (`neuroom-identify`):
//!
//! - [`sphere`]: the equirectangular projection at any resolution, with its Jacobian and pixel
//!   neighbourhoods; [`plane`]: single-channel and colour panorama images (blur, area averaging,
//!   gradients).
//! - [`database`]: small colour + depth panoramas of the empty room rendered over its floor, stored beside
//!   the trained models.
//! - [`cloud`]: coloured surface points of a model, carved by what its captures saw through, splatted
//!   into a panorama as a cheap render; [`object_model`]: a model's clouds with its box and where it may
//!   stand.
//! - [`capture_shading`]: the light an object was captured under, by surface orientation, taken out of
//!   its cloud's colours.
//! - [`region`]: where a detector sees an object, and connected regions of a mask on the sphere.

pub mod capture_shading;
pub mod cloud;
pub mod database;
pub mod object_model;
pub mod plane;
pub mod region;
pub mod sphere;

pub use database::{DATABASE_FILE, Database, DatabaseConfig, DatabaseEntry, build_database};
pub use object_model::{ObjectModel, Support, without_capture_shading};
pub use region::Detection;

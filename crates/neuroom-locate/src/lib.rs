//! The online front end of "Neural Rendering in a Room": from a bare panorama and a trained room, the
//! panorama's camera and the objects' initial poses.
//!
//! - Camera localization ([`localize()`]): a [`database`] of small colour + depth panoramas rendered from
//!   the background model over the floor; headings by circular correlation of illumination-robust
//!   [`features`] ([`yaw`]); direct 6-DoF alignment ([`align`]) against database panoramas, then against
//!   keyframes rendered at the current estimate.
//! - Objects: [`shading`] (the empty room re-shaded to the panorama's lighting, by a gain that depends on
//!   the surface normal), [`evidence`] (where the panorama differs from that empty room; the
//!   [`evidence::Detector`] trait lets a learned detector replace it), [`cloud`] (coloured surface points
//!   of each model, projected as a cheap render), [`objects`] (pose hypotheses on the floor, on walls and
//!   on other objects, scored by render-and-compare, taken greedily), [`merge`] (the objects of several
//!   views of one arrangement as one list).
//! - Geometry helpers: [`plane`] (single-channel panorama images), [`sphere`] (the equirectangular
//!   projection with its Jacobian), [`sphere_image`] (the query on the sphere: a panorama, or a photo
//!   with its intrinsics warped onto it, with the pixels it saw).

pub mod align;
mod cell_smooth;
pub mod cloud;
pub mod database;
pub mod evidence;
pub mod features;
pub mod level;
pub mod local_light;
pub mod localize;
pub mod merge;
pub mod objects;
pub mod plane;
pub mod shading;
pub mod sphere;
pub mod sphere_image;
pub mod yaw;

pub use database::{DATABASE_FILE, Database, DatabaseConfig, build_database};
pub use localize::{CameraEstimate, LocalizeConfig, localize, render_background};
pub use sphere_image::{PANORAMA_FROM_PINHOLE, SphereImage};

//! The online front end of "Neural Rendering in a Room": from a bare panorama and a trained room, the
//! panorama's camera and the objects' initial poses. The room on the sphere (the localization database,
//! the objects' surface clouds, the projection) comes from `neuroom-panorama`.
//!
//! - Camera localization ([`localize()`]): headings against the database's panoramas by circular
//!   correlation of illumination-robust [`features`] ([`yaw`]); direct 6-DoF alignment ([`align`])
//!   against database panoramas, then against keyframes rendered at the current estimate; levelling
//!   from straight edges ([`level`]).
//! - Light: [`shading`] (the empty room re-shaded to the panorama's lighting, by a gain that depends on
//!   the surface normal) times a light at a point of the room ([`point_light`]) times a smooth field
//!   over the panorama ([`local_light`]).
//! - Objects: [`evidence`] (where the panorama differs from that empty room; the
//!   [`evidence::Detector`] trait is what a region detector implements), [`objects`] (pose hypotheses
//!   on the floor, on walls and on other objects, scored by render-and-compare, taken greedily),
//!   [`merge`] (the objects of several views of one arrangement as one list).
//! - Progress: [`stage`] (the stage of locating an image, reported as it starts).
//! - The query on the sphere: [`sphere_image`] (a panorama, or a photo with its intrinsics warped onto
//!   it, with the pixels it saw).

pub mod align;
mod cell_smooth;
pub mod evidence;
pub mod features;
mod lattice;
pub mod level;
pub mod local_light;
pub mod localize;
mod memo;
pub mod merge;
pub mod objects;
mod outline;
pub mod point_light;
pub mod shading;
pub mod sphere_image;
pub mod stage;
#[cfg(test)]
mod test_rooms;
pub mod yaw;

pub use localize::{CameraEstimate, LocalizeConfig, localize, render_background};
pub use sphere_image::{PANORAMA_FROM_PINHOLE, SphereImage};
pub use stage::LocateStage;

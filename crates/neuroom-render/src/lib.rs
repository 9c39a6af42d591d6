//! Rendering of signed-distance + radiance fields. So far: per-ray NeuS volume rendering, forward and
//! backward ([`volume`]), and where to put samples along a ray ([`sampling`]). Sphere tracing, multi-object
//! compositing with poses and image rendering for both camera kinds come next on top of these.

pub mod sampling;
pub mod volume;

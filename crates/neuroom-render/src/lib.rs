//! Rendering of signed-distance + radiance fields: a background and posed objects composited together
//! along world rays, forward and backward, as "Neural Rendering in a Room" needs for its holistic fit.
//!
//! - [`scene`]: the background, the models (fields shared by identical objects) and the posed instances
//!   with their codes and tone adjusters.
//! - [`renderer::Renderer`]: plan (culling [`cull`], sphere tracing [`trace`], sample placement, no
//!   gradient) → forward (field queries, [`composite`] of all fields by distance) → backward (to poses,
//!   tone adjusters and the fields' parameters, codes included).
//! - [`config`]: safe-region vs classical sampling and the per-pass cost ([`config::RenderStats`]).
//! - [`image`]: whole images (pinhole or panorama) with depth and instance ids.
//! - [`bench`](mod@bench): the paper's Table 3 — queries, memory and time per iteration, safe region vs classical.
//! - [`volume`], [`sampling`]: single-field NeuS volume rendering and sample placement, also used by the
//!   trainer.
//!
//! How a fit uses it, per iteration:
//! 1. Update the [`Scene`]'s object translations / 6D rotations / tones (and the fields' code rows).
//! 2. `renderer.config_mut().seed = iteration; let out = renderer.render(&scene, &rays);` (plan + forward).
//! 3. Compute the loss and its gradient `d_out[r]` with respect to each ray's [`volume::RayOutput`].
//! 4. `let g = renderer.backward(&scene, &d_out, &mut model_grads);` — `g.objects[k]` holds the pose and
//!    tone gradients of object `k`, `model_grads[m]` the parameter gradients of model `m` (its code rows:
//!    one row per instance that has its own code).
//!
//! Compositing rule (see [`composite`]): each field's intervals take their NeuS opacity from that field's
//! own consecutive samples; the intervals of all fields along a ray are sorted by midpoint and composited
//! front to back. The sample distances are fixed by the plan and not differentiated; nor is the NeuS
//! sharpness [`Model::inv_s`], which the fit does not change.

pub mod bench;
pub mod composite;
pub mod config;
pub mod cull;
pub mod image;
pub mod plan;
pub mod renderer;
pub mod sampling;
pub mod scene;
pub mod trace;
pub mod volume;

pub use config::{RenderConfig, RenderStats, Sampling};
pub use image::{RenderedShare, render_image, render_image_reporting};
pub use renderer::{ObjectGrad, Renderer, SceneGrad};
pub use scene::{Background, InstanceCodes, Model, Scene, SceneObject, Tone};
pub use trace::TraceConfig;

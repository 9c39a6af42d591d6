//! Holistic optimisation of "Neural Rendering in a Room": given a panorama, its camera and initial object
//! poses, solve for the poses, tone adjusters and light codes that explain it, under physical constraints,
//! by optimising through the compositional renderer ([`neuroom_render::Renderer`]).
//!
//! - [`fit()`]: the entry point (stage 1 poses, stage 2 lighting), with [`FitConfig`] and its ablation
//!   switches, returning a [`FitResult`] (solution, loss log, timings, before/after previews; its
//!   [`FitResult::report`] is the serialisable part).
//! - Losses, each a forward/backward pair with a finite-difference test: [`photometric`] (joint rendering
//!   vs pixels), [`observation`] (viewing directions), [`magnetic`] (relation contacts), [`alignment`]
//!   (backs square to their walls), [`violation`] (penetration of neighbours and the room), [`gravity`]
//!   (upright objects).
//! - Geometry they share: [`surface`] (surface points from the SDF zero set), [`probe`] (a target's SDF at
//!   posed points, backward to both poses), [`pose_grad`] (matrix-form pose gradients → 6D).
//! - [`relations`]: support and wall relations from rules and room.json hints; [`sampling`]: the
//!   object-mask and latitude-biased choice of pixels; [`optim`]: Adam over scalars; [`codes`]: the code
//!   rows a field exposes to stage 2; [`bench`](mod@bench): noisy initialisations and scores for `neuroom bench fit`.
//!
//! ```
//! use neuroom_fit::bench::analytic_room;
//! use neuroom_fit::{FitConfig, fit};
//!
//! let config = FitConfig { pose_iterations: 5, appearance_iterations: 2, ..FitConfig::default() };
//! // A room shell with two cuboids; its panorama rendered at the true poses.
//! let room = analytic_room(2, 100.0, 32, &config);
//! let init: Vec<_> = room.objects.iter().map(|o| o.truth.clone()).collect();
//! let result = fit(
//!     room.scene, &room.room, &room.panorama, &room.camera_to_world, &init, &config, &mut |_| {},
//! )
//! .unwrap();
//! assert_eq!(result.objects.len(), 2);
//! assert_eq!(result.log.len(), 7);
//! ```

pub mod alignment;
pub mod bench;
pub mod codes;
pub mod config;
pub mod fit;
pub mod gravity;
pub mod magnetic;
pub mod observation;
pub mod optim;
pub mod photometric;
pub mod pose_grad;
pub mod probe;
pub mod relations;
pub mod sampling;
pub mod search;
pub mod surface;
pub mod violation;

pub use codes::FitField;
pub use config::{AdaptSwitches, FitConfig, FitLossWeights, LossSwitches};
pub use fit::{
    FitError, FitReport, FitResult, FitTimings, FittedObject, FittedObjectReport, Fitter,
    IterationLog, ObjectInit, Stage, fit, render_panorama,
};
pub use relations::{Hint, Relation, RelationRules, RoomBox};
pub use search::PoseSearchConfig;

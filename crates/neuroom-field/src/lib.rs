//! Neural implicit fields with hand-written gradients: a multiresolution hash encoding, tiny MLPs, the
//! NeuS SDF + radiance field, the [`Field`] trait (also implemented by analytic fields), Adam and
//! checkpoints.
//!
//! How a trainer uses it:
//! 1. `let mut field = NeusField::<f32>::new(NeusConfig::object(half_extent));`
//!    `let mut grads = Params::zeros_like(&field.params); let mut adam = Adam::new(AdamConfig::default(), &field.params);`
//! 2. Per step: sample points along rays (object frame), `field.forward(&points, &dirs, &codes,
//!    Outputs::Full, &mut tape)`, read `tape.copy_sdf` / `copy_rgb`, render and compute the loss with
//!    `neuroom-render`, then `field.backward(&codes, &mut tape, &d_sdf, Some(&d_rgb), &mut grads, None)`,
//!    `field.backward_inv_s(d_inv_s, &mut grads)`, `field.eikonal(...)` and `adam.step(&mut field.params,
//!    &mut grads, &lrs)`, which leaves the gradients of the groups it moved zero for the next step.

pub mod adam;
pub mod batch;
pub mod bench;
pub mod checkpoint;
pub mod clock;
pub mod field;
pub mod hash;
pub mod health;
pub mod kernel;
pub mod mlp;
pub mod neus;
pub mod params;
pub mod real;
pub mod rng;
pub mod sh;

pub use adam::{Adam, AdamConfig, AdamUpdate, Schedule};
pub use batch::Tape;
pub use field::{AnalyticColor, AnalyticField, Field, FieldOutput, Query};
pub use neus::{CHUNK, CodeSet, Codes, GeometricInit, NeusConfig, NeusField, Outputs, Workspace};
pub use params::{Group, NUM_GROUPS, Params};
pub use real::Real;

//! The options that say how objects are looked for, shared by `locate`, `bench locate` and `fit`.

use neuroom::locate::{DetectorChoice, LocateConfig};

/// The light code objects are seen under.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct ObjectLightArgs {
    /// Light code (its name in the model manifest, e.g. `studio`) under which the objects are seen: the
    /// object search compares their colours under it and the fit starts their light codes from it; by
    /// default their first capture lighting. For objects captured under a light unlike the room's (on
    /// blender-lite the objects lit by a studio environment, the room by ceiling panels).
    #[arg(long)]
    pub object_light: Option<String>,
}

/// Which detector finds the object regions, and the light objects are seen under.
#[derive(clap::Args, Clone, Debug)]
pub(crate) struct SearchArgs {
    /// Detector of the object regions: `residual` (difference with the empty room), `network` (the
    /// identification network `neuroom train` stores beside the models), `named` (the residual's
    /// regions named by the network) or `auto` (the network when present).
    #[arg(long)]
    pub detector: Option<DetectorChoice>,
    #[command(flatten)]
    pub light: ObjectLightArgs,
}

impl SearchArgs {
    /// `config` with the detector and the object light these options name.
    pub fn apply(&self, config: LocateConfig) -> LocateConfig {
        LocateConfig {
            detection: self.detector.unwrap_or(config.detection),
            object_light: self.light.object_light.clone(),
            ..config
        }
    }
}

//! `--frame-corrections capture|always|never`: whether training learns a colour gain and a pose
//! correction per frame (`train`, `bench phone`).

use neuroom::train::RefineWhen;

/// Which per-frame corrections training learns, as the command line names them.
#[derive(Clone, Copy, Debug, Default, clap::ValueEnum)]
pub enum FrameCorrectionsArg {
    /// What each capture says its camera did (`auto_exposure`, `tracked_poses`).
    #[default]
    Capture,
    /// Colour gains and poses for every capture.
    Always,
    /// None: every frame as its capture gives it.
    Never,
}

impl From<FrameCorrectionsArg> for RefineWhen {
    fn from(a: FrameCorrectionsArg) -> Self {
        match a {
            FrameCorrectionsArg::Capture => RefineWhen::FromCapture,
            FrameCorrectionsArg::Always => RefineWhen::Always,
            FrameCorrectionsArg::Never => RefineWhen::Never,
        }
    }
}

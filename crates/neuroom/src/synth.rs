//! Synthetic ground-truth rooms, by preset name.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
pub use neuroom_synth::preset::CapturePlacement;
pub use neuroom_synth::{Preset, StageProgress, Summary};

/// Generates the room of preset `preset` (`tiny`, `bedroom`, `living`, `office`) into `out`.
/// With no `hdris`, the vendored maps light it. `placement` says where the objects stand while they
/// are captured (alone, or in the room for scans whose masks are made automatically).
pub fn synthesize(
    preset: &str,
    out: &Path,
    seed: u64,
    furniture: Option<&Path>,
    hdris: &[PathBuf],
    placement: CapturePlacement,
    progress: &mut dyn FnMut(StageProgress),
) -> anyhow::Result<Summary> {
    let mut preset = Preset::named(preset).with_context(|| {
        format!(
            "unknown preset `{preset}`; choose one of {}",
            neuroom_synth::PRESET_NAMES.join(", ")
        )
    })?;
    let hdris = if hdris.is_empty() {
        neuroom_train::augment::vendored_env_maps()
    } else {
        hdris.to_vec()
    };
    preset.object_capture.placement = placement;
    Ok(neuroom_synth::generate(
        &preset, out, seed, furniture, &hdris, progress,
    )?)
}

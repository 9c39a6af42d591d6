//! Synthetic ground-truth rooms, by preset name.

use std::path::{Path, PathBuf};

use anyhow::Context as _;
pub use neuroom_synth::{Preset, Progress, Summary};

/// The vendored CC0 environment maps (`assets/hdri/`), the default ambient light of synthetic rooms.
pub fn vendored_hdris() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets/hdri");
    let mut maps: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map(|entries| {
            entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "exr"))
                .collect()
        })
        .unwrap_or_default();
    maps.sort();
    maps
}

/// Generates the room of preset `preset` (`tiny`, `bedroom`, `living`, `office`) into `out`.
/// With no `hdris`, the vendored maps light it.
pub fn synthesize(
    preset: &str,
    out: &Path,
    seed: u64,
    furniture: Option<&Path>,
    hdris: &[PathBuf],
    progress: &mut dyn FnMut(Progress),
) -> anyhow::Result<Summary> {
    let preset = Preset::named(preset).with_context(|| {
        format!(
            "unknown preset `{preset}`; choose one of {}",
            neuroom_synth::PRESET_NAMES.join(", ")
        )
    })?;
    let hdris = if hdris.is_empty() {
        vendored_hdris()
    } else {
        hdris.to_vec()
    };
    Ok(neuroom_synth::generate(
        &preset, out, seed, furniture, &hdris, progress,
    )?)
}

//! Folders written whole or not at all: filled beside their target under a hidden name, then moved
//! into place once complete, so an interrupted run never leaves a folder that looks finished.

use std::path::{Path, PathBuf};

use anyhow::Context as _;

/// A folder being written beside its `target` (`.<name>.partial`).
pub(crate) struct StagedFolder {
    partial: PathBuf,
    target: PathBuf,
}

impl StagedFolder {
    /// Stages `target`, removing what an interrupted run left in its place.
    pub(crate) fn new(target: &Path) -> anyhow::Result<Self> {
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "folder".into());
        let partial = target.with_file_name(format!(".{name}.partial"));
        if partial.exists() {
            std::fs::remove_dir_all(&partial)
                .with_context(|| format!("{}: cannot remove", partial.display()))?;
        }
        Ok(Self {
            partial,
            target: target.to_path_buf(),
        })
    }

    /// Where to write meanwhile.
    pub(crate) fn path(&self) -> &Path {
        &self.partial
    }

    /// Moves the written folder into place.
    pub(crate) fn finish(self) -> anyhow::Result<()> {
        std::fs::rename(&self.partial, &self.target)
            .with_context(|| format!("{}: cannot move into place", self.target.display()))
    }
}

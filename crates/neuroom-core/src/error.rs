//! The error every reader returns: it names the file and the problem, so a user can fix their input.

use std::path::{Path, PathBuf};

/// A problem with one file on disk: which file, which field (if any), and what is wrong.
#[derive(Debug, thiserror::Error)]
#[error("{}: {}{message}", path.display(), field.as_deref().map(|f| format!("field `{f}`: ")).unwrap_or_default())]
pub struct FormatError {
    /// The file that was being read or written.
    pub path: PathBuf,
    /// The JSON field (dotted path such as `frames[3].transform_matrix`) or other part of the file at fault.
    pub field: Option<String>,
    /// What is wrong, in words a user understands.
    pub message: String,
}

impl FormatError {
    /// An error about the file as a whole (missing, unreadable, undecodable).
    pub fn file(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Self {
            path: path.as_ref().to_path_buf(),
            field: None,
            message: message.into(),
        }
    }

    /// An error about one field of the file.
    pub fn field(
        path: impl AsRef<Path>,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self {
            path: path.as_ref().to_path_buf(),
            field: Some(field.into()),
            message: message.into(),
        }
    }
}

/// Result of reading or writing a file.
pub type FormatResult<T> = Result<T, FormatError>;

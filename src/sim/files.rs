//! The one error every layer gives for a file it cannot read, create or write: the
//! path and what the system said, printed as one line (`cannot write out/report.json:
//! Permission denied (os error 13)`).

use std::path::{Path, PathBuf};

/// A file or folder that could not be read, created or written.
#[derive(Debug, thiserror::Error)]
#[error("cannot {action} {}: {source}", path.display())]
pub struct FileError {
    /// What was tried: `read`, `create` or `write`.
    pub action: &'static str,
    pub path: PathBuf,
    #[source]
    pub source: std::io::Error,
}

impl FileError {
    /// `path` could not be written.
    pub fn write(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Self {
            action: "write",
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    /// `path` could not be created.
    pub fn create(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Self {
            action: "create",
            path: path.as_ref().to_path_buf(),
            source,
        }
    }

    /// `path` could not be read.
    pub fn read(path: impl AsRef<Path>, source: std::io::Error) -> Self {
        Self {
            action: "read",
            path: path.as_ref().to_path_buf(),
            source,
        }
    }
}

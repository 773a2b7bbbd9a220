use std::path::PathBuf;

/// Why a mesh could not be read. Every variant names the file; text formats add the 1-based
/// line and column, binary PLY the byte offset, so a user can open the file at the spot.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    #[error("{path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}:{line}:{column}: {message}")]
    Text {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: byte offset {offset}: {message}")]
    Binary {
        path: PathBuf,
        offset: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    Invalid { path: PathBuf, message: String },
}

impl MeshError {
    pub(crate) fn text(
        path: &std::path::Path,
        line: usize,
        column: usize,
        message: impl Into<String>,
    ) -> Self {
        MeshError::Text {
            path: path.to_path_buf(),
            line,
            column,
            message: message.into(),
        }
    }

    pub(crate) fn invalid(path: &std::path::Path, message: impl Into<String>) -> Self {
        MeshError::Invalid {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

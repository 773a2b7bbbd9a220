use std::path::PathBuf;

/// Why a mesh could not be read. Every variant names the file; text formats add the 1-based
/// line and column, binary PLY the byte offset, so a user can open the file at the spot.
#[derive(Debug, thiserror::Error)]
pub enum MeshError {
    /// The file could not be read.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// A text format (OBJ, OFF, ASCII PLY) is wrong at one place.
    #[error("{path}:{line}:{column}: {message}")]
    Text {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// A binary PLY is wrong at one byte.
    #[error("{path}: byte offset {offset}: {message}")]
    Binary {
        /// The file.
        path: PathBuf,
        /// Offset from the start of the file.
        offset: usize,
        /// What is wrong there.
        message: String,
    },
    /// The file as a whole cannot be used (unknown format, no triangles, an index out of range).
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
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

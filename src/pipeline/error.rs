use std::path::PathBuf;

/// Why a pipeline call failed: the file it concerns where there is one, and the stage's own
/// error text (which carries line and column where the stage knows them).
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    /// A file or folder could not be read or written.
    #[error("cannot access {}: {error}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// An input file is not usable.
    #[error("{}: {message}", path.display())]
    Input {
        /// The file.
        path: PathBuf,
        /// Why, from the stage that read it.
        message: String,
    },
    /// The request itself cannot be carried out (parameters, an empty selection).
    #[error("{0}")]
    Invalid(String),
    /// A stage's own error, whose text already names the file (and line and column).
    #[error("{0}")]
    Stage(String),
}

impl PipelineError {
    /// An input error for `path` from any stage error.
    pub fn input(path: impl Into<PathBuf>, error: impl std::fmt::Display) -> PipelineError {
        PipelineError::Input {
            path: path.into(),
            message: error.to_string(),
        }
    }

    /// A stage's error, kept as its text (which names its file).
    pub fn stage(error: impl std::fmt::Display) -> PipelineError {
        PipelineError::Stage(error.to_string())
    }

    /// An I/O error on `path`.
    pub fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> PipelineError {
        let path = path.into();
        move |error| PipelineError::Io { path, error }
    }
}

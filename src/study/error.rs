use std::path::{Path, PathBuf};

/// Why a study (or the demo, a one-mesh study) could not run, or one of its steps failed.
/// A step's failure is logged in run.log and the study goes on with the other meshes; the
/// errors returned from [`run_study`](super::run_study) stop the whole run.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// study.toml cannot be used; the message gives line and column where TOML has them.
    #[error("{}: {message}", path.display())]
    Config {
        /// The study file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A mesh or the protocol changed after its video was shown to the subjects.
    #[error("{0}")]
    Changed(String),
    /// A file or folder could not be read, created or written.
    #[error("cannot {action} {}: {error}", path.display())]
    Io {
        /// `read`, `create`, `write`.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// A pipeline stage refused; its message names the file (and line and column).
    #[error("{0}")]
    Stage(String),
    /// The request cannot be carried out (recordings of one subject twice, no worker threads).
    #[error("{0}")]
    Invalid(String),
}

impl StudyError {
    /// An I/O error while doing `action` on `path`.
    pub fn io(
        action: &'static str,
        path: impl AsRef<Path>,
    ) -> impl FnOnce(std::io::Error) -> StudyError {
        let path = path.as_ref().to_path_buf();
        move |error| StudyError::Io {
            action,
            path,
            error,
        }
    }
}

/// A stage's error kept as its text in [`StudyError::Stage`].
pub(crate) trait OrStage<T> {
    fn or_stage(self) -> Result<T, StudyError>;
}

impl<T, E: std::fmt::Display> OrStage<T> for Result<T, E> {
    fn or_stage(self) -> Result<T, StudyError> {
        self.map_err(|e| StudyError::Stage(e.to_string()))
    }
}

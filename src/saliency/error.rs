use std::path::PathBuf;

/// Why a saliency map could not be computed, written or read.
#[derive(Debug, thiserror::Error)]
pub enum SaliencyError {
    /// The request cannot be carried out: an unknown method, a setting that does not apply,
    /// a parameter out of its range.
    #[error("{0}")]
    Invalid(String),
    /// The method could not compute a map of this mesh (no triangles, a degenerate surface,
    /// a model that does not fit the protocol).
    #[error("{0}")]
    Compute(String),
    /// The hold views could not frame the mesh (the centre prior).
    #[error("{0}")]
    Camera(#[from] crate::stimulus::camera::CameraError),
    /// The gaze model could not be applied.
    #[error("{0}")]
    GazeModel(#[from] crate::gaze_model::GazeModelError),
    /// A map file could not be used; the truth reader's message names its file, line and
    /// column.
    #[error("{0}")]
    Map(String),
    /// A file or folder could not be created or written.
    #[error("cannot {action} {}: {error}", path.display())]
    Io {
        /// `create`, `write`.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
}

impl SaliencyError {
    /// An I/O error while doing `action` on `path`.
    pub fn io(
        action: &'static str,
        path: impl Into<PathBuf>,
    ) -> impl FnOnce(std::io::Error) -> SaliencyError {
        let path = path.into();
        move |error| SaliencyError::Io {
            action,
            path,
            error,
        }
    }
}

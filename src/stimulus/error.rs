use std::path::PathBuf;

/// Why a stimulus could not be rendered. Loading a rendered stimulus back has its own error,
/// [`StimulusLoadError`](super::load::StimulusLoadError), whose variants say which file changed.
#[derive(Debug, thiserror::Error)]
pub enum StimulusError {
    /// A file or folder could not be created, written or hashed.
    #[error("{}: {error}", path.display())]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// No camera plan fits this mesh under this protocol (an empty or degenerate mesh, a
    /// protocol whose views cannot frame it).
    #[error("{0}")]
    Camera(#[from] crate::stimulus::camera::CameraError),
    /// Rendering, encoding or writing the video or a frame image failed; the message names
    /// the file.
    #[error("{0}")]
    Video(#[from] crate::stimulus::VideoError),
    /// The manifest could not be serialized.
    #[error("the stimulus manifest: {0}")]
    Manifest(String),
}

impl StimulusError {
    /// An I/O error on `path`.
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> StimulusError {
        let path = path.into();
        move |error| StimulusError::Io { path, error }
    }
}

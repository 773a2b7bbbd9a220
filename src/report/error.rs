use std::path::PathBuf;

/// Why a report, chart, page or figure could not be made. The I/O variant names the file and
/// what was being done to it; a table row that cannot be used names the file and its line.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file or folder could not be read, listed, created or written.
    #[error("cannot {action} {}: {error}", path.display())]
    Io {
        /// `read`, `write`, `list`, `create`.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// A row of an input table (a study's scores, chance draws, quality) cannot be used.
    #[error("{}: line {line}: {message}", path.display())]
    Table {
        /// The table.
        path: PathBuf,
        /// 1-based line in the file, the header being line 1.
        line: usize,
        /// What is wrong with the row.
        message: String,
    },
    /// A chart, render or figure could not be drawn or encoded.
    #[error("{0}")]
    Chart(String),
    /// The request cannot be carried out (two maps of one name, a stimulus of another mesh).
    #[error("{0}")]
    Invalid(String),
    /// Another part of the library refused (an input it reads, an output folder it makes);
    /// its message names the file.
    #[error("{0}")]
    Stage(String),
    /// No camera plan frames a mesh to draw.
    #[error("{0}")]
    Camera(#[from] crate::stimulus::camera::CameraError),
    /// The chance band of the mean over meshes could not be formed.
    #[error("{0}")]
    Score(#[from] crate::scoring::ScoreError),
    /// Formatting the page text failed (writing into a `String` does not fail in practice).
    #[error("formatting the page failed")]
    Format(#[from] std::fmt::Error),
}

impl ReportError {
    /// An I/O error while doing `action` on `path`.
    pub fn io(
        action: &'static str,
        path: impl Into<PathBuf>,
    ) -> impl FnOnce(std::io::Error) -> ReportError {
        let path = path.into();
        move |error| ReportError::Io {
            action,
            path,
            error,
        }
    }

    /// Another part's error, kept as its message (which names the file).
    pub fn stage(error: impl std::fmt::Display) -> ReportError {
        ReportError::Stage(error.to_string())
    }

    /// A drawing or encoding error.
    pub fn chart(error: impl std::fmt::Display) -> ReportError {
        ReportError::Chart(error.to_string())
    }
}

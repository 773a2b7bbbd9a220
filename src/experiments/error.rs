use std::path::PathBuf;

use crate::gaze_model::{FeatureError, GazeModelError};
use crate::saliency::SaliencyError;
use crate::stimulus::camera::CameraError;

/// Why an experiment (robustness, feature points, the gaze model's cross-validation) could
/// not run, or one of its input files could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ExperimentError {
    /// A file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// A line of a marks or categories file is not what the format allows.
    #[error("{name}:{line}:{column}: {message}")]
    At {
        /// The file (or the label it was given).
        name: String,
        /// 1-based line.
        line: usize,
        /// 1-based column (in characters).
        column: usize,
        /// What is wrong.
        message: String,
    },
    /// A file as a whole cannot be used (no usable line).
    #[error("{name}: {message}")]
    File {
        /// The file (or its label).
        name: String,
        /// Why.
        message: String,
    },
    /// The request cannot be carried out (a damage that leaves nothing, a step out of range,
    /// objects without a category).
    #[error("{0}")]
    Invalid(String),
    /// A method failed on one held-out mesh.
    #[error("{what}: {error}")]
    Method {
        /// The mesh and the method.
        what: String,
        /// Why.
        error: SaliencyError,
    },
    /// A saliency map could not be computed.
    #[error("{0}")]
    Saliency(#[from] SaliencyError),
    /// A mesh's gaze-model features could not be computed.
    #[error("{0}")]
    Feature(#[from] FeatureError),
    /// A mesh's hold views could not be framed.
    #[error("{0}")]
    Camera(#[from] CameraError),
    /// A fold's model could not be trained.
    #[error("{0}")]
    GazeModel(#[from] GazeModelError),
}

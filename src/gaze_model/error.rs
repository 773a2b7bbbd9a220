use std::path::PathBuf;

use crate::stimulus::camera::CameraError;

/// Why a point set's features could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum FeatureError {
    /// The point set is empty.
    #[error("no points")]
    NoPoints,
    /// Every point is at the centre (or a coordinate is not a number).
    #[error("the points have no extent")]
    NoExtent,
    /// The hold views could not frame the points.
    #[error("{0}")]
    Camera(#[from] CameraError),
}

/// Why a gaze model could not be trained, read or applied.
#[derive(Debug, thiserror::Error)]
pub enum GazeModelError {
    /// A file could not be read.
    #[error("cannot read {}: {error}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// A gaze-point file could not be read (its reader names file, line and column).
    #[error("{0}")]
    Points(String),
    /// Features of a training object or of the points to predict.
    #[error("{what}: {error}")]
    Features {
        /// The object (its file or name).
        what: String,
        /// Why its features could not be computed.
        error: FeatureError,
    },
    /// Features of the points to predict.
    #[error("{0}")]
    Feature(#[from] FeatureError),
    /// The inputs cannot train a model (no labels, a map of another length, an unknown
    /// feature to leave out, a non-positive dataset weight, features of another version).
    #[error("{0}")]
    Invalid(String),
    /// A model file is not one this build reads (not JSON of a model, another format or
    /// feature set).
    #[error("{0}")]
    Model(String),
    /// The boosted trees refused their inputs.
    #[error("{0}")]
    Trees(#[from] TreesError),
}

/// Why the boosted trees could not be trained.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TreesError {
    /// Columns, labels and weights of different lengths.
    #[error("the feature columns, labels and weights must have one entry per row")]
    Lengths,
    /// A histogram bin count outside 2..=255.
    #[error("bins must be 2..=255, not {0}")]
    Bins(usize),
    /// A feature value is NaN or infinite.
    #[error("a feature value is not finite")]
    NotFinite,
    /// Every label is the same.
    #[error("the labels need both positives and negatives")]
    OneClass,
}

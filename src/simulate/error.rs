use std::path::PathBuf;

/// Why virtual observers could not be simulated or their recordings written.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// A saliency map to look at does not have one value per vertex.
    #[error("the saliency map has {values} values but the mesh has {vertices} vertices")]
    MapLength {
        /// Values in the map.
        values: usize,
        /// Vertices of the mesh.
        vertices: usize,
    },
    /// A target vertex is not a vertex of the mesh.
    #[error("target vertex {vertex} is out of range: the mesh has {vertices} vertices")]
    TargetOutOfRange {
        /// The vertex given.
        vertex: usize,
        /// Vertices of the mesh.
        vertices: usize,
    },
    /// The output folder could not be made (the message names it).
    #[error("{0}")]
    OutputFolder(String),
    /// A file could not be created or written.
    #[error("cannot {action} {}: {error}", path.display())]
    Io {
        /// `create`, `write`.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// targets.csv could not be written.
    #[error("{0}")]
    Csv(#[from] csv::Error),
    /// simulate.json could not be serialized.
    #[error("{0}")]
    Json(#[from] serde_json::Error),
}

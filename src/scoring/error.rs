/// Why a mesh could not be scored, or a blur or chance band not computed.
#[derive(Debug, thiserror::Error)]
pub enum ScoreError {
    /// The blur grid's bounds are unusable (a non-positive step, or more than 10,000 widths).
    #[error("--blur-step must be positive and --blur-max / --blur-step at most 10000")]
    BlurGrid,
    /// The heat kernel's operator could not be assembled or factored at this σ_b.
    #[error("{0}")]
    HeatOperator(String),
    /// The inputs do not fit together (visibility flags of another length, no chance map).
    #[error("{0}")]
    Invalid(&'static str),
    /// Meshes whose chance draws are averaged were scored over different blur grids or chance
    /// map counts.
    #[error("meshes were scored over different blur grids or chance map counts")]
    MismatchedBands,
}

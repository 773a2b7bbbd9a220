//! The commands' pipelines as library calls: each loads its inputs, runs the stages in order
//! and writes the same files the command writes, returning what the command prints. The CLI
//! parses arguments into these parameters and prints; other Rust code calls them the same way.
mod error;
pub mod feature_points;
pub mod score_dataset;
pub mod training_data;

pub use error::PipelineError;

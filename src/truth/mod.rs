//! Human ground truth for scoring, in the formats documented in docs/ground-truth-format.md:
//! a per-vertex map (one value per vertex, optionally with a 0/1 "fixated" flag, as in the
//! `time bin` files of the VR dataset), or a fixation set (CSV with `subject` and `vertex`
//! columns, one row per fixation, as `meshgaze truth` writes).
pub(crate) mod build;
mod density_file;
mod error;
mod face_map;
mod fixation_truth;
mod read_truth_file;
mod text_table;

pub use build::{
    build_truth, projected_file, read_projections, write_truth, Projections, TruthBuildError,
    TruthParams, TruthResult,
};
pub use density_file::read_density;
pub use error::TruthError;
pub use face_map::{face_values_to_vertices, load_ground_truth_on, TruthLayout};
pub use fixation_truth::fixation_truth_from_rows;
pub use read_truth_file::{load_ground_truth, vertex_truth_from_values, TruthValueError};

pub use crate::scoring::ground_truth::{Fixation, FixationTruth, GroundTruth, VertexTruth};

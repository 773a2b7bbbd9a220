//! Timing of the pipeline's costly steps, as `meshgaze bench` reports them: SMS and its
//! competitors at the paper's settings against the paper's Table 3, scoring a mesh the way a
//! study does, the gaze model's feature groups, the stimulus render, and the SMI parser. Each measurement is a function on
//! plain data; [`run_cell_in_child`] runs one in a process of its own so its peak memory is
//! its own.
mod gaze_features_cell;
mod memory;
mod scoring_cell;
mod smi_parse;
mod stimulus_cell;
mod table3;

pub use gaze_features_cell::{gaze_features_cell, GazeFeaturesCell};
pub use memory::peak_rss_mb;
pub use scoring_cell::{scoring_cell, ScoringCell};
pub use smi_parse::{
    eyelink_parse_speed, smi_parse_speed, table_parse_speeds, ParseSpeed, PARSE_RUNS,
};
pub use stimulus_cell::{stimulus_cell, StimulusCell};
pub use table3::{
    load_case, paper_case, run_case, run_cell_in_child, CaseResult, PaperCase, COMPETITORS,
    PAPER_CASES,
};

use std::path::PathBuf;

/// Why a timing could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum TimingError {
    /// A bench mesh or data file is missing or unreadable.
    #[error("cannot read {}: {message}", path.display())]
    Input {
        /// The file that could not be used.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// The case name is not one of [`PAPER_CASES`].
    #[error(
        "no bench case `{0}`: the cases are bunny-35k, horse-48k, igea-134k, armadillo-subdivided"
    )]
    UnknownCase(String),
    /// The measured step itself failed.
    #[error("{step} failed: {message}")]
    Step {
        /// Which step (method, case, render).
        step: String,
        /// Its error.
        message: String,
    },
    /// A child process could not be run or printed no result.
    #[error("{what}: {message}")]
    Child {
        /// The cell the child was measuring.
        what: String,
        /// The failure, with the child's standard error.
        message: String,
    },
}

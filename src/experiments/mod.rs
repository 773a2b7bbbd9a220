//! The paper's experiments beyond scoring: robustness to corruption (Fig. 8), feature points
//! with the Dutagaci et al. 2012 benchmark (§5.5), and the timings `meshgaze bench` reports.
//! May import every stage below it in the order of ARCHITECTURE.md.
pub mod corruption;
mod error;
pub mod features;
pub mod gaze_model_cross_validation;
pub mod robustness;
pub mod timing;

pub use error::ExperimentError;

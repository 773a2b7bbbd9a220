//! What a person looks at: the HTML reports, line charts and coloured renders of per-vertex
//! maps. May import every library stage (it shows their results); no stage imports it.
pub mod cross_validation_report;
pub mod demo_report;
mod error;
pub mod html;
pub mod map_render;
pub mod mesh_page;
pub mod plot;
pub mod robustness_report;
pub mod score_plots;
pub mod study_report;
pub mod viewer;
pub mod viewer_files;

pub use error::ReportError;

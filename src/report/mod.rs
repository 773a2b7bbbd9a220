//! What a person looks at: the HTML reports, line charts and coloured renders of per-vertex
//! maps. May import every library stage (it shows their results); no stage imports it.
pub mod cross_validation_report;
pub(crate) mod demo_report;
mod error;
pub mod html;
pub(crate) mod map_render;
pub(crate) mod mesh_page;
pub(crate) mod plot;
pub mod robustness_report;
pub(crate) mod score_plots;
pub(crate) mod study_report;
pub mod viewer;
pub mod viewer_files;

pub use error::ReportError;

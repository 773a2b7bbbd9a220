//! meshgaze: build and validate 3D eye-fixation datasets on polygon meshes, with a fast
//! sparse metric-based mesh saliency core (Hu et al., "Sparse metric-based mesh saliency",
//! Neurocomputing 2020).
//!
//! The modules follow the pipeline, ground floor first (ARCHITECTURE.md gives the import
//! order a test holds them to): [`protocol`] (what an experiment fixes), [`mesh`] I/O and
//! geometry, [`stimulus`] rendering, [`gaze`] recordings and fixations, [`projection`] onto
//! the mesh, [`simulate`]d observers, [`scoring`] against human truth, [`truth`] building,
//! the learned [`gaze_model`], the [`saliency`] methods, the paper's [`experiments`],
//! [`report`]s and whole [`study`]s, with the [`provenance`] every output carries.
//!
//! The calls most users need are re-exported here. Compute the paper's method on a mesh and
//! score it against a human fixation set:
//!
//! ```
//! use meshgaze::{compute_saliency, load_ground_truth, load_mesh, score_mesh};
//! use meshgaze::{Method, ScoreParams, Silent, SmsParams};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
//!     .join("stimuli/meshes/bun_zipper_res3.ply");
//! let (mesh, _load_report) = load_mesh(&path)?;
//! let sms = compute_saliency(Method::Sms, &mesh, &SmsParams::default(), &Silent)?;
//! assert_eq!(sms.values.len(), mesh.positions.len());
//!
//! // A fixation set: one row per fixation, the vertex each subject looked at (the format
//! // `meshgaze truth` writes as truth.csv).
//! let truth_csv = std::env::temp_dir().join(format!("meshgaze-doc-{}.csv", std::process::id()));
//! std::fs::write(&truth_csv, "subject,vertex\ns01,10\ns01,500\ns02,12\ns02,900\n")?;
//! let truth = load_ground_truth(&truth_csv, mesh.positions.len(), 0.05)?;
//!
//! let params = ScoreParams { blur_sigmas: vec![0.0, 0.05], ..ScoreParams::default() };
//! let maps = vec![("sms".to_string(), sms.values)];
//! let score = score_mesh(&mesh, &truth, &maps, &params, None, &Silent)?;
//! let auc = score.summaries[0].auc_judd_unblurred;
//! assert!((0.0..=1.0).contains(&auc));
//! # std::fs::remove_file(&truth_csv)?;
//! # Ok(())
//! # }
//! ```
//!
//! With `default-features = false` the crate builds without the command line (no clap, no
//! progress bars).

// Every public item says what it is: a library user reads these pages, not the source.
#![deny(missing_docs)]

pub mod experiments;
pub mod file_bytes;
pub mod gaze;
pub mod gaze_model;
pub mod mesh;
pub mod pipeline;
pub mod progress;
pub mod projection;
pub mod protocol;
pub mod provenance;
pub(crate) mod random;
pub mod report;
pub mod saliency;
pub mod scoring;
pub mod simulate;
pub mod stimulus;
pub mod study;
pub(crate) mod total_order_key;
pub mod truth;

pub use mesh::{load_mesh, Mesh, MeshError};
pub use progress::{Progress, Silent};
pub use protocol::Protocol;
pub use saliency::{compute_saliency, Method, SmsParams, PAPER_METHODS};
pub use scoring::{score_mesh, MeshScore, ScoreParams};
pub use truth::{load_ground_truth, GroundTruth, TruthError};

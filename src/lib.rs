//! meshgaze: build and validate 3D eye-fixation datasets on polygon meshes, with a fast
//! sparse metric-based mesh saliency core (Hu et al., Neurocomputing 2020).
//!
//! The modules follow the pipeline (see ARCHITECTURE.md): [`mesh`] I/O and geometry,
//! [`stimulus`] rendering, [`gaze`] recordings and fixations, [`projection`] onto the mesh,
//! [`truth`] per-mesh ground truth, [`saliency`] methods, [`scoring`] against the truth,
//! [`experiments`], [`simulate`]d observers and [`report`]s, with the [`provenance`] every
//! output carries.

pub mod experiments;
pub mod file_bytes;
pub mod gaze;
pub mod gaze_model;
pub mod mesh;
pub mod progress;
pub mod projection;
pub mod protocol;
pub mod provenance;
pub mod report;
pub mod saliency;
pub mod scoring;
pub mod simulate;
pub mod stimulus;
pub mod study;
pub mod truth;

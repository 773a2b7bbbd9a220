//! meshgaze: build and validate 3D eye-fixation datasets on polygon meshes, with a fast
//! sparse metric-based mesh saliency core (Hu et al., Neurocomputing 2020).
//!
//! The modules follow the pipeline: [`mesh`] I/O, [`geometry`] helpers, surface
//! [`sampling`], shape [`descriptors`], [`saliency`] methods, [`metrics`], and the
//! [`provenance`] every output carries.

pub mod corruption;
pub mod descriptors;
pub mod features;
pub mod file_bytes;
pub mod gaze;
pub mod geometry;
pub mod ground_truth;
pub mod mean_curvature;
pub mod mesh;
pub mod metrics;
pub mod plot;
pub mod progress;
pub mod projection;
pub mod provenance;
pub mod robustness;
pub mod saliency;
pub mod sampling;
pub mod scoring;
pub mod simplification;
pub mod simulate;
pub mod stimulus;

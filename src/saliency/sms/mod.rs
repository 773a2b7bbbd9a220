//! The paper's method, sparse metric-based saliency (Hu et al. 2020), step by step: a distance
//! field and harmonic shape descriptors on random surface samples, a global descriptor metric,
//! its sparse leading eigenvector by the truncated power method, and Gaussian interpolation back
//! to the vertices. May import `mesh`, `progress`; nothing above it.
pub mod descriptor_metric;
pub mod descriptors;
pub mod gaussian_interpolation;
pub mod sparse_metric_saliency;
pub mod truncated_power;

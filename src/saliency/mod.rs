//! Saliency methods: each computes one value per input vertex.
pub mod descriptor_metric;
pub mod gaussian_interpolation;
pub mod lee_mesh_saliency;
pub mod mean_curvature_saliency;
pub mod method;
pub mod sparse_metric_saliency;
pub mod spectral_irregularity;
pub mod truncated_power;

pub use method::{compute_saliency, Method, MethodOutput};
pub use sparse_metric_saliency::{
    descriptors_at, sparse_metric_saliency, FieldKind, SmsExtras, SmsParams, SmsResult,
};

//! Saliency methods: each computes one value per input vertex.
pub mod descriptor_metric;
pub mod gaussian_interpolation;
pub mod sparse_metric_saliency;
pub mod truncated_power;

pub use sparse_metric_saliency::{
    descriptors_at, sparse_metric_saliency, FieldKind, SmsExtras, SmsParams, SmsResult,
};

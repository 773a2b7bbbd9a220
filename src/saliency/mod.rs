//! Saliency methods: each computes one value per input vertex.
mod error;
pub mod laplacian_spectrum;
pub mod lee_mesh_saliency;
pub mod map_file;
pub(crate) mod mean_curvature_saliency;
pub mod method;
pub mod point_cloud;
pub mod rarity;
pub mod sms;
pub mod spectral_irregularity;
pub mod view_priors;

pub use error::SaliencyError;
pub use method::{
    compute_saliency, compute_saliency_side_by_side, compute_saliency_viewed, Method, MethodOutput,
    RarityParams, Viewing, PAPER_METHODS,
};
pub use sms::sparse_metric_saliency::{
    descriptors_at, sparse_metric_saliency, FieldKind, SmsExtras, SmsParams, SmsResult,
};

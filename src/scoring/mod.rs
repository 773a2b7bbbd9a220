//! Measures on saliency maps: sparsity, and agreement with human ground truth.
pub mod auc;
pub(crate) mod cut_gaussian_sums;
pub mod dataset;
pub(crate) mod error;
pub(crate) mod exp_of_nonpositive;
pub mod gini;
pub(crate) mod ground_truth;
pub(crate) mod lattice_gauss_transform;
pub(crate) mod map_agreement;
pub mod mesh_score;
pub mod surface_blur;

pub use auc::{auc_borji, auc_judd};
pub use error::ScoreError;
pub use gini::{gini_index, lorenz_curve};
pub use map_agreement::{kl_divergence, lcc, nss, sim};

pub use mesh_score::*;

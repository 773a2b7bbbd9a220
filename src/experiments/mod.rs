//! The paper's experiments beyond scoring: robustness to corruption (Fig. 8) and feature points
//! with the Dutagaci et al. 2012 benchmark (§5.5). May import `mesh`, `saliency`, `scoring`.
pub mod corruption;
pub mod features;
pub mod gaze_model_cross_validation;
pub mod robustness;

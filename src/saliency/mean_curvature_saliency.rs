//! "MC": saliency as the magnitude of mean curvature (the paper's baseline [51]), with the
//! cotangent estimator of Meyer et al. 2003 and no smoothing; rescaled to [0, 1].
use super::sms::gaussian_interpolation::min_max_normalize;
use crate::mesh::mean_curvature::{mean_curvature, CurvatureReport};
use crate::mesh::Mesh;

pub fn mean_curvature_saliency(mesh: &Mesh) -> (Vec<f64>, CurvatureReport) {
    let (h, report) = mean_curvature(mesh);
    let mut s: Vec<f64> = h.iter().map(|v| v.abs()).collect();
    min_max_normalize(&mut s);
    (s, report)
}

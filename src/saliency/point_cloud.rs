//! Saliency of a point cloud with normals (no triangles): only the methods that need no
//! connectivity, the learned gaze model and the two view priors.
use crate::gaze_model::features::up_and_front;
use crate::gaze_model::surface_points::SurfacePoints;
use crate::gaze_model::view_visibility::view_exposure;
use crate::saliency::sms::gaussian_interpolation::min_max_normalize;
use crate::saliency::{Method, SaliencyError, Viewing};

/// One value per point, in input order, rescaled to [0, 1]; an error naming the method when it
/// needs a surface.
pub fn point_cloud_saliency(
    points: &SurfacePoints,
    method: Method,
    viewing: &Viewing,
) -> Result<Vec<f64>, SaliencyError> {
    let mut values = match method {
        Method::Gaze => viewing.gaze_model().predict(points, &viewing.protocol)?,
        Method::Up => {
            let (up, _) = up_and_front(&viewing.protocol);
            points.positions.iter().map(|p| p.dot(up)).collect()
        }
        Method::Centre => view_exposure(points, &viewing.protocol)?.centre_closeness,
        other => {
            return Err(SaliencyError::Invalid(format!(
                "a point cloud (no triangles) can be given to --method gaze, up or centre; `{}` needs a mesh's surface",
                other.name()
            )))
        }
    };
    min_max_normalize(&mut values);
    Ok(values)
}

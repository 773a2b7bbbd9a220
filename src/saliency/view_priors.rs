//! Priors that know nothing of shape detail, only how the object is placed and shown: the
//! baselines a method must beat before it claims to predict gaze.
use glam::DVec3;

use super::sms::gaussian_interpolation::min_max_normalize;
use crate::gaze_model::features::up_and_front;
use crate::mesh::Mesh;
use crate::protocol::Protocol;
use crate::stimulus::camera::CameraError;
use crate::stimulus::hold_views::hold_view_exposure;

/// Height along the protocol's up axis, scaled to [0, 1] over the mesh.
pub fn up_prior(mesh: &Mesh, protocol: &Protocol) -> Vec<f64> {
    let (up, _) = up_and_front(protocol);
    let mut values: Vec<f64> = mesh.positions.iter().map(|p: &DVec3| p.dot(up)).collect();
    min_max_normalize(&mut values);
    values
}

/// Each vertex's mean closeness to the screen centre over the hold views that show it (the
/// 3D analogue of the 2D centre-bias map); 0 for vertices no view shows.
pub fn centre_prior(mesh: &Mesh, protocol: &Protocol) -> Result<Vec<f64>, CameraError> {
    let mut values = hold_view_exposure(mesh, protocol)?.centre_closeness;
    min_max_normalize(&mut values);
    Ok(values)
}

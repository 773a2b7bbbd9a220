use std::path::Path;
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::TimingError;
use crate::gaze_model::features::point_features_timed;
use crate::gaze_model::surface_points::SurfacePoints;
use crate::gaze_model::GazeModel;
use crate::mesh::load_mesh;
use crate::Protocol;

/// What predicting one mesh with the gaze model costs, by feature group.
#[derive(Debug, Serialize, Deserialize)]
pub struct GazeFeaturesCell {
    /// Vertices of the mesh.
    pub vertices: usize,
    /// (group, seconds) in the order they are computed.
    pub groups: Vec<(String, f64)>,
    /// The boosted trees over the features.
    pub predict_s: f64,
}

/// The 20k-vertex VR bunny (fixations-vr/meshes/bunny.obj.gz) predicted by the built-in
/// model under the built-in protocol: each feature group timed on its own, then the trees.
pub fn gaze_features_cell(data: &Path) -> Result<GazeFeaturesCell, TimingError> {
    let path = data.join("fixations-vr/meshes/bunny.obj.gz");
    let (mesh, _) = load_mesh(&path).map_err(|e| TimingError::Input {
        path: path.clone(),
        message: e.to_string(),
    })?;
    let (protocol, _) = Protocol::builtin();
    let points = SurfacePoints::of_mesh(&mesh);
    let mut groups = Vec::new();
    let features = point_features_timed(&points, &protocol, &mut |g, s| {
        groups.push((g.to_string(), s))
    })
    .map_err(|e| TimingError::Step {
        step: "gaze features".into(),
        message: e.to_string(),
    })?;
    let model = GazeModel::builtin();
    let clock = Instant::now();
    let predicted = model.predict_features(&features);
    let predict_s = clock.elapsed().as_secs_f64();
    debug_assert_eq!(predicted.len(), mesh.positions.len());
    Ok(GazeFeaturesCell {
        vertices: mesh.positions.len(),
        groups,
        predict_s,
    })
}

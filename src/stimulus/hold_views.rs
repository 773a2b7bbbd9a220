//! What the stimulus's hold views show of a mesh, vertex by vertex: in how many of them the
//! vertex is on screen and unoccluded, and how close to the screen centre it appears there.
//! Scoring uses it to leave never-shown vertices out of the negatives; the `centre` prior is
//! its closeness.
use glam::DVec3;

use super::camera::{CameraError, CameraPlan};
use super::raster::{Rasterizer, BACKGROUND_ID};
use crate::mesh::Mesh;
use crate::protocol::Protocol;

/// Which vertices the subjects saw in the video's hold views, and how close to the screen centre.
#[derive(Debug, Clone, PartialEq)]
pub struct HoldViewExposure {
    /// Hold views in which at least one pixel of a triangle around the vertex is drawn.
    pub seen_views: Vec<u32>,
    /// Mean over those views of 1 − (distance of the vertex's projection from the screen
    /// centre / half the screen diagonal); 0 for a vertex no view shows.
    pub centre_closeness: Vec<f64>,
    /// Hold views rendered.
    pub views: usize,
}

impl HoldViewExposure {
    /// Whether each vertex is shown in some hold view.
    pub fn seen(&self) -> Vec<bool> {
        self.seen_views.iter().map(|&s| s > 0).collect()
    }
}

/// Renders the triangle-id buffer of every hold view at the protocol's display size.
pub fn hold_view_exposure(
    mesh: &Mesh,
    protocol: &Protocol,
) -> Result<HoldViewExposure, CameraError> {
    let plan = CameraPlan::new(mesh, protocol)?;
    let raster = Rasterizer::new(mesh);
    let n = mesh.positions.len();
    let mut seen_views = vec![0u32; n];
    let mut closeness = vec![0.0; n];
    let period = protocol.timing.hold_s + protocol.timing.move_s;
    let mut shown_triangle = vec![false; mesh.triangles.len()];
    let mut shown_vertex = vec![false; n];
    for k in 0..plan.viewpoints() {
        let cam = plan.at(k as f64 * period);
        shown_triangle.iter_mut().for_each(|s| *s = false);
        shown_vertex.iter_mut().for_each(|s| *s = false);
        for id in raster.triangle_ids(&cam) {
            if id != BACKGROUND_ID {
                shown_triangle[id as usize] = true;
            }
        }
        for (t, tri) in mesh.triangles.iter().enumerate() {
            if shown_triangle[t] {
                for &v in tri {
                    shown_vertex[v as usize] = true;
                }
            }
        }
        let (w, h) = (cam.width_px as f64, cam.height_px as f64);
        let half_diagonal = 0.5 * (w * w + h * h).sqrt();
        for v in 0..n {
            if !shown_vertex[v] {
                continue;
            }
            let p: DVec3 = mesh.positions[v];
            if let Some((x, y, _)) = cam.project(p) {
                seen_views[v] += 1;
                let r = ((x - 0.5 * w).powi(2) + (y - 0.5 * h).powi(2)).sqrt();
                closeness[v] += (1.0 - r / half_diagonal).max(0.0);
            }
        }
    }
    for v in 0..n {
        if seen_views[v] > 0 {
            closeness[v] /= seen_views[v] as f64;
        }
    }
    Ok(HoldViewExposure {
        seen_views,
        centre_closeness: closeness,
        views: plan.viewpoints(),
    })
}

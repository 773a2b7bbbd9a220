//! A target model that favours no saliency method.
use glam::DVec3;

use crate::mesh::Mesh;

/// A target model independent of every saliency method: the distance of each vertex from the
/// mesh's area-weighted centroid, min–max normalized. Observers drawn by it favour protruding
/// parts (ears, limbs, tails), a known pull on attention, without favouring any method.
pub fn extremity_map(mesh: &Mesh) -> Vec<f64> {
    let mut centroid = DVec3::ZERO;
    let mut area = 0.0;
    for t in 0..mesh.triangles.len() {
        let a = mesh.triangle_area(t);
        let [p, q, r] = mesh.triangle(t);
        centroid += a * (p + q + r) / 3.0;
        area += a;
    }
    if area > 0.0 {
        centroid /= area;
    }
    let d: Vec<f64> = mesh
        .positions
        .iter()
        .map(|p| p.distance(centroid))
        .collect();
    let (lo, hi) = d
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
            (a.min(x), b.max(x))
        });
    d.iter()
        .map(|&x| if hi > lo { (x - lo) / (hi - lo) } else { 0.0 })
        .collect()
}

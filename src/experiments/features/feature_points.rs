//! Feature points from a saliency map (paper §5.5): local maxima over the 1-ring, kept when
//! above the mean of all local maxima, sorted by saliency, and accepted greedily when at
//! least `separation` (geodesic) from every point already accepted.
use super::geodesic::GeodesicGraph;
use crate::mesh::mean_curvature::VertexAdjacency;
use crate::mesh::Mesh;

/// Vertices whose value is at least every 1-ring neighbour's (ties count as maxima).
pub fn local_maxima(mesh: &Mesh, values: &[f64]) -> Vec<usize> {
    let adj = VertexAdjacency::of_mesh(mesh);
    (0..mesh.positions.len())
        .filter(|&v| {
            let nb = adj.neighbours(v);
            !nb.is_empty()
                && values[v].is_finite()
                && nb.iter().all(|&u| values[v] >= values[u as usize])
        })
        .collect()
}

/// A feature point: a local maximum of the map, kept when no more salient point lies within the separation.
#[derive(Debug, Clone, PartialEq)]
pub struct FeaturePoint {
    /// Its vertex.
    pub vertex: usize,
    /// The map's value there.
    pub saliency: f64,
}

/// The paper's rule. `separation` is in the mesh's own units (callers convert).
pub fn feature_points(
    mesh: &Mesh,
    values: &[f64],
    graph: &GeodesicGraph,
    separation: f64,
) -> Vec<FeaturePoint> {
    let maxima = local_maxima(mesh, values);
    if maxima.is_empty() {
        return Vec::new();
    }
    let mean = maxima.iter().map(|&v| values[v]).sum::<f64>() / maxima.len() as f64;
    let mut candidates: Vec<usize> = maxima.into_iter().filter(|&v| values[v] > mean).collect();
    // Highest first; ties to the lower vertex index.
    candidates.sort_by(|&a, &b| values[b].total_cmp(&values[a]).then(a.cmp(&b)));
    let mut blocked = vec![false; mesh.positions.len()];
    let mut out = Vec::new();
    for v in candidates {
        if blocked[v] {
            continue;
        }
        out.push(FeaturePoint {
            vertex: v,
            saliency: values[v],
        });
        // Everything closer than the separation can no longer be accepted.
        for (u, d) in graph.distances_from(v, separation) {
            if d < separation {
                blocked[u] = true;
            }
        }
    }
    out
}

//! Gaussian blur of per-vertex maps over the surface: s_b(v) = Σ_u a_u s(u) K(u,v) / Σ_u a_u K(u,v)
//! with K = exp(−‖u−v‖²/2σ²) cut at 3σ (Euclidean, kd-tree) and a_u the vertex area (a third of
//! its triangles' areas), so dense tessellation does not weigh more. The blur is linear, so
//! a sum of maps blurs to the sum of the blurred maps (used for split-half human maps).
//! σ is in normalized units (half the bounding-box diagonal = 1).
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use crate::mesh::Mesh;

/// Vertex areas: one third of the area of each incident triangle.
pub fn vertex_areas(mesh: &Mesh) -> Vec<f64> {
    let mut a = vec![0.0; mesh.positions.len()];
    for t in 0..mesh.triangles.len() {
        let third = mesh.triangle_area(t) / 3.0;
        for &i in &mesh.triangles[t] {
            a[i as usize] += third;
        }
    }
    a
}

pub struct SurfaceBlur {
    positions: Vec<DVec3>,
    areas: Vec<f64>,
    /// Sources: vertices with area (unreferenced vertices carry no surface).
    sources: Vec<usize>,
    tree: ImmutableKdTree<f64, 3>,
}

impl SurfaceBlur {
    /// `positions` in normalized units, one area per vertex.
    pub fn new(positions: Vec<DVec3>, areas: Vec<f64>) -> SurfaceBlur {
        let sources: Vec<usize> = (0..positions.len()).filter(|&i| areas[i] > 0.0).collect();
        let pts: Vec<[f64; 3]> = sources.iter().map(|&i| positions[i].to_array()).collect();
        let tree = ImmutableKdTree::new_from_slice(&pts).expect("fewer than 2^32 vertices");
        SurfaceBlur {
            positions,
            areas,
            sources,
            tree,
        }
    }

    /// Blurs every map at σ; σ = 0 returns copies.
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Vec<Vec<f64>> {
        if sigma <= 0.0 {
            return maps.iter().map(|m| m.to_vec()).collect();
        }
        let radius2 = 9.0 * sigma * sigma;
        let inv = 1.0 / (2.0 * sigma * sigma);
        let k = maps.len();
        let per_vertex: Vec<Vec<f64>> = self
            .positions
            .par_iter()
            .enumerate()
            .map(|(v, p)| {
                let mut hits = self
                    .tree
                    .query(&p.to_array())
                    .within::<SquaredEuclidean<f64>>(radius2)
                    .unsorted()
                    .execute();
                hits.sort_unstable_by_key(|h| h.item);
                let mut num = vec![0.0; k];
                let mut den = 0.0;
                for h in &hits {
                    let u = self.sources[h.item as usize];
                    let w = self.areas[u] * (-h.distance * inv).exp();
                    den += w;
                    for (n, m) in num.iter_mut().zip(maps) {
                        *n += w * m[u];
                    }
                }
                if den > 0.0 {
                    num.iter().map(|n| n / den).collect()
                } else {
                    maps.iter().map(|m| m[v]).collect()
                }
            })
            .collect();
        (0..k)
            .map(|m| per_vertex.iter().map(|row| row[m]).collect())
            .collect()
    }
}

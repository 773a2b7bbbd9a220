//! Mesh saliency of Lee, Varshney and Jacobs 2005 ("MS"): centre–surround differences of
//! Gaussian-weighted mean curvature at five scales, each scale passed through Itti's
//! non-linear suppression, summed.
//!
//! G(v, σ) = Σ_{x: ‖x−v‖<2σ} H(x) e^{−‖x−v‖²/2σ²} / Σ_{x: ‖x−v‖<2σ} e^{−‖x−v‖²/2σ²} (v itself
//! included), S_i = |G(v, σ_i) − G(v, 2σ_i)|, σ_i ∈ {2, 3, 4, 5, 6}·ε, ε = 0.3% of the
//! bounding-box diagonal. Suppression: rescale S_i to [0, 1], m̄ = mean of its local maxima
//! (1-ring) other than the global maximum, S_i ← S_i (1 − m̄)².
//! Avoided pitfalls of public code: the centre vertex is included, weights are summed in
//! floating point, each scale uses its own kernel, distances are Euclidean. The sums are
//! taken over clusters of vertices by default (see `GaussianSum`, docs/baselines.md).
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use serde::Serialize;

use super::sms::gaussian_interpolation::min_max_normalize;
use crate::mesh::clustered_gaussian_average::{clustered_gaussian_average, GaussianSum};
use crate::mesh::mean_curvature::{
    mean_curvature_with, CurvatureReport, VertexAdjacency, VertexTriangles,
};
use crate::mesh::Mesh;
use glam::DVec3;

/// Parameters of Lee et al.'s mesh saliency (their defaults).
#[derive(Debug, Clone, Serialize)]
pub struct LeeParams {
    /// ε as a fraction of the bounding-box diagonal (Lee et al.: 0.003).
    pub epsilon_fraction: f64,
    /// Scale multipliers of ε (Lee et al.: 2, 3, 4, 5, 6).
    pub scale_multipliers: Vec<f64>,
    /// How each G(v, σ) is summed.
    pub gaussian_sum: GaussianSum,
}

impl Default for LeeParams {
    fn default() -> Self {
        LeeParams {
            epsilon_fraction: 0.003,
            scale_multipliers: vec![2.0, 3.0, 4.0, 5.0, 6.0],
            gaussian_sum: GaussianSum::Clustered {
                cells_per_sigma: 6.0,
            },
        }
    }
}

/// What a run of MS met.
#[derive(Debug, Clone, Serialize)]
pub struct LeeReport {
    /// ε in the mesh's units.
    pub epsilon: f64,
    /// The mean-curvature estimate's report.
    pub curvature: CurvatureReport,
    /// Per scale: mean of the local maxima other than the global one, after rescaling.
    pub suppression_mean_of_maxima: Vec<f64>,
}

/// Per-vertex MS saliency in [0, 1] (input order and count).
pub fn lee_mesh_saliency(mesh: &Mesh, params: &LeeParams) -> (Vec<f64>, LeeReport) {
    // One incidence serves the curvature and the 1-ring of the suppression step.
    let incidence = VertexTriangles::of_mesh(mesh);
    let (h, curvature) = mean_curvature_with(mesh, &incidence);
    let (lo, hi) = mesh.referenced_bounds().expect("a mesh with triangles");
    let epsilon = params.epsilon_fraction * (hi - lo).length();
    // Every distinct σ (σ_i and 2σ_i), each with cutoff 2σ.
    let mut sigmas: Vec<f64> = params
        .scale_multipliers
        .iter()
        .flat_map(|m| [m * epsilon, 2.0 * m * epsilon])
        .collect();
    sigmas.sort_by(f64::total_cmp);
    sigmas.dedup();
    let mut used = vec![false; mesh.positions.len()];
    for t in &mesh.triangles {
        for &i in t {
            used[i as usize] = true;
        }
    }
    let averages = match params.gaussian_sum {
        GaussianSum::Exact => exact_averages(mesh, &h, &used, &sigmas),
        GaussianSum::Clustered { cells_per_sigma } => {
            clustered_averages(mesh, &h, &used, &sigmas, cells_per_sigma)
        }
    };
    let index_of = |sigma: f64| {
        sigmas
            .iter()
            .position(|s| (s - sigma).abs() <= 1e-12 * sigma)
            .expect("σ in the list")
    };
    let adjacency = VertexAdjacency::from_incidence(mesh, &incidence);
    let mut total = vec![0.0; mesh.positions.len()];
    let mut suppression = Vec::new();
    for m in &params.scale_multipliers {
        let (a, b) = (index_of(m * epsilon), index_of(2.0 * m * epsilon));
        let mut s: Vec<f64> = averages.iter().map(|g| (g[a] - g[b]).abs()).collect();
        min_max_normalize(&mut s);
        let m_bar = mean_of_local_maxima_except_global(&s, &adjacency, &used);
        let factor = (1.0 - m_bar) * (1.0 - m_bar);
        suppression.push(m_bar);
        for (t, v) in total.iter_mut().zip(&s) {
            *t += v * factor;
        }
    }
    min_max_normalize(&mut total);
    (
        total,
        LeeReport {
            epsilon,
            curvature,
            suppression_mean_of_maxima: suppression,
        },
    )
}

/// G(v, σ) for every vertex (rows) and every σ (columns), summed exactly.
fn exact_averages(mesh: &Mesh, h: &[f64], used: &[bool], sigmas: &[f64]) -> Vec<Vec<f64>> {
    let max_cutoff = 2.0 * sigmas.last().copied().unwrap_or(0.0);
    let sources: Vec<usize> = (0..mesh.positions.len()).filter(|&i| used[i]).collect();
    let pts: Vec<[f64; 3]> = sources
        .iter()
        .map(|&i| mesh.positions[i].to_array())
        .collect();
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&pts).expect("fewer than 2^32 vertices");
    let inv2: Vec<f64> = sigmas.iter().map(|s| 1.0 / (2.0 * s * s)).collect();
    let cut2: Vec<f64> = sigmas.iter().map(|s| 4.0 * s * s).collect();
    // G(v, σ) for every vertex and every distinct σ.
    mesh.positions
        .par_iter()
        .map(|p| {
            // Summed in the tree's traversal order: fixed for a given tree and query (same
            // bytes across runs and thread counts), and sorting thousands of hits per vertex
            // cost a third of MS's time on big meshes.
            let hits = tree
                .query(&p.to_array())
                .within::<SquaredEuclidean<f64>>(max_cutoff * max_cutoff)
                .unsorted()
                .execute();
            let mut num = vec![0.0; sigmas.len()];
            let mut den = vec![0.0; sigmas.len()];
            for hit in &hits {
                let hx = h[sources[hit.item as usize]];
                for s in (0..sigmas.len()).rev() {
                    if hit.distance >= cut2[s] {
                        break; // σ ascending: smaller σ have smaller cutoffs too
                    }
                    let w = (-hit.distance * inv2[s]).exp();
                    num[s] += w * hx;
                    den[s] += w;
                }
            }
            (0..sigmas.len())
                .map(|s| if den[s] > 0.0 { num[s] / den[s] } else { 0.0 })
                .collect()
        })
        .collect()
}

/// G(v, σ) for every vertex (rows) and every σ (columns), summed over clusters.
fn clustered_averages(
    mesh: &Mesh,
    h: &[f64],
    used: &[bool],
    sigmas: &[f64],
    cells_per_sigma: f64,
) -> Vec<Vec<f64>> {
    let sources: Vec<DVec3> = (0..mesh.positions.len())
        .filter(|&i| used[i])
        .map(|i| mesh.positions[i])
        .collect();
    let values: Vec<f64> = (0..mesh.positions.len())
        .filter(|&i| used[i])
        .map(|i| h[i])
        .collect();
    let weights = vec![1.0; sources.len()];
    let columns: Vec<Vec<Option<f64>>> = sigmas
        .iter()
        .map(|&sigma| {
            clustered_gaussian_average(
                &sources,
                &weights,
                &values,
                &mesh.positions,
                sigma,
                2.0 * sigma,
                cells_per_sigma,
            )
        })
        .collect();
    (0..mesh.positions.len())
        .map(|v| columns.iter().map(|c| c[v].unwrap_or(0.0)).collect())
        .collect()
}

/// Mean of the values at local maxima (≥ every 1-ring neighbour, referenced vertices only),
/// leaving out the single global maximum (Itti et al. 1998's M − m̄ with M = 1).
pub fn mean_of_local_maxima_except_global(
    values: &[f64],
    adjacency: &VertexAdjacency,
    used: &[bool],
) -> f64 {
    let global = (0..values.len())
        .filter(|&v| used[v])
        .max_by(|&a, &b| values[a].total_cmp(&values[b]).then(b.cmp(&a)));
    let mut sum = 0.0;
    let mut count = 0usize;
    for v in 0..values.len() {
        if !used[v] || Some(v) == global {
            continue;
        }
        if adjacency
            .neighbours(v)
            .iter()
            .all(|&u| values[v] >= values[u as usize])
        {
            sum += values[v];
            count += 1;
        }
    }
    if count == 0 {
        0.0
    } else {
        sum / count as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A flat square plate of n × n vertices with a small Gaussian bump.
    fn plate_with_bump(n: usize, bump: (f64, f64), width: f64, height: f64) -> Mesh {
        crate::mesh::test_meshes::height_field(n, 0.0, |x, y| {
            let r2 = (x - bump.0).powi(2) + (y - bump.1).powi(2);
            height * (-r2 / (2.0 * width * width)).exp()
        })
    }

    #[test]
    fn a_small_bump_on_a_flat_plate_is_the_most_salient_region() {
        let bump = (0.35, 0.6);
        let mesh = plate_with_bump(160, bump, 0.015, 0.01);
        let (s, report) = lee_mesh_saliency(&mesh, &LeeParams::default());
        assert_eq!(report.curvature.boundary_vertices, 4 * 159);
        // The bump plus the reach of the widest kernel (cutoff 2·12ε ≈ 0.10 here).
        let near = |p: DVec3| ((p.x - bump.0).powi(2) + (p.y - bump.1).powi(2)).sqrt() < 0.12;
        let argmax = (0..s.len()).max_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap();
        assert!(
            near(mesh.positions[argmax]),
            "most salient vertex at {:?}",
            mesh.positions[argmax]
        );
        let (mut inside, mut outside) = (vec![], vec![]);
        for (p, v) in mesh.positions.iter().zip(&s) {
            if near(*p) {
                inside.push(*v)
            } else {
                outside.push(*v)
            }
        }
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let max_out = outside.iter().cloned().fold(0.0, f64::max);
        assert!(
            max_out < 0.05,
            "saliency away from the bump reaches {max_out}"
        );
        assert!(mean(&inside) > 10.0 * mean(&outside));
    }
}

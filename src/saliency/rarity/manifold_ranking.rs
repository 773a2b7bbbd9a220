//! "MR": mesh saliency via ranking unsalient patches in a descriptor space (Tao, Cao, Li, Liu,
//! Liu, Computers & Graphics 2015), as reconstructed in docs/baselines.md (no public code;
//! choices are parameters):
//! 1. over-segment into patches; describe each by its vertices' mean Zernike height-map
//!    coefficients (several radii);
//! 2. local distinctness by a centre-surround operator: the area-weighted mean descriptor
//!    distance to the patches within `surround_rings` rings of the patch adjacency;
//! 3. background queries: the `background_fraction` of patches with the least distinctness;
//! 4. manifold ranking (Zhou et al. 2004) on a k-nearest-neighbour graph in descriptor space,
//!    w_ij = exp(−‖f_i − f_j‖² / σ²) with σ² the mean squared neighbour distance:
//!    r = (D − αW)⁻¹ y, y the queries' indicator; a patch's saliency is 1 − r / max r (a patch
//!    that ranks close to the background is not salient);
//! 5. patch saliency on its vertices, spread by `smoothing_iterations` steps of Laplacian
//!    smoothing (each vertex moves halfway to its neighbours' mean).
use crate::saliency::SaliencyError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::global_rarity::{distance, patch_descriptors};
use super::working_copy::{RawSpread, WorkingCopy, WorkingCopyReport};
use super::zernike_patches::{ZernikePatches, ZernikePatchesParams};
use crate::mesh::over_segmentation::Patches;
use crate::mesh::Mesh;

/// Parameters of MR (Tao et al. 2015); docs/baselines.md gives the choices.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MrParams {
    /// Vertices of the simplified working copy.
    pub vertices: usize,
    /// Height-map radii (normalized units: half the bounding-box diagonal = 1).
    pub radii: Vec<f64>,
    /// Highest Zernike order.
    pub order: usize,
    /// Patches of the over-segmentation.
    pub patches: usize,
    /// Rings of neighbouring patches forming a patch's surround.
    pub surround_rings: usize,
    /// Fraction of patches (least distinct first) used as background queries.
    pub background_fraction: f64,
    /// k of the descriptor-space neighbour graph.
    pub neighbours: usize,
    /// α of manifold ranking (Zhou et al.'s 0.99).
    pub alpha: f64,
    /// σ of the affinity in descriptor units; 0: the root mean squared neighbour distance.
    pub sigma: f64,
    /// Steps of Laplacian smoothing of the vertex map (each vertex moves halfway to its
    /// neighbours' mean).
    pub smoothing_iterations: usize,
    /// Seed of the over-segmentation's first patch centre.
    pub seed: u64,
}

impl Default for MrParams {
    fn default() -> Self {
        MrParams {
            vertices: 10_000,
            radii: vec![0.05, 0.1, 0.2],
            order: 8,
            patches: 500,
            surround_rings: 2,
            background_fraction: 0.1,
            neighbours: 10,
            alpha: 0.99,
            sigma: 0.0,
            smoothing_iterations: 10,
            seed: 1,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct MrReport {
    pub working_copy: WorkingCopyReport,
    /// The map on the working copy before rescaling.
    pub raw: RawSpread,
    pub patches: usize,
    pub background_queries: usize,
    /// Conjugate-gradient iterations of the ranking solve and its final relative residual.
    pub ranking_iterations: usize,
    pub ranking_residual: f64,
}

impl MrParams {
    /// What MR's working copy, descriptors and patches depend on.
    pub fn zernike_patches(&self) -> ZernikePatchesParams {
        ZernikePatchesParams {
            vertices: self.vertices,
            radii: self.radii.clone(),
            order: self.order,
            patches: self.patches,
            seed: self.seed,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), SaliencyError> {
        if self.radii.is_empty()
            || !(0.0..1.0).contains(&self.alpha)
            || !(self.background_fraction > 0.0 && self.background_fraction <= 1.0)
        {
            return Err(SaliencyError::Invalid(
                "mr needs at least one radius, alpha in [0, 1) and background_fraction in (0, 1]"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// MR's map of `mesh`, one value per input vertex, with its report.
pub fn manifold_ranking_saliency(
    mesh: &Mesh,
    params: &MrParams,
) -> Result<(Vec<f64>, MrReport), SaliencyError> {
    params.validate()?;
    let shared = ZernikePatches::new(mesh, &params.zernike_patches())?;
    manifold_ranking_saliency_from(&shared, params)
}

/// [`manifold_ranking_saliency`] from inputs already built (shared with GR when their
/// parameters agree).
pub fn manifold_ranking_saliency_from(
    shared: &ZernikePatches,
    params: &MrParams,
) -> Result<(Vec<f64>, MrReport), SaliencyError> {
    params.validate()?;
    let (work, z, patches) = shared.built_with(&params.zernike_patches(), "mr")?;
    let (desc, area) = patch_descriptors(work, patches, z);
    let p = patches.len();

    let distinctness = surround_distinctness(patches, &desc, &area, params.surround_rings);
    let queries = ((params.background_fraction * p as f64).round() as usize).clamp(1, p);
    let mut order: Vec<usize> = (0..p).collect();
    order.sort_by(|&a, &b| distinctness[a].total_cmp(&distinctness[b]).then(a.cmp(&b)));
    let mut y = vec![0.0; p];
    for &q in &order[..queries] {
        y[q] = 1.0;
    }
    let weights = descriptor_graph(&desc, params.neighbours, params.sigma);
    let (ranking, iterations, residual) = rank(&weights, &y, params.alpha);
    let max_r = ranking.iter().cloned().fold(0.0, f64::max);
    let patch_saliency: Vec<f64> = ranking
        .iter()
        .map(|r| if max_r > 0.0 { 1.0 - r / max_r } else { 0.0 })
        .collect();

    let values: Vec<f64> = (0..work.len())
        .map(|v| patch_saliency[patches.label[v] as usize])
        .collect();
    let values = smooth_on_graph(work, values, params.smoothing_iterations);
    Ok((
        work.carry_back(&values),
        MrReport {
            working_copy: work.report(),
            raw: RawSpread::of(&values, &work.areas),
            patches: p,
            background_queries: queries,
            ranking_iterations: iterations,
            ranking_residual: residual,
        },
    ))
}

/// Centre-surround distinctness of each patch: the area-weighted mean descriptor distance
/// to the patches within `rings` adjacency rings of it.
fn surround_distinctness(
    patches: &Patches,
    desc: &[Vec<f64>],
    area: &[f64],
    rings: usize,
) -> Vec<f64> {
    (0..desc.len())
        .map(|a| {
            let mut seen = vec![a];
            let mut frontier = vec![a];
            for _ in 0..rings {
                let mut next = Vec::new();
                for &q in &frontier {
                    for &r in &patches.adjacency[q] {
                        if !seen.contains(&r) {
                            seen.push(r);
                            next.push(r);
                        }
                    }
                }
                frontier = next;
            }
            let (mut num, mut den) = (0.0, 0.0);
            for &q in &seen[1..] {
                num += area[q] * distance(&desc[a], &desc[q]);
                den += area[q];
            }
            if den > 0.0 {
                num / den
            } else {
                0.0
            }
        })
        .collect()
}

/// The symmetric k-nearest-neighbour graph of the patches in descriptor space, weights
/// exp(−d²/σ²) (σ² the mean squared edge length when `sigma` is 0): adjacency lists.
fn descriptor_graph(desc: &[Vec<f64>], neighbours: usize, sigma: f64) -> Vec<Vec<(usize, f64)>> {
    let p = desc.len();
    let k = neighbours.min(p.saturating_sub(1));
    let nearest: Vec<Vec<(usize, f64)>> = (0..p)
        .into_par_iter()
        .map(|a| {
            let mut row: Vec<(usize, f64)> = (0..p)
                .filter(|&b| b != a)
                .map(|b| (b, distance(&desc[a], &desc[b]).powi(2)))
                .collect();
            row.sort_by(|x, y| x.1.total_cmp(&y.1).then(x.0.cmp(&y.0)));
            row.truncate(k);
            row
        })
        .collect();
    let mut edges: Vec<(usize, usize, f64)> = nearest
        .iter()
        .enumerate()
        .flat_map(|(a, row)| row.iter().map(move |&(b, d2)| (a.min(b), a.max(b), d2)))
        .collect();
    edges.sort_by_key(|e| (e.0, e.1));
    edges.dedup_by(|x, y| x.0 == y.0 && x.1 == y.1);
    let sigma2 = if sigma > 0.0 {
        sigma * sigma
    } else {
        edges.iter().map(|e| e.2).sum::<f64>() / edges.len().max(1) as f64
    };
    let mut weights: Vec<Vec<(usize, f64)>> = vec![Vec::new(); p];
    for &(a, b, d2) in &edges {
        let w = if sigma2 > 0.0 {
            (-d2 / sigma2).exp()
        } else {
            1.0
        };
        weights[a].push((b, w));
        weights[b].push((a, w));
    }
    weights
}

/// `iterations` rounds of v ← ½ v + ½ (mean of its mesh neighbours).
fn smooth_on_graph(work: &WorkingCopy, mut values: Vec<f64>, iterations: usize) -> Vec<f64> {
    for _ in 0..iterations {
        values = (0..work.len())
            .map(|v| {
                let (mut sum, mut count) = (0.0, 0usize);
                for (u, _) in work.graph.neighbours_of(v) {
                    sum += values[u];
                    count += 1;
                }
                if count == 0 {
                    values[v]
                } else {
                    0.5 * values[v] + 0.5 * sum / count as f64
                }
            })
            .collect();
    }
    values
}

/// Solves (D − αW) r = y by conjugate gradients (the matrix is symmetric and strictly
/// diagonally dominant for α < 1, hence positive definite). A node without edges keeps
/// r = y (its row is the identity).
fn rank(weights: &[Vec<(usize, f64)>], y: &[f64], alpha: f64) -> (Vec<f64>, usize, f64) {
    let p = y.len();
    let degree: Vec<f64> = weights
        .iter()
        .map(|row| row.iter().map(|e| e.1).sum::<f64>())
        .collect();
    let apply = |x: &[f64]| -> Vec<f64> {
        (0..p)
            .map(|i| {
                if degree[i] <= 0.0 {
                    return x[i];
                }
                degree[i] * x[i] - alpha * weights[i].iter().map(|&(j, w)| w * x[j]).sum::<f64>()
            })
            .collect()
    };
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let mut x = vec![0.0; p];
    let mut r = y.to_vec();
    let mut d = r.clone();
    let norm_y = dot(y, y).sqrt().max(f64::MIN_POSITIVE);
    let mut rr = dot(&r, &r);
    let mut iterations = 0;
    while iterations < 10 * p.max(10) && rr.sqrt() > 1e-12 * norm_y {
        let ad = apply(&d);
        let step = rr / dot(&d, &ad);
        for i in 0..p {
            x[i] += step * d[i];
            r[i] -= step * ad[i];
        }
        let next = dot(&r, &r);
        let beta = next / rr;
        rr = next;
        for i in 0..p {
            d[i] = r[i] + beta * d[i];
        }
        iterations += 1;
    }
    (x, iterations, rr.sqrt() / norm_y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranking_spreads_from_the_query_along_the_graph() {
        // A path 0 – 1 – 2 – 3 with the query at 0: rank falls with distance along the path.
        let w = vec![
            vec![(1, 1.0)],
            vec![(0, 1.0), (2, 1.0)],
            vec![(1, 1.0), (3, 1.0)],
            vec![(2, 1.0)],
        ];
        let (r, _, residual) = rank(&w, &[1.0, 0.0, 0.0, 0.0], 0.9);
        assert!(residual < 1e-10);
        assert!(
            r[0] > r[1] && r[1] > r[2] && r[2] > r[3] && r[3] > 0.0,
            "{r:?}"
        );
    }
}

//! "SRI": surface regions of interest (Leifman, Shtrom, Tal, CVPR 2012; TPAMI 2016), as
//! reconstructed in docs/baselines.md (no public code exists; every choice the papers'
//! abstracts leave open is a parameter here):
//! 1. vertex descriptors: spin images at each support radius, reduced by PCA;
//! 2. distinctness (after Goferman et al.'s context-aware saliency): a vertex is distinct
//!    when even its most similar vertices are far from it in descriptor space, where
//!    nearby look-alikes count less: d(i, j) = ‖u_i − u_j‖ / (1 + c·g(i, j)) with g the
//!    geodesic distance, D(i) = 1 − exp(−mean of the K smallest d(i, ·)), averaged over radii;
//! 3. shape extremities: patches on the convex hull of a multidimensional-scaling embedding of
//!    the geodesic distances that are also local maxima of distance from its centre (tips of
//!    limbs, ears, tails);
//! 4. association: foci = the most distinct vertices and the extremities; every vertex gains
//!    A(v) = max over foci f of value_f · exp(−g(v, f)² / 2σ²), so regions near foci rise
//!    (a distinct focus is worth how far its D stands above the median vertex's, an extremity by how far it reaches past the median
//!    radius of the embedding); S = ½ (D + A).
//!
//! Geodesic distances are coarse: between patch centres along the patch adjacency graph
//! (never below the straight distance; the straight distance across components).
use faer::Mat;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::pca::{pca_project, symmetric_eigen};
use super::spin_images::spin_images;
use super::working_copy::{RawSpread, WorkingCopy, WorkingCopyReport};
use crate::gaze_model::view_visibility::fibonacci_directions;
use crate::mesh::edge_graph::distance_or_euclidean;
use crate::mesh::over_segmentation::{over_segment, Patches};
use crate::mesh::Mesh;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SriParams {
    /// Vertices of the simplified working copy.
    pub vertices: usize,
    /// Spin-image support radii (normalized units: half the bounding-box diagonal = 1).
    pub radii: Vec<f64>,
    pub alpha_bins: usize,
    pub beta_bins: usize,
    /// Principal components kept of each spin image.
    pub pca_dims: usize,
    /// K: how many most similar vertices a vertex's distinctness averages over.
    pub most_similar: usize,
    /// c: how much geodesic distance discounts a look-alike (Goferman et al.'s 3).
    pub geodesic_weight: f64,
    /// Spin-image distance (images sum to 1) that counts as "unlike": D = 1 − exp(−d/this).
    pub distance_scale: f64,
    /// Patches for the coarse geodesic distances and the extremities.
    pub patches: usize,
    /// Vertices whose distinctness is at least this fraction of the largest are foci.
    pub focus_threshold: f64,
    /// σ of the association's geodesic Gaussian (normalized units).
    pub association_sigma: f64,
    /// Directions probed to find the embedding's convex hull.
    pub hull_directions: usize,
    /// An extremity at this multiple of the embedding's median radius (or farther) is a
    /// focus of full weight; one at the median radius weighs nothing.
    pub extremity_reach: f64,
    pub seed: u64,
}

impl Default for SriParams {
    fn default() -> Self {
        SriParams {
            vertices: 10_000,
            radii: vec![0.05, 0.1, 0.2],
            alpha_bins: 8,
            beta_bins: 16,
            pca_dims: 16,
            most_similar: 64,
            geodesic_weight: 3.0,
            distance_scale: 0.1,
            patches: 500,
            focus_threshold: 0.8,
            association_sigma: 0.1,
            hull_directions: 2000,
            extremity_reach: 1.5,
            seed: 1,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct SriReport {
    pub working_copy: WorkingCopyReport,
    /// The map on the working copy before rescaling.
    pub raw: RawSpread,
    /// The two terms of S = ½ (D + A).
    pub distinctness: RawSpread,
    pub association: RawSpread,
    pub patches: usize,
    pub extremities: usize,
    pub distinct_foci: usize,
}

pub fn surface_regions_of_interest(
    mesh: &Mesh,
    params: &SriParams,
) -> Result<(Vec<f64>, SriReport), String> {
    if params.radii.is_empty() || params.most_similar == 0 {
        return Err("sri needs at least one radius and most_similar ≥ 1".into());
    }
    let work = WorkingCopy::new(mesh, params.vertices)?;
    let n = work.len();
    let patches = over_segment(&work.mesh, &work.graph, params.patches, params.seed);
    let centre_distance = patches.centre_distances(&work.mesh);
    let geodesic = |i: usize, j: usize| {
        let (a, b) = (patches.label[i] as usize, patches.label[j] as usize);
        distance_or_euclidean(
            centre_distance[a][b],
            work.mesh.positions[i],
            work.mesh.positions[j],
        )
    };

    // Per radius: PCA-reduced spin images (an orthogonal projection, so distances stay in
    // the images' own units: a featureless shape stays featureless), f32 in lanes of 8
    // (zero-padded) because the pair loop is the method's cost and 8-wide sums vectorize.
    let mut flat: Vec<Vec<f32>> = vec![Vec::new(); n];
    let mut dims = Vec::new();
    let to_units = 1.0 / params.distance_scale;
    for &radius in &params.radii {
        let images = spin_images(&work, radius, params.alpha_bins, params.beta_bins);
        let u = pca_project(&images, params.pca_dims)?;
        let padded = u[0].len().div_ceil(8) * 8;
        dims.push(padded);
        for (row, r) in flat.iter_mut().zip(u) {
            let start = row.len();
            row.extend(r.into_iter().map(|x| (x * to_units) as f32));
            row.resize(start + padded, 0.0);
        }
    }
    let k = params.most_similar.min(n - 1).max(1);
    let scales = params.radii.len();
    // One pass over all pairs serves every radius: the geodesic term is shared.
    let distinctness: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut rows: Vec<Vec<f64>> = vec![Vec::with_capacity(n - 1); scales];
            // geodesic(i, j) inlined: this loop runs n² times.
            let from_patch = &centre_distance[patches.label[i] as usize];
            let pi = work.mesh.positions[i];
            for j in (0..n).filter(|&j| j != i) {
                let straight = pi.distance(work.mesh.positions[j]);
                let path = from_patch[patches.label[j] as usize];
                let g = if path.is_finite() {
                    path.max(straight)
                } else {
                    straight
                };
                let discount = 1.0 / (1.0 + params.geodesic_weight * g);
                let mut offset = 0;
                for (s, &d) in dims.iter().enumerate() {
                    let a = &flat[i][offset..offset + d];
                    let b = &flat[j][offset..offset + d];
                    rows[s].push(lane_distance(a, b) * discount);
                    offset += d;
                }
            }
            rows.iter_mut()
                .map(|row| {
                    row.select_nth_unstable_by(k - 1, f64::total_cmp);
                    let mean = row[..k].iter().sum::<f64>() / k as f64;
                    1.0 - (-mean).exp()
                })
                .sum::<f64>()
                / scales as f64
        })
        .collect();
    let max_d = distinctness.iter().cloned().fold(0.0, f64::max);
    let extremities = extremity_patches(&work, &patches, &centre_distance, params.hull_directions)?;
    // Foci are picked relative to the most distinct vertex but weigh how far they stand above
    // the typical (median) vertex, so on a shape with nothing distinct no focus lifts its
    // surroundings.
    let mut sorted = distinctness.clone();
    sorted.sort_by(f64::total_cmp);
    let typical = sorted[n / 2];
    let mut foci: Vec<(usize, f64)> = (0..n)
        .filter(|&v| max_d > 0.0 && distinctness[v] >= params.focus_threshold * max_d)
        .map(|v| (v, ((distinctness[v] - typical) / (1.0 - typical)).max(0.0)))
        .collect();
    let distinct_foci = foci.len();
    foci.extend(extremities.iter().filter_map(|&(p, reach)| {
        let weight = ((reach - 1.0) / (params.extremity_reach - 1.0)).clamp(0.0, 1.0);
        (weight > 0.0).then_some((patches.centres[p], weight))
    }));
    let inv = 1.0 / (2.0 * params.association_sigma * params.association_sigma);
    let association: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|v| {
            foci.iter()
                .map(|&(f, value)| {
                    let g = geodesic(v, f);
                    value * (-g * g * inv).exp()
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let saliency: Vec<f64> = (0..n)
        .map(|v| 0.5 * (distinctness[v] + association[v]))
        .collect();
    Ok((
        work.carry_back(&saliency),
        SriReport {
            working_copy: work.report(),
            raw: RawSpread::of(&saliency, &work.areas),
            distinctness: RawSpread::of(&distinctness, &work.areas),
            association: RawSpread::of(&association, &work.areas),
            patches: patches.len(),
            extremities: extremities.len(),
            distinct_foci,
        },
    ))
}

/// Euclidean distance of two equally long f32 vectors whose length is a multiple of 8,
/// summed in eight lanes (a fixed order, so the same bytes on every machine).
fn lane_distance(a: &[f32], b: &[f32]) -> f64 {
    let mut lanes = [0.0f32; 8];
    for (x, y) in a.chunks_exact(8).zip(b.chunks_exact(8)) {
        for k in 0..8 {
            let d = x[k] - y[k];
            lanes[k] += d * d;
        }
    }
    (lanes.iter().sum::<f32>() as f64).sqrt()
}

/// Patches whose centres lie on the convex hull of a 3-D classical MDS embedding of the
/// centre-to-centre geodesic distances and are farther from the embedding's centroid than
/// every neighbouring patch, each with its distance from the centroid over the median's.
fn extremity_patches(
    work: &WorkingCopy,
    patches: &Patches,
    centre_distance: &[Vec<f64>],
    directions: usize,
) -> Result<Vec<(usize, f64)>, String> {
    let p = patches.len();
    if p < 4 {
        return Ok(Vec::new());
    }
    // Double-centred squared distances: B = −½ J D² J.
    let pos = |a: usize| work.mesh.positions[patches.centres[a]];
    let mut sq = Mat::<f64>::zeros(p, p);
    for a in 0..p {
        for b in 0..p {
            let g = distance_or_euclidean(centre_distance[a][b], pos(a), pos(b));
            sq[(a, b)] = g * g;
        }
    }
    let row_mean: Vec<f64> = (0..p)
        .map(|a| (0..p).map(|b| sq[(a, b)]).sum::<f64>() / p as f64)
        .collect();
    let all_mean = row_mean.iter().sum::<f64>() / p as f64;
    let mut b = Mat::<f64>::zeros(p, p);
    for i in 0..p {
        for j in 0..p {
            b[(i, j)] = -0.5 * (sq[(i, j)] - row_mean[i] - row_mean[j] + all_mean);
        }
    }
    let (values, vectors) = symmetric_eigen(&b)?;
    let embedding: Vec<[f64; 3]> = (0..p)
        .map(|i| {
            std::array::from_fn(|k| {
                let col = p - 1 - k;
                values[col].max(0.0).sqrt() * vectors[(i, col)]
            })
        })
        .collect();
    let mut on_hull = vec![false; p];
    for d in fibonacci_directions(directions) {
        let d = d.to_array();
        let best = (0..p)
            .max_by(|&x, &y| {
                let dx: f64 = (0..3).map(|k| embedding[x][k] * d[k]).sum();
                let dy: f64 = (0..3).map(|k| embedding[y][k] * d[k]).sum();
                dx.total_cmp(&dy).then(y.cmp(&x))
            })
            .expect("p ≥ 4");
        on_hull[best] = true;
    }
    let centroid: [f64; 3] =
        std::array::from_fn(|k| embedding.iter().map(|e| e[k]).sum::<f64>() / p as f64);
    let radius: Vec<f64> = embedding
        .iter()
        .map(|e| {
            (0..3)
                .map(|k| (e[k] - centroid[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let mut sorted = radius.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[p / 2].max(f64::MIN_POSITIVE);
    Ok((0..p)
        .filter(|&a| on_hull[a] && patches.adjacency[a].iter().all(|&q| radius[q] < radius[a]))
        .map(|a| (a, radius[a] / median))
        .collect())
}

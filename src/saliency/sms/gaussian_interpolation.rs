//! Saliency of sample points carried to mesh vertices by Gaussian filtering (paper Eq. 2):
//! ξ(v) = Σ_{p: ‖v−p‖<3σ} w_p φ(p) / Σ w_p, w_p = exp(−‖v−p‖²/(2σ²)), found with a kd-tree.
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Whether the Gaussian sum is divided by the sum of weights (the paper's Eq. 2) or not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum InterpolationKind {
    /// Weighted mean (Nadaraya–Watson), as Eq. 2 writes it; independent of sample density.
    Normalized,
    /// Plain weighted sum: denser sampling reads as more salient.
    Sum,
}

#[derive(Debug, Clone, Serialize)]
pub struct InterpolationReport {
    pub sigma: f64,
    pub radius: f64,
    pub kind: InterpolationKind,
    /// Vertices with no sample within the radius; they take the nearest sample's value.
    pub vertices_without_sample_in_radius: usize,
}

/// Values at `targets` from values at `sources`, both in the normalized frame.
pub fn gaussian_interpolation(
    sources: &[DVec3],
    values: &[f64],
    targets: &[DVec3],
    sigma: f64,
    kind: InterpolationKind,
) -> (Vec<f64>, InterpolationReport) {
    assert_eq!(sources.len(), values.len());
    let points: Vec<[f64; 3]> = sources.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&points).expect("fewer than 2^32 samples");
    let radius = 3.0 * sigma;
    let inv = 1.0 / (2.0 * sigma * sigma);
    let out: Vec<(f64, bool)> = targets
        .par_iter()
        .map(|v| {
            let q = v.to_array();
            let mut hits = tree
                .query(&q)
                .within::<SquaredEuclidean<f64>>(radius * radius)
                .unsorted()
                .execute();
            if hits.is_empty() {
                let nearest = tree
                    .query(&q)
                    .nearest_one::<SquaredEuclidean<f64>>()
                    .execute();
                return (values[nearest.item as usize], true);
            }
            // Fixed summation order, independent of the tree's traversal.
            hits.sort_unstable_by_key(|h| h.item);
            let (mut num, mut den) = (0.0, 0.0);
            for h in &hits {
                let w = (-h.distance * inv).exp();
                num += w * values[h.item as usize];
                den += w;
            }
            match kind {
                InterpolationKind::Normalized => (num / den, false),
                InterpolationKind::Sum => (num, false),
            }
        })
        .collect();
    let fallback = out.iter().filter(|(_, f)| *f).count();
    (
        out.into_iter().map(|(v, _)| v).collect(),
        InterpolationReport {
            sigma,
            radius,
            kind,
            vertices_without_sample_in_radius: fallback,
        },
    )
}

/// Rescales to [0, 1] (all zeros if the values are constant).
pub fn min_max_normalize(values: &mut [f64]) {
    let lo = values.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let span = hi - lo;
    for v in values.iter_mut() {
        *v = if span > 0.0 { (*v - lo) / span } else { 0.0 };
    }
}

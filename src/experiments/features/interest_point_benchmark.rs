//! The evaluation of Dutagaci, Cheung and Godil 2012 ("Evaluation of 3D interest point
//! detection techniques via human-generated ground truth", Visual Computer 28): a voted
//! ground truth from several subjects' marked points, one-to-one matching within a geodesic
//! tolerance, and the False Negative, False Positive and Weighted Miss Errors, with the
//! recall / precision / F-measure the SMS paper reports (its Fig. 9).
//!
//! Distances are geodesic, in the mesh's units; radii are fractions of the mesh diameter d_M.
use serde::Serialize;

use super::geodesic::GeodesicGraph;

/// A ground-truth point and how many subjects marked near it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TruthPoint {
    /// The vertex.
    pub vertex: usize,
    /// Subjects who marked near it.
    pub subjects: usize,
}

/// Ground truth for (σ, n): a marked point is a candidate when the marks within geodesic
/// σ·d_M of it come from at least `n` distinct subjects. Repeatedly, the candidate with the
/// smallest summed distance to the marks around it becomes a ground-truth point and the marks
/// around it are removed.
pub fn voted_ground_truth(
    graph: &GeodesicGraph,
    marks: &[Vec<usize>],
    sigma: f64,
    n: usize,
    diameter: f64,
) -> Vec<TruthPoint> {
    let radius = sigma * diameter;
    // Every mark as (subject, vertex).
    let all: Vec<(usize, usize)> = marks
        .iter()
        .enumerate()
        .flat_map(|(s, m)| m.iter().map(move |&v| (s, v)))
        .collect();
    // Neighbourhoods: indices of marks within the radius of each mark, with distances.
    let hoods: Vec<Vec<(usize, f64)>> = all
        .iter()
        .map(|&(_, v)| {
            let near = graph.distances_from(v, radius);
            all.iter()
                .enumerate()
                .filter_map(|(j, &(_, u))| {
                    near.binary_search_by_key(&u, |x| x.0)
                        .ok()
                        .map(|k| (j, near[k].1))
                })
                .collect()
        })
        .collect();
    let mut alive = vec![true; all.len()];
    let mut truth = Vec::new();
    loop {
        let subjects_of = |i: usize| {
            let mut s: Vec<usize> = hoods[i]
                .iter()
                .filter(|(j, _)| alive[*j])
                .map(|(j, _)| all[*j].0)
                .collect();
            s.sort_unstable();
            s.dedup();
            s.len()
        };
        let best = (0..all.len())
            .filter(|&i| alive[i] && subjects_of(i) >= n)
            .map(|i| {
                let cost: f64 = hoods[i]
                    .iter()
                    .filter(|(j, _)| alive[*j])
                    .map(|x| x.1)
                    .sum();
                (i, cost)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1).then(a.0.cmp(&b.0)));
        let Some((i, _)) = best else { break };
        truth.push(TruthPoint {
            vertex: all[i].1,
            subjects: subjects_of(i),
        });
        for &(j, _) in &hoods[i] {
            alive[j] = false;
        }
        alive[i] = false;
    }
    truth
}

/// Detected points against the ground truth at one tolerance α (Dutagaci et al. 2012).
#[derive(Debug, Clone, Serialize)]
pub struct Evaluation {
    /// Tolerance as a fraction of the diameter.
    pub alpha: f64,
    /// Ground-truth points.
    pub truth_points: usize,
    /// Detected points.
    pub detected_points: usize,
    /// Ground-truth points with a detected point within α.
    pub matched: usize,
    /// False negative error: the share of ground-truth points missed.
    pub false_negative_error: f64,
    /// False positive error: the share of detected points near no ground-truth point.
    pub false_positive_error: f64,
    /// Weighted miss error: misses weighted by how many subjects marked them.
    pub weighted_miss_error: f64,
    /// Recall, 1 − false negative error.
    pub recall: f64,
    /// Precision, 1 − false positive error.
    pub precision: f64,
    /// Harmonic mean of recall and precision.
    pub f_measure: f64,
}

/// Matches detections to ground-truth points within geodesic α·d_M, closest pairs first,
/// each point used once.
pub fn evaluate(
    graph: &GeodesicGraph,
    truth: &[TruthPoint],
    detected: &[usize],
    alpha: f64,
    diameter: f64,
) -> Evaluation {
    let r = alpha * diameter;
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, t) in truth.iter().enumerate() {
        let near = graph.distances_from(t.vertex, r);
        for (j, &d) in detected.iter().enumerate() {
            if let Ok(k) = near.binary_search_by_key(&d, |x| x.0) {
                pairs.push((near[k].1, i, j));
            }
        }
    }
    pairs.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let mut t_used = vec![false; truth.len()];
    let mut d_used = vec![false; detected.len()];
    for (_, i, j) in pairs {
        if !t_used[i] && !d_used[j] {
            t_used[i] = true;
            d_used[j] = true;
        }
    }
    let matched = t_used.iter().filter(|x| **x).count();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { f64::NAN };
    let fne = 1.0 - ratio(matched as f64, truth.len() as f64);
    let fpe = 1.0 - ratio(matched as f64, detected.len() as f64);
    let w_total: usize = truth.iter().map(|t| t.subjects).sum();
    let w_hit: usize = truth
        .iter()
        .zip(&t_used)
        .filter(|x| *x.1)
        .map(|x| x.0.subjects)
        .sum();
    let recall = 1.0 - fne;
    let precision = 1.0 - fpe;
    Evaluation {
        alpha,
        truth_points: truth.len(),
        detected_points: detected.len(),
        matched,
        false_negative_error: fne,
        false_positive_error: fpe,
        weighted_miss_error: 1.0 - ratio(w_hit as f64, w_total as f64),
        recall,
        precision,
        f_measure: if recall + precision > 0.0 {
            2.0 * precision * recall / (precision + recall)
        } else {
            0.0
        },
    }
}

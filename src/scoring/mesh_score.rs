//! Scores saliency maps against human ground truth on one mesh: every metric at every blur
//! level, beside a seeded chance map blurred the same way and, for fixation sets with subject
//! ids, the split-half human ceiling (paper §5.3, Fig. 6).
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::scoring::surface_blur::{vertex_areas, BlurKernel, MeshBlur};
use crate::scoring::{auc_borji, auc_judd, gini_index, kl_divergence, lcc, nss, sim};
use crate::truth::GroundTruth;

/// How vertices count in the metrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Weighting {
    /// Every vertex counts once (as the papers do).
    Vertex,
    /// Vertices weigh their area (a third of their triangles'), so tessellation density
    /// does not matter.
    Area,
}

#[derive(Debug, Clone, Serialize)]
pub struct ScoreParams {
    /// Blur widths σ_b in normalized units (half bounding-box diagonal = 1).
    pub blur_sigmas: Vec<f64>,
    pub weighting: Weighting,
    pub borji_splits: usize,
    pub seed: u64,
    /// Random split-halves when a set has more than 8 subjects (else all splits).
    pub human_random_splits: usize,
    pub bounding_box: BoundingBox,
    pub kernel: BlurKernel,
}

impl Default for ScoreParams {
    fn default() -> Self {
        ScoreParams {
            blur_sigmas: (0..=20).map(|i| i as f64 / 100.0).collect(),
            weighting: Weighting::Vertex,
            borji_splits: 100,
            seed: 1,
            human_random_splits: 100,
            bounding_box: BoundingBox::Oriented,
            kernel: BlurKernel::Euclidean,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct ScoreRow {
    pub method: String,
    pub metric: &'static str,
    pub blur: f64,
    pub value: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct MethodSummary {
    pub method: String,
    pub auc_judd_unblurred: f64,
    pub auc_judd_peak: f64,
    pub auc_judd_peak_blur: f64,
    /// The chance map's AUC-Judd at the same blur as this method's peak.
    pub chance_auc_judd_at_peak: f64,
    pub lcc_unblurred: f64,
    pub lcc_peak: f64,
    pub lcc_peak_blur: f64,
    pub nss_unblurred: f64,
    pub gini_unblurred: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct MeshScore {
    pub rows: Vec<ScoreRow>,
    pub summaries: Vec<MethodSummary>,
    /// Ordered (predictor, target) subject splits behind the human curve; 0 if none.
    pub human_splits: usize,
    pub positives: usize,
    pub fixations: usize,
}

pub const CHANCE: &str = "chance";
pub const HUMAN: &str = "human";

/// Subject index sets (predictor, target) for the split-half ceiling.
pub fn human_splits(n: usize, random_splits: usize, seed: u64) -> Vec<(Vec<usize>, Vec<usize>)> {
    if n < 2 {
        return Vec::new();
    }
    let half = n / 2;
    let complement = |a: &[usize]| (0..n).filter(|i| !a.contains(i)).collect::<Vec<_>>();
    let mut halves: Vec<Vec<usize>> = Vec::new();
    if n <= 8 {
        for mask in 0u32..(1 << n) {
            if mask.count_ones() as usize == half {
                halves.push((0..n).filter(|i| mask & (1 << i) != 0).collect());
            }
        }
    } else {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for _ in 0..random_splits {
            let mut idx: Vec<usize> = (0..n).collect();
            for i in (1..n).rev() {
                idx.swap(i, rng.random_range(0..=i));
            }
            let mut a = idx[..half].to_vec();
            a.sort();
            halves.push(a);
        }
    }
    let mut out = Vec::new();
    for a in halves {
        let b = complement(&a);
        // With an even count the halves already include every complement (both directions).
        if n % 2 == 1 || n > 8 {
            out.push((b.clone(), a.clone()));
        }
        out.push((a, b));
    }
    out
}

/// σ_b from 0 to `max` in steps of `step` (rounded to 1e-9 so 0.07 prints as 0.07).
pub fn blur_grid(max: f64, step: f64) -> Result<Vec<f64>, String> {
    if !(step > 0.0 && max >= 0.0 && max / step <= 10_000.0) {
        return Err(
            "--blur-step must be positive and --blur-max / --blur-step at most 10000".to_string(),
        );
    }
    let k = (max / step + 1e-9).floor() as usize;
    Ok((0..=k)
        .map(|i| (i as f64 * step * 1e9).round() / 1e9)
        .collect())
}

/// The (blur, value) of a curve's highest finite value; the first of equal peaks (the least
/// blur, as curves run from sharp to blurred). (NaN, NaN) when no value is finite.
pub fn peak_over_blur(curve: &[(f64, f64)]) -> (f64, f64) {
    curve
        .iter()
        .copied()
        .filter(|x| x.1.is_finite())
        .fold((f64::NAN, f64::NAN), |best, x| {
            if best.1.is_nan() || x.1 > best.1 {
                x
            } else {
                best
            }
        })
}

/// (value, blur) of the peak of one method's metric over blur.
fn argmax_over_blur(rows: &[ScoreRow], method: &str, metric: &str) -> (f64, f64) {
    let curve: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.method == method && r.metric == metric)
        .map(|r| (r.blur, r.value))
        .collect();
    let (blur, value) = peak_over_blur(&curve);
    (value, blur)
}

fn value_at(rows: &[ScoreRow], method: &str, metric: &str, blur: f64) -> f64 {
    rows.iter()
        .find(|r| r.method == method && r.metric == metric && r.blur == blur)
        .map_or(f64::NAN, |r| r.value)
}

/// Scores `maps` (name, one value per vertex) against `truth` on `mesh`.
pub fn score_mesh(
    mesh: &Mesh,
    truth: &GroundTruth,
    maps: &[(String, Vec<f64>)],
    params: &ScoreParams,
    progress: &dyn Progress,
) -> Result<MeshScore, String> {
    let n = mesh.positions.len();
    let norm = Normalization::of_mesh(mesh, params.bounding_box);
    let areas = vertex_areas(mesh);
    let normalized = norm.normalized_mesh(mesh);
    let blur = MeshBlur::new(&normalized, params.kernel);
    let weights = (params.weighting == Weighting::Area).then_some(areas.as_slice());
    let positive = truth.positive(n);
    let fixated = truth.fixated();
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let chance: Vec<f64> = (0..n).map(|_| rng.random::<f64>()).collect();
    // Per-subject fixation counts, for density maps and the human ceiling.
    let (subject_counts, splits) = match truth {
        GroundTruth::Fixations(f) => {
            let counts: Vec<Vec<f64>> = f
                .subjects
                .iter()
                .map(|s| {
                    let mut c = vec![0.0; n];
                    for x in f.fixations.iter().filter(|x| &x.subject == s) {
                        c[x.vertex] += 1.0;
                    }
                    c
                })
                .collect();
            let splits = human_splits(f.subjects.len(), params.human_random_splits, params.seed);
            (counts, splits)
        }
        GroundTruth::VertexMap(_) => (Vec::new(), Vec::new()),
    };
    let mut rows = Vec::new();
    progress.start("scoring over blur", params.blur_sigmas.len() as u64);
    for &sigma in &params.blur_sigmas {
        let mut inputs: Vec<&[f64]> = maps.iter().map(|(_, m)| m.as_slice()).collect();
        inputs.push(&chance);
        inputs.extend(subject_counts.iter().map(|c| c.as_slice()));
        let blurred = blur.blur(&inputs, sigma)?;
        let (method_maps, rest) = blurred.split_at(maps.len());
        let (chance_map, subject_maps) = rest.split_first().expect("chance map");
        let density: Vec<f64> = match truth {
            GroundTruth::VertexMap(m) => m.values.clone(),
            GroundTruth::Fixations(_) => {
                let mut d = vec![0.0; n];
                for s in subject_maps {
                    for (a, b) in d.iter_mut().zip(s) {
                        *a += b;
                    }
                }
                d
            }
        };
        let names = maps.iter().map(|(name, _)| name.as_str()).chain([CHANCE]);
        for (name, map) in names.zip(method_maps.iter().chain([chance_map])) {
            let mut push = |metric: &'static str, value: f64| {
                rows.push(ScoreRow {
                    method: name.to_string(),
                    metric,
                    blur: sigma,
                    value,
                })
            };
            push("auc_judd", auc_judd(map, &positive, weights));
            push(
                "auc_borji",
                auc_borji(map, &fixated, weights, params.borji_splits, params.seed),
            );
            push("lcc", lcc(map, &density, weights));
            push("nss", nss(map, &fixated, weights));
            push("sim", sim(map, &density, weights));
            push("kl", kl_divergence(map, &density, weights));
            push(
                "gini",
                gini_index(&map.iter().map(|v| v.max(0.0)).collect::<Vec<_>>()),
            );
        }
        if !splits.is_empty() {
            let (mut auc_sum, mut lcc_sum, mut nss_sum) = (0.0, 0.0, 0.0);
            if let GroundTruth::Fixations(f) = truth {
                for (pred, target) in &splits {
                    let sum_of = |set: &[usize]| {
                        let mut m = vec![0.0; n];
                        for &s in set {
                            for (a, b) in m.iter_mut().zip(&subject_maps[s]) {
                                *a += b;
                            }
                        }
                        m
                    };
                    let predictor = sum_of(pred);
                    let target_density = sum_of(target);
                    let target_names: Vec<&String> =
                        target.iter().map(|&s| &f.subjects[s]).collect();
                    let target_fix: Vec<usize> = f
                        .fixations
                        .iter()
                        .filter(|x| target_names.contains(&&x.subject))
                        .map(|x| x.vertex)
                        .collect();
                    let mut target_pos = vec![false; n];
                    for &v in &target_fix {
                        target_pos[v] = true;
                    }
                    auc_sum += auc_judd(&predictor, &target_pos, weights);
                    lcc_sum += lcc(&predictor, &target_density, weights);
                    nss_sum += nss(&predictor, &target_fix, weights);
                }
            }
            let k = splits.len() as f64;
            for (metric, v) in [
                ("auc_judd", auc_sum / k),
                ("lcc", lcc_sum / k),
                ("nss", nss_sum / k),
            ] {
                rows.push(ScoreRow {
                    method: HUMAN.into(),
                    metric,
                    blur: sigma,
                    value: v,
                });
            }
        }
        progress.advance(1);
    }
    progress.finish();
    let summaries = maps
        .iter()
        .map(|(name, _)| name.as_str())
        .chain([CHANCE])
        .map(|name| {
            let (auc_peak, auc_blur) = argmax_over_blur(&rows, name, "auc_judd");
            let (lcc_peak, lcc_blur) = argmax_over_blur(&rows, name, "lcc");
            MethodSummary {
                method: name.to_string(),
                auc_judd_unblurred: value_at(&rows, name, "auc_judd", 0.0),
                auc_judd_peak: auc_peak,
                auc_judd_peak_blur: auc_blur,
                chance_auc_judd_at_peak: value_at(&rows, CHANCE, "auc_judd", auc_blur),
                lcc_unblurred: value_at(&rows, name, "lcc", 0.0),
                lcc_peak,
                lcc_peak_blur: lcc_blur,
                nss_unblurred: value_at(&rows, name, "nss", 0.0),
                gini_unblurred: value_at(&rows, name, "gini", 0.0),
            }
        })
        .collect();
    Ok(MeshScore {
        rows,
        summaries,
        human_splits: splits.len(),
        positives: positive.iter().filter(|p| **p).count(),
        fixations: fixated.len(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn all_splits_of_eight_subjects_both_directions() {
        let s = human_splits(8, 100, 1);
        assert_eq!(s.len(), 70); // 35 unordered splits × 2 directions
        for (a, b) in &s {
            assert_eq!(a.len(), 4);
            assert_eq!(b.len(), 4);
        }
        assert_eq!(human_splits(5, 100, 1).len(), 20); // C(5,2) × 2
        assert_eq!(human_splits(12, 50, 1).len(), 100);
        assert!(human_splits(1, 10, 1).is_empty());
    }
}

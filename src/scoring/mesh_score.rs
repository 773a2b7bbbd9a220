//! Scores saliency maps against human ground truth on one mesh: every metric at every blur
//! level, beside a chance band (seeded random maps blurred the same way: their mean and 95%
//! interval) and, for fixation sets with subject ids, the split-half human ceiling (paper §5.3,
//! Fig. 6).
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::vertex_areas::vertex_areas;
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::scoring::auc::auc_judd_and_seen;
use crate::scoring::error::ScoreError;
use crate::scoring::ground_truth::GroundTruth;
use crate::scoring::map_agreement::{
    as_distribution, kl_divergence_of, lcc_of, nss_of, sim_of, MeanStd,
};
use crate::scoring::surface_blur::{BlurKernel, MeshBlur};
use crate::scoring::{auc_borji, auc_judd, gini_index};

/// How vertices count in the metrics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Weighting {
    /// Every vertex counts once (as the papers do).
    Vertex,
    /// Vertices weigh their area (a third of their triangles'), so tessellation density
    /// does not matter.
    Area,
}

/// How one mesh is scored; the defaults are the paper's (21 blur widths 0–0.2, 20 chance
/// maps, 100 random human splits).
#[derive(Debug, Clone, Serialize)]
pub struct ScoreParams {
    /// Blur widths σ_b in normalized units (half bounding-box diagonal = 1).
    pub blur_sigmas: Vec<f64>,
    /// How vertices count in the metrics.
    pub weighting: Weighting,
    /// Random negative sets behind AUC-Borji.
    pub borji_splits: usize,
    /// Seed of every random step (chance maps, human splits, AUC-Borji's negatives).
    pub seed: u64,
    /// Random split-halves when a set has more than 8 subjects (else all splits).
    pub human_random_splits: usize,
    /// The box whose half diagonal is the unit of σ_b.
    pub bounding_box: BoundingBox,
    /// How maps are blurred over the surface.
    pub kernel: BlurKernel,
    /// Random maps behind the chance band; the first is the single chance map of old.
    pub chance_maps: usize,
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
            chance_maps: 20,
        }
    }
}

/// One number of a score: a method's (or chance's, or the human ceiling's) metric at a blur.
#[derive(Debug, Clone, Serialize)]
pub struct ScoreRow {
    /// The map's name, or [`CHANCE`], [`CHANCE_LOW`], [`CHANCE_HIGH`], [`HUMAN`].
    pub method: String,
    /// `auc_judd`, `auc_judd_visible`, `auc_borji`, `lcc`, `nss`, `sim`, `kl`.
    pub metric: &'static str,
    /// σ_b, in normalized units.
    pub blur: f64,
    /// The metric's value.
    pub value: f64,
}

/// One method's headline numbers on a mesh.
#[derive(Debug, Clone, Serialize)]
pub struct MethodSummary {
    /// The map's name.
    pub method: String,
    /// AUC-Judd of the map as given (σ_b = 0).
    pub auc_judd_unblurred: f64,
    /// AUC-Judd unblurred with never-shown vertices left out of the negatives (NaN when the
    /// scoring had no visibility).
    pub auc_judd_visible_unblurred: f64,
    /// The best AUC-Judd over the blur grid.
    pub auc_judd_peak: f64,
    /// The σ_b of that best AUC-Judd.
    pub auc_judd_peak_blur: f64,
    /// The chance maps' mean AUC-Judd at the same blur as this method's peak, and the 2.5th
    /// and 97.5th percentiles of their values there.
    pub chance_auc_judd_at_peak: f64,
    /// The chance maps' 2.5th percentile there.
    pub chance_auc_judd_low_at_peak: f64,
    /// The chance maps' 97.5th percentile there.
    pub chance_auc_judd_high_at_peak: f64,
    /// LCC of the map as given against the truth density.
    pub lcc_unblurred: f64,
    /// The best LCC over the blur grid.
    pub lcc_peak: f64,
    /// The σ_b of that best LCC.
    pub lcc_peak_blur: f64,
    /// NSS of the map as given.
    pub nss_unblurred: f64,
    /// Gini index of the map as given (its sparsity).
    pub gini_unblurred: f64,
}

/// Everything [`score_mesh`] computes on one mesh.
#[derive(Debug, Clone, Serialize)]
pub struct MeshScore {
    /// Every metric of every map, the chance band and the human ceiling at every blur.
    pub rows: Vec<ScoreRow>,
    /// One summary per map, in the order given.
    pub summaries: Vec<MethodSummary>,
    /// Ordered (predictor, target) subject splits behind the human curve; 0 if none.
    pub human_splits: usize,
    /// Positive vertices of the truth (fixated, or the top fraction of a map).
    pub positives: usize,
    /// Fixations of a fixation set (0 for a per-vertex map).
    pub fixations: usize,
    /// AUC-Judd of every chance map at every blur, (σ_b, one value per map): what a band over
    /// several meshes is computed from (see [`chance_band_of_mean`]).
    pub chance_auc_judd: Vec<(f64, Vec<f64>)>,
}

/// The chance band of a mean over meshes: draw j of every mesh is averaged into one sample of
/// the mean (draws are independent across meshes), then the samples give the mean and the
/// 2.5th–97.5th percentiles at each blur. Meshes must share one blur grid and map count.
/// Returns (σ_b, mean, low, high).
pub fn chance_band_of_mean(
    meshes: &[&[(f64, Vec<f64>)]],
) -> Result<Vec<(f64, f64, f64, f64)>, ScoreError> {
    let Some(first) = meshes.first() else {
        return Ok(Vec::new());
    };
    let mut band = Vec::new();
    for (b, (sigma, draws)) in first.iter().enumerate() {
        let mut sums = vec![0.0; draws.len()];
        for m in meshes {
            let (s, d) = m.get(b).ok_or(ScoreError::MismatchedBands)?;
            if s != sigma || d.len() != draws.len() {
                return Err(ScoreError::MismatchedBands);
            }
            for (a, x) in sums.iter_mut().zip(d) {
                *a += x;
            }
        }
        let means: Vec<f64> = sums.iter().map(|x| x / meshes.len() as f64).collect();
        let mean = means.iter().sum::<f64>() / means.len() as f64;
        band.push((
            *sigma,
            mean,
            quantile(&means, 0.025),
            quantile(&means, 0.975),
        ));
    }
    Ok(band)
}

/// The chance band's mean over the random maps (per metric and blur), as a method name in
/// score rows.
pub const CHANCE: &str = "chance";
/// The chance band's 2.5th percentile, as a method name in score rows.
pub const CHANCE_LOW: &str = "chance_p2.5";
/// The chance band's 97.5th percentile, as a method name in score rows.
pub const CHANCE_HIGH: &str = "chance_p97.5";

/// The q-quantile (0..=1) of `values` by linear interpolation between order statistics
/// (Hyndman–Fan type 7, numpy's default); NaN when empty or when any value is NaN.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    if values.is_empty() || values.iter().any(|v| v.is_nan()) {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let h = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    v[lo] + (h - lo as f64) * (v[hi] - v[lo])
}

/// `count` random maps with values uniform in [0, 1), drawn in sequence from one seeded stream.
pub fn chance_maps(n: usize, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| (0..n).map(|_| rng.random::<f64>()).collect())
        .collect()
}
/// The split-half human ceiling, as a method name in score rows.
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
pub fn blur_grid(max: f64, step: f64) -> Result<Vec<f64>, ScoreError> {
    if !(step > 0.0 && max >= 0.0 && max / step <= 10_000.0) {
        return Err(ScoreError::BlurGrid);
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

/// Fixations per vertex, one map per subject of a fixation set (none for a vertex map).
fn subject_fixation_counts(truth: &GroundTruth, n: usize) -> Vec<Vec<f64>> {
    match truth {
        GroundTruth::Fixations(f) => f
            .subjects
            .iter()
            .map(|s| {
                let mut c = vec![0.0; n];
                for x in f.fixations.iter().filter(|x| &x.subject == s) {
                    c[x.vertex] += 1.0;
                }
                c
            })
            .collect(),
        GroundTruth::VertexMap(_) => Vec::new(),
    }
}

/// The maps' sum, vertex by vertex: 0 + m₀ + m₁ + …, in the maps' order. Four maps at a time
/// per pass over the vertices (the same additions in the same order: the same bits), since a
/// split-half side sums four subjects' maps for each of 70 splits at each of 21 blurs.
fn sum_of_maps<'a>(maps: impl Iterator<Item = &'a Vec<f64>>, n: usize) -> Vec<f64> {
    let maps: Vec<&Vec<f64>> = maps.collect();
    let mut d = vec![0.0; n];
    for group in maps.chunks(4) {
        match group {
            [a, b, c, e] => {
                let quads = a.iter().zip(b.iter()).zip(c.iter()).zip(e.iter());
                for (x, (((a, b), c), e)) in d.iter_mut().zip(quads) {
                    *x = *x + a + b + c + e;
                }
            }
            _ => {
                for m in group {
                    for (a, b) in d.iter_mut().zip(m.iter()) {
                        *a += b;
                    }
                }
            }
        }
    }
    d
}

/// What every map is scored against at one blur.
struct Target<'a> {
    positive: &'a [bool],
    fixated: &'a [usize],
    density: Vec<f64>,
    /// The density's statistics and distribution, the same for every map at this blur.
    density_stats: MeanStd,
    density_distribution: Option<Vec<f64>>,
    weights: Option<&'a [f64]>,
    params: &'a ScoreParams,
    seen: Option<&'a [bool]>,
}

impl Target<'_> {
    /// Every metric of one map; AUC-Judd comes first (the chance band reads it there).
    fn metrics_of(&self, map: &[f64]) -> Vec<(&'static str, f64)> {
        let (w, p) = (self.weights, self.params);
        // What several metrics of this map share, computed once (the same arithmetic as
        // each metric alone: the same bits).
        let stats = MeanStd::of(map, w);
        let distribution = as_distribution(map, w);
        let density = self.density_distribution.as_deref();
        // AUC-Judd over every negative and over the seen ones come from one pass.
        let (auc, auc_visible) = match self.seen {
            Some(seen) => {
                let (all, visible) = auc_judd_and_seen(map, self.positive, seen, w);
                (all, Some(visible))
            }
            None => (auc_judd(map, self.positive, w), None),
        };
        let mut metrics = vec![
            ("auc_judd", auc),
            (
                "auc_borji",
                auc_borji(map, self.fixated, w, p.borji_splits, p.seed),
            ),
            (
                "lcc",
                lcc_of(map, stats, &self.density, self.density_stats, w),
            ),
            ("nss", nss_of(map, stats, self.fixated)),
            ("sim", sim_of(distribution.as_deref(), density)),
            ("kl", kl_divergence_of(distribution.as_deref(), density)),
            (
                "gini",
                gini_index(&map.iter().map(|v| v.max(0.0)).collect::<Vec<_>>()),
            ),
        ];
        if let Some(visible) = auc_visible {
            metrics.push((AUC_JUDD_VISIBLE, visible));
        }
        metrics
    }
}

/// The metric name of AUC-Judd with never-shown vertices left out of the negatives.
pub const AUC_JUDD_VISIBLE: &str = "auc_judd_visible";

/// AUC-Judd over the positives and only those negatives with `seen` set: a vertex no view
/// ever showed cannot be a miss.
pub fn auc_judd_seen(
    map: &[f64],
    positive: &[bool],
    seen: &[bool],
    weights: Option<&[f64]>,
) -> f64 {
    auc_judd_and_seen(map, positive, seen, weights).1
}

/// One side of a human split: its subjects' summed map and what the metrics read of it.
struct SubjectSet {
    map: Vec<f64>,
    stats: MeanStd,
    /// Its subjects' fixated vertices, in file order (a vertex fixated twice is listed twice).
    fixated: Vec<usize>,
    positive: Vec<bool>,
}

impl SubjectSet {
    fn of(
        set: &[usize],
        fixations: &crate::scoring::ground_truth::FixationTruth,
        subject_maps: &[Vec<f64>],
        n: usize,
        weights: Option<&[f64]>,
    ) -> SubjectSet {
        let map = sum_of_maps(set.iter().map(|&s| &subject_maps[s]), n);
        let names: Vec<&String> = set.iter().map(|&s| &fixations.subjects[s]).collect();
        let fixated: Vec<usize> = fixations
            .fixations
            .iter()
            .filter(|x| names.contains(&&x.subject))
            .map(|x| x.vertex)
            .collect();
        let mut positive = vec![false; n];
        for &v in &fixated {
            positive[v] = true;
        }
        SubjectSet {
            stats: MeanStd::of(&map, weights),
            map,
            fixated,
            positive,
        }
    }
}

/// The split-half human ceiling at one blur: (metric, mean over splits) for AUC-Judd, LCC, NSS.
fn human_ceiling(
    fixations: &crate::scoring::ground_truth::FixationTruth,
    subject_maps: &[Vec<f64>],
    splits: &[(Vec<usize>, Vec<usize>)],
    weights: Option<&[f64]>,
) -> [(&'static str, f64); 3] {
    let n = subject_maps.first().map_or(0, |m| m.len());
    // Each subject set is a predictor in some splits and a target in others (every half of
    // eight subjects is both): its summed map, statistics, fixations and positives are made
    // once, by the same arithmetic the metrics would do alone (the same bits).
    let mut set_index: std::collections::HashMap<&[usize], usize> = Default::default();
    let mut sets: Vec<&[usize]> = Vec::new();
    let mut split_sets = Vec::with_capacity(splits.len());
    for (pred, target) in splits {
        let mut pair = [0; 2];
        for (slot, set) in pair.iter_mut().zip([pred, target]) {
            *slot = *set_index.entry(set.as_slice()).or_insert_with(|| {
                sets.push(set.as_slice());
                sets.len() - 1
            });
        }
        split_sets.push((pair[0], pair[1]));
    }
    let halves: Vec<SubjectSet> = sets
        .par_iter()
        .map(|set| SubjectSet::of(set, fixations, subject_maps, n, weights))
        .collect();
    // Splits in parallel, summed in split order afterwards: the same bytes on any thread count.
    let per_split: Vec<[f64; 3]> = split_sets
        .par_iter()
        .map(|&(p, t)| {
            let (predictor, target) = (&halves[p], &halves[t]);
            [
                auc_judd(&predictor.map, &target.positive, weights),
                lcc_of(
                    &predictor.map,
                    predictor.stats,
                    &target.map,
                    target.stats,
                    weights,
                ),
                nss_of(&predictor.map, predictor.stats, &target.fixated),
            ]
        })
        .collect();
    let (mut auc_sum, mut lcc_sum, mut nss_sum) = (0.0, 0.0, 0.0);
    for [a, l, m] in per_split {
        auc_sum += a;
        lcc_sum += l;
        nss_sum += m;
    }
    let k = splits.len() as f64;
    [
        ("auc_judd", auc_sum / k),
        ("lcc", lcc_sum / k),
        ("nss", nss_sum / k),
    ]
}

/// Each method's (and chance's) values unblurred and at its peak over blur.
fn summaries_of(rows: &[ScoreRow], methods: &[(String, Vec<f64>)]) -> Vec<MethodSummary> {
    methods
        .iter()
        .map(|(name, _)| name.as_str())
        .chain([CHANCE])
        .map(|name| {
            let (auc_peak, auc_blur) = argmax_over_blur(rows, name, "auc_judd");
            let (lcc_peak, lcc_blur) = argmax_over_blur(rows, name, "lcc");
            MethodSummary {
                method: name.to_string(),
                auc_judd_unblurred: value_at(rows, name, "auc_judd", 0.0),
                auc_judd_visible_unblurred: value_at(rows, name, AUC_JUDD_VISIBLE, 0.0),
                auc_judd_peak: auc_peak,
                auc_judd_peak_blur: auc_blur,
                chance_auc_judd_at_peak: value_at(rows, CHANCE, "auc_judd", auc_blur),
                chance_auc_judd_low_at_peak: value_at(rows, CHANCE_LOW, "auc_judd", auc_blur),
                chance_auc_judd_high_at_peak: value_at(rows, CHANCE_HIGH, "auc_judd", auc_blur),
                lcc_unblurred: value_at(rows, name, "lcc", 0.0),
                lcc_peak,
                lcc_peak_blur: lcc_blur,
                nss_unblurred: value_at(rows, name, "nss", 0.0),
                gini_unblurred: value_at(rows, name, "gini", 0.0),
            }
        })
        .collect()
}

/// Scores `maps` (name, one value per vertex) against `truth` on `mesh`.
///
/// `seen` (one flag per vertex: shown by some hold view of the stimulus) adds the metric
/// `auc_judd_visible`, AUC-Judd with never-shown vertices left out of the negatives.
pub fn score_mesh(
    mesh: &Mesh,
    truth: &GroundTruth,
    maps: &[(String, Vec<f64>)],
    params: &ScoreParams,
    seen: Option<&[bool]>,
    progress: &dyn Progress,
) -> Result<MeshScore, ScoreError> {
    if seen.is_some_and(|s| s.len() != mesh.positions.len()) {
        return Err(ScoreError::Invalid(
            "the visibility flags must have one entry per vertex",
        ));
    }
    if params.chance_maps == 0 {
        return Err(ScoreError::Invalid(
            "the chance band needs at least one random map",
        ));
    }
    let n = mesh.positions.len();
    let norm = Normalization::of_mesh(mesh, params.bounding_box);
    let areas = vertex_areas(mesh);
    let blur = MeshBlur::new(&norm.normalized_mesh(mesh), params.kernel);
    let weights = (params.weighting == Weighting::Area).then_some(areas.as_slice());
    let positive = truth.positive(n);
    let fixated = truth.fixated();
    let chance = chance_maps(n, params.chance_maps, params.seed);
    let subject_counts = subject_fixation_counts(truth, n);
    let splits = match truth {
        GroundTruth::Fixations(f) => {
            human_splits(f.subjects.len(), params.human_random_splits, params.seed)
        }
        GroundTruth::VertexMap(_) => Vec::new(),
    };
    progress.start("scoring over blur", params.blur_sigmas.len() as u64);
    // The blur levels run side by side (each is parallel inside but has serial steps between
    // its parallel ones: grouping sources, reordering rows, the chance band's quantiles), and
    // their rows are joined in σ order afterwards: the same bytes on any thread count.
    let per_sigma: Vec<(Vec<ScoreRow>, Vec<f64>)> = params
        .blur_sigmas
        .par_iter()
        .map(|&sigma| {
            let mut rows = Vec::new();
            let mut push = |method: &str, metric: &'static str, value: f64| {
                rows.push(ScoreRow {
                    method: method.to_string(),
                    metric,
                    blur: sigma,
                    value,
                })
            };
            let mut inputs: Vec<&[f64]> = maps.iter().map(|(_, m)| m.as_slice()).collect();
            inputs.extend(subject_counts.iter().map(|c| c.as_slice()));
            // The chance maps matter only as samples of a distribution (the band), so where
            // the blur merges sources they go to first order, four channels to a method's ten.
            let references: Vec<&[f64]> = chance.iter().map(|c| c.as_slice()).collect();
            let blurred = blur.blur_with_references(&inputs, &references, sigma)?;
            let (method_maps, rest) = blurred.split_at(maps.len());
            let (subject_maps, chance_blurred) = rest.split_at(subject_counts.len());
            let density = match truth {
                GroundTruth::VertexMap(m) => m.values.clone(),
                GroundTruth::Fixations(_) => sum_of_maps(subject_maps.iter(), n),
            };
            let target = Target {
                positive: &positive,
                fixated: &fixated,
                density_stats: MeanStd::of(&density, weights),
                density_distribution: as_distribution(&density, weights),
                density,
                weights,
                params,
                seen,
            };
            // Every map's metrics in parallel (Gini sorts each map): rows keep the maps' order.
            let mut all_metrics: Vec<Vec<(&'static str, f64)>> = method_maps
                .par_iter()
                .chain(chance_blurred.par_iter())
                .map(|m| target.metrics_of(m))
                .collect();
            let chance_metrics = all_metrics.split_off(maps.len());
            for ((name, _), metrics) in maps.iter().zip(all_metrics) {
                for (metric, value) in metrics {
                    push(name, metric, value);
                }
            }
            let chance_auc: Vec<f64> = chance_metrics.iter().map(|m| m[0].1).collect();
            for (j, (metric, _)) in chance_metrics[0].iter().enumerate() {
                let values: Vec<f64> = chance_metrics.iter().map(|m| m[j].1).collect();
                push(
                    CHANCE,
                    metric,
                    values.iter().sum::<f64>() / values.len() as f64,
                );
                push(CHANCE_LOW, metric, quantile(&values, 0.025));
                push(CHANCE_HIGH, metric, quantile(&values, 0.975));
            }
            if let (GroundTruth::Fixations(f), false) = (truth, splits.is_empty()) {
                for (metric, value) in human_ceiling(f, subject_maps, &splits, weights) {
                    push(HUMAN, metric, value);
                }
            }
            progress.advance(1);
            Ok((rows, chance_auc))
        })
        .collect::<Result<_, ScoreError>>()?;
    let mut rows = Vec::new();
    let mut chance_auc_judd = Vec::new();
    for (&sigma, (sigma_rows, chance_auc)) in params.blur_sigmas.iter().zip(per_sigma) {
        rows.extend(sigma_rows);
        chance_auc_judd.push((sigma, chance_auc));
    }
    progress.finish();
    Ok(MeshScore {
        summaries: summaries_of(&rows, maps),
        rows,
        human_splits: splits.len(),
        positives: positive.iter().filter(|p| **p).count(),
        fixations: fixated.len(),
        chance_auc_judd,
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

    /// `count` fixations of `subjects` subjects taking turns, on every `stride`-th vertex.
    fn spread_fixations(mesh: &Mesh, subjects: usize, count: usize, stride: usize) -> GroundTruth {
        use crate::scoring::ground_truth::{Fixation, FixationTruth};
        let n = mesh.positions.len();
        let names: Vec<String> = (0..subjects).map(|s| format!("s{s}")).collect();
        let fixations: Vec<Fixation> = (0..count)
            .map(|i| Fixation {
                subject: names[i % subjects].clone(),
                vertex: (i * stride) % n,
            })
            .collect();
        GroundTruth::Fixations(FixationTruth {
            rows: fixations.len(),
            fixations,
            subjects: names,
            rows_not_on_mesh: Default::default(),
        })
    }

    /// The truth build keeps only the human rows and scores with one chance map: they must not
    /// depend on how many there are.
    #[test]
    fn human_rows_do_not_depend_on_the_chance_band() {
        use crate::progress::Silent;
        let mesh = crate::mesh::test_meshes::icosphere(1.0, 3);
        let truth = spread_fixations(&mesh, 6, 60, 37);
        let human_rows = |chance_maps: usize| {
            let params = ScoreParams {
                chance_maps,
                blur_sigmas: vec![0.0, 0.05, 0.2],
                ..ScoreParams::default()
            };
            let score = score_mesh(&mesh, &truth, &[], &params, None, &Silent).unwrap();
            score
                .rows
                .into_iter()
                .filter(|r| r.method == HUMAN)
                .map(|r| (r.metric, r.blur.to_bits(), r.value.to_bits()))
                .collect::<Vec<_>>()
        };
        let one = human_rows(1);
        assert_eq!(one.len(), 9);
        assert_eq!(one, human_rows(20));
    }

    /// The blur levels and maps run side by side: the rows must be the same bytes, in the same
    /// order, whatever the thread count.
    #[test]
    fn rows_are_the_same_bytes_on_one_or_three_threads() {
        use crate::progress::Silent;
        let mesh = crate::mesh::test_meshes::icosphere(1.0, 3);
        let truth = spread_fixations(&mesh, 4, 40, 53);
        let height: Vec<f64> = mesh.positions.iter().map(|p| p.z).collect();
        let maps = vec![("height".to_string(), height)];
        let params = ScoreParams {
            chance_maps: 5,
            blur_sigmas: vec![0.0, 0.05, 0.1, 0.3, 0.6],
            ..ScoreParams::default()
        };
        let rows_on = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| score_mesh(&mesh, &truth, &maps, &params, None, &Silent))
                .unwrap()
                .rows
                .into_iter()
                .map(|r| (r.method, r.metric, r.blur.to_bits(), r.value.to_bits()))
                .collect::<Vec<_>>()
        };
        let one = rows_on(1);
        assert!(one.iter().any(|r| r.0 == HUMAN && r.2 == 0.6f64.to_bits()));
        assert_eq!(one, rows_on(3));
    }

    /// Four maps a pass give the bits of one map at a time, for any count of maps.
    #[test]
    fn maps_sum_as_one_at_a_time() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let n = 1001;
        let maps: Vec<Vec<f64>> = (0..9)
            .map(|_| (0..n).map(|_| rng.random::<f64>() * 1e3 - 1.0).collect())
            .collect();
        for count in 0..=maps.len() {
            let mut expected = vec![0.0; n];
            for m in &maps[..count] {
                for (a, b) in expected.iter_mut().zip(m) {
                    *a += b;
                }
            }
            let got = sum_of_maps(maps[..count].iter(), n);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&expected), "{count} maps");
        }
    }

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        let v: Vec<f64> = (1..=20).rev().map(f64::from).collect();
        assert_eq!(quantile(&v, 0.0), 1.0);
        assert_eq!(quantile(&v, 1.0), 20.0);
        assert!((quantile(&v, 0.025) - 1.475).abs() < 1e-12);
        assert!((quantile(&v, 0.975) - 19.525).abs() < 1e-12);
        assert!(quantile(&[], 0.5).is_nan());
        assert!(quantile(&[1.0, f64::NAN], 0.5).is_nan());
    }
}

//! Gradient-boosted regression trees for a binary label (logistic loss), on histogram splits.
//!
//! Written here rather than taken from a crate: `perpetual` (the maintained Rust GBM) needs
//! a nightly compiler (E0554 on this toolchain, versions 1.1 to 2.3), and `gbdt` 0.1.3 has
//! had no release since 2020, samples with `thread_rng` (not seedable) and tries every value
//! as a split. This one is small, has no randomness at all (every row and feature is used),
//! and gives the same bytes on any number of threads: each feature's histogram is summed in
//! row order, and ties between splits go to the lower feature, then the lower bin.
use crate::gaze_model::TreesError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Gradient-boosted trees' training parameters (logistic loss).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoostParams {
    /// Trees.
    pub rounds: usize,
    /// Shrinkage of each tree's values.
    pub learning_rate: f64,
    /// Deepest split level.
    pub max_depth: usize,
    /// Smallest summed hessian (≈ weighted rows × p(1−p)) a child may have.
    pub min_child_hessian: f64,
    /// L2 penalty on leaf values.
    pub lambda: f64,
    /// Histogram bins per feature (quantiles of the training values), at most 255.
    pub bins: usize,
}

impl Default for BoostParams {
    fn default() -> Self {
        BoostParams {
            rounds: 200,
            learning_rate: 0.1,
            max_depth: 4,
            min_child_hessian: 5.0,
            lambda: 1.0,
            bins: 64,
        }
    }
}

/// One node: a split `value <= threshold` (left) or a leaf (`feature` = None).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Node {
    /// The feature a split tests (None: a leaf).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub feature: Option<usize>,
    /// A split's threshold.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub threshold: Option<f64>,
    /// The node for `value <= threshold`.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub left: Option<usize>,
    /// The node for the rest.
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub right: Option<usize>,
    /// A leaf's value (log-odds).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub value: Option<f64>,
}

/// One regression tree.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Tree {
    /// Its nodes; the root is the first.
    pub nodes: Vec<Node>,
}

impl Tree {
    fn predict(&self, row: impl Fn(usize) -> f64) -> f64 {
        let mut i = 0;
        loop {
            let node = &self.nodes[i];
            match (node.feature, node.threshold, node.left, node.right) {
                (Some(f), Some(t), Some(l), Some(r)) => i = if row(f) <= t { l } else { r },
                _ => return node.value.unwrap_or(0.0),
            }
        }
    }
}

/// A trained ensemble: log-odds = `base` + Σ trees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoostedTrees {
    /// How it was trained.
    pub params: BoostParams,
    /// The log-odds before any tree (the weighted base rate).
    pub base: f64,
    /// The trees, in training order.
    pub trees: Vec<Tree>,
    /// Total split gain per feature, summed over all trees (what the model leans on).
    pub gain: Vec<f64>,
}

impl BoostedTrees {
    /// Log-odds of every row of a column-major matrix.
    pub fn predict(&self, columns: &[Vec<f64>]) -> Vec<f64> {
        let n = columns.first().map_or(0, Vec::len);
        (0..n)
            .into_par_iter()
            .map(|i| {
                self.base
                    + self
                        .trees
                        .iter()
                        .map(|t| t.predict(|f| columns[f][i]))
                        .sum::<f64>()
            })
            .collect()
    }
}

/// Trains on a column-major matrix with labels and row weights.
pub fn train(
    columns: &[Vec<f64>],
    labels: &[bool],
    weights: &[f64],
    params: &BoostParams,
) -> Result<BoostedTrees, TreesError> {
    let n = labels.len();
    if n == 0 || columns.iter().any(|c| c.len() != n) || weights.len() != n {
        return Err(TreesError::Lengths);
    }
    if params.bins < 2 || params.bins > 255 {
        return Err(TreesError::Bins(params.bins));
    }
    if columns.iter().flatten().any(|v| !v.is_finite()) {
        return Err(TreesError::NotFinite);
    }
    let positive: f64 = (0..n).filter(|&i| labels[i]).map(|i| weights[i]).sum();
    let total: f64 = weights.iter().sum();
    if positive <= 0.0 || positive >= total {
        return Err(TreesError::OneClass);
    }
    let thresholds: Vec<Vec<f64>> = columns
        .iter()
        .map(|c| quantile_edges(c, params.bins))
        .collect();
    let binned: Vec<Vec<u8>> = columns
        .par_iter()
        .zip(&thresholds)
        .map(|(c, t)| c.iter().map(|&v| bin_of(v, t)).collect())
        .collect();
    let base = (positive / (total - positive)).ln();
    let mut score = vec![base; n];
    let mut trees = Vec::with_capacity(params.rounds);
    let mut gain = vec![0.0; columns.len()];
    let mut grad = vec![0.0; n];
    let mut hess = vec![0.0; n];
    for _ in 0..params.rounds {
        for i in 0..n {
            let p = 1.0 / (1.0 + (-score[i]).exp());
            grad[i] = weights[i] * (p - labels[i] as u8 as f64);
            hess[i] = weights[i] * (p * (1.0 - p)).max(1e-12);
        }
        let mut builder = TreeBuilder {
            binned: &binned,
            thresholds: &thresholds,
            grad: &grad,
            hess: &hess,
            params,
            nodes: Vec::new(),
            gain: &mut gain,
        };
        let rows: Vec<u32> = (0..n as u32).collect();
        builder.grow(rows, 0);
        let tree = Tree {
            nodes: builder.nodes,
        };
        for (i, s) in score.iter_mut().enumerate() {
            *s += tree.predict(|f| columns[f][i]);
        }
        trees.push(tree);
    }
    Ok(BoostedTrees {
        params: params.clone(),
        base,
        trees,
        gain,
    })
}

struct TreeBuilder<'a> {
    binned: &'a [Vec<u8>],
    thresholds: &'a [Vec<f64>],
    grad: &'a [f64],
    hess: &'a [f64],
    params: &'a BoostParams,
    nodes: Vec<Node>,
    gain: &'a mut [f64],
}

impl TreeBuilder<'_> {
    /// Adds the subtree over `rows` and returns its root's index.
    fn grow(&mut self, rows: Vec<u32>, depth: usize) -> usize {
        let g: f64 = rows.iter().map(|&i| self.grad[i as usize]).sum();
        let h: f64 = rows.iter().map(|&i| self.hess[i as usize]).sum();
        let me = self.nodes.len();
        self.nodes.push(Node {
            feature: None,
            threshold: None,
            left: None,
            right: None,
            value: Some(-self.params.learning_rate * g / (h + self.params.lambda)),
        });
        if depth >= self.params.max_depth {
            return me;
        }
        let Some((feature, bin, gain)) = self.best_split(&rows, g, h) else {
            return me;
        };
        self.gain[feature] += gain;
        let (left, right): (Vec<u32>, Vec<u32>) = rows
            .iter()
            .partition(|&&i| self.binned[feature][i as usize] <= bin);
        let l = self.grow(left, depth + 1);
        let r = self.grow(right, depth + 1);
        self.nodes[me] = Node {
            feature: Some(feature),
            threshold: Some(self.thresholds[feature][bin as usize]),
            left: Some(l),
            right: Some(r),
            value: None,
        };
        me
    }

    /// The split with the largest gain: (feature, last bin going left, gain).
    fn best_split(&self, rows: &[u32], g: f64, h: f64) -> Option<(usize, u8, f64)> {
        let lambda = self.params.lambda;
        let parent = g * g / (h + lambda);
        let min_h = self.params.min_child_hessian;
        let per_feature: Vec<Option<(u8, f64)>> = (0..self.binned.len())
            .into_par_iter()
            .map(|f| {
                let bins = self.thresholds[f].len() + 1;
                let mut hg = vec![0.0; bins];
                let mut hh = vec![0.0; bins];
                let column = &self.binned[f];
                for &i in rows {
                    let b = column[i as usize] as usize;
                    hg[b] += self.grad[i as usize];
                    hh[b] += self.hess[i as usize];
                }
                let mut best: Option<(u8, f64)> = None;
                let (mut gl, mut hl) = (0.0, 0.0);
                for b in 0..bins - 1 {
                    gl += hg[b];
                    hl += hh[b];
                    let (gr, hr) = (g - gl, h - hl);
                    if hl < min_h || hr < min_h {
                        continue;
                    }
                    let gain = gl * gl / (hl + lambda) + gr * gr / (hr + lambda) - parent;
                    if gain > best.map_or(1e-12, |b| b.1) {
                        best = Some((b as u8, gain));
                    }
                }
                best
            })
            .collect();
        let mut best: Option<(usize, u8, f64)> = None;
        for (f, s) in per_feature.into_iter().enumerate() {
            if let Some((b, gain)) = s {
                if gain > best.map_or(0.0, |x| x.2) {
                    best = Some((f, b, gain));
                }
            }
        }
        best
    }
}

/// Up to `bins − 1` distinct split values: midpoints between neighbouring quantiles.
fn quantile_edges(values: &[f64], bins: usize) -> Vec<f64> {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let n = sorted.len();
    let mut edges: Vec<f64> = Vec::with_capacity(bins - 1);
    for k in 1..bins {
        let i = (k * n / bins).min(n - 1);
        if i == 0 {
            continue;
        }
        let (a, b) = (sorted[i - 1], sorted[i]);
        if a < b {
            let edge = 0.5 * (a + b);
            if edges.last().is_none_or(|&last| edge > last) {
                edges.push(edge);
            }
        }
    }
    edges
}

/// The bin of a value: the number of edges below it (so bin b means edge[b−1] < v ≤ edge[b]).
fn bin_of(value: f64, edges: &[f64]) -> u8 {
    edges.partition_point(|&e| e < value) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn learns_an_interaction_no_single_feature_shows() {
        // Label = (x > 0.5) xor (y > 0.5): each feature alone is useless.
        let n = 4000;
        let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % n) as f64 / n as f64).collect();
        let y: Vec<f64> = (0..n)
            .map(|i| ((i * 104_729) % n) as f64 / n as f64)
            .collect();
        let labels: Vec<bool> = (0..n).map(|i| (x[i] > 0.5) != (y[i] > 0.5)).collect();
        let model = train(
            &[x.clone(), y.clone()],
            &labels,
            &vec![1.0; n],
            &BoostParams {
                rounds: 30,
                ..Default::default()
            },
        )
        .unwrap();
        let scores = model.predict(&[x, y]);
        let correct = (0..n).filter(|&i| (scores[i] > 0.0) == labels[i]).count();
        assert!(correct as f64 > 0.98 * n as f64, "{correct}");
    }

    #[test]
    fn same_bytes_on_one_and_two_threads() {
        let n = 3000;
        let cols: Vec<Vec<f64>> = (0..5)
            .map(|f| {
                (0..n)
                    .map(|i| ((i * (f + 3) * 7919) % 1009) as f64)
                    .collect()
            })
            .collect();
        let labels: Vec<bool> = (0..n)
            .map(|i| (cols[0][i] + cols[2][i]) % 3.0 == 0.0)
            .collect();
        let fit = |threads| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| train(&cols, &labels, &vec![1.0; n], &BoostParams::default()))
                .unwrap()
        };
        let (a, b) = (fit(1), fit(2));
        assert_eq!(
            serde_json::to_string(&a).unwrap(),
            serde_json::to_string(&b).unwrap()
        );
    }
}

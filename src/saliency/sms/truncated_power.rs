//! Sparse leading eigenvector by the truncated power method (Yuan & Zhang, JMLR 2013), as the
//! paper §3.4 applies it: shift the metric by its principal eigenvalue ν so M + νI is
//! positive semidefinite, start from the principal eigenvector, then repeat
//! "multiply by M + νI, keep the k largest entries, normalize".
//!
//! The metric is a Euclidean distance matrix: exactly one positive eigenvalue and trace 0, so
//! |λ_min| ≤ λ_1 and M + λ_1 I ⪰ 0. On unit vectors the shift adds the constant ν to the
//! objective, so the sparse optimum is unchanged. All entries are ≥ 0 and so is the start,
//! hence every iterate is ≥ 0 (the paper's constraint φ ≥ 0 holds without projection).
use serde::Serialize;

use super::descriptor_metric::{deterministic_dot, SymmetricOperator};

/// Limits of the power iterations (the principal eigenpair and the truncated power method).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct PowerParams {
    /// Iterations at most.
    pub max_iterations: usize,
    /// Stop when the Rayleigh quotient changes by less than this, relative.
    pub tolerance: f64,
}

impl Default for PowerParams {
    fn default() -> Self {
        PowerParams {
            max_iterations: 1000,
            tolerance: 1e-12,
        }
    }
}

/// How the principal eigenpair was found.
#[derive(Debug, Clone, Serialize)]
pub struct EigenReport {
    /// The largest eigenvalue.
    pub value: f64,
    /// Iterations run.
    pub iterations: usize,
    /// Whether the tolerance was met before the limit.
    pub converged: bool,
}

/// Principal eigenpair by power iteration from the constant vector 1/√n (the Perron vector of
/// a non-negative matrix is positive, so this start has a component along it).
pub fn principal_eigenpair(
    op: &dyn SymmetricOperator,
    params: PowerParams,
) -> (EigenReport, Vec<f64>) {
    let n = op.size();
    let mut x = vec![1.0 / (n as f64).sqrt(); n];
    let mut y = vec![0.0; n];
    let mut lambda = 0.0;
    for it in 1..=params.max_iterations {
        op.apply(&x, &mut y);
        let new_lambda = deterministic_dot(&x, &y);
        let norm = deterministic_dot(&y, &y).sqrt();
        if norm == 0.0 {
            return (
                EigenReport {
                    value: 0.0,
                    iterations: it,
                    converged: true,
                },
                x,
            );
        }
        x.iter_mut().zip(&y).for_each(|(a, b)| *a = b / norm);
        let done = (new_lambda - lambda).abs() <= params.tolerance * new_lambda.abs();
        lambda = new_lambda;
        if done {
            return (
                EigenReport {
                    value: lambda,
                    iterations: it,
                    converged: true,
                },
                x,
            );
        }
    }
    (
        EigenReport {
            value: lambda,
            iterations: params.max_iterations,
            converged: false,
        },
        x,
    )
}

/// How the truncated power method ran.
#[derive(Debug, Clone, Serialize)]
pub struct TruncatedPowerReport {
    /// Non-zeros kept (k = round(μ n)).
    pub k: usize,
    /// The shift ν added to the diagonal.
    pub shift: f64,
    /// Iterations run.
    pub iterations: usize,
    /// Whether the tolerance was met before the limit.
    pub converged: bool,
    /// xᵀ M x of the result, without the shift.
    pub objective: f64,
    /// xᵀ M x of the truncated start vector.
    pub start_objective: f64,
}

/// Indices of the k largest entries, ties broken by the lower index (deterministic).
pub fn top_k_indices(v: &[f64], k: usize) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    let k = k.min(v.len());
    if k == 0 {
        return Vec::new();
    }
    let cmp = |a: &usize, b: &usize| v[*b].total_cmp(&v[*a]).then(a.cmp(b));
    if k < idx.len() {
        idx.select_nth_unstable_by(k - 1, cmp);
        idx.truncate(k);
    }
    idx.sort_unstable();
    idx
}

/// Keeps the entries at `support`, zeroes the rest, normalizes to unit length.
fn truncate_normalize(v: &[f64], support: &[usize]) -> Vec<f64> {
    let mut x = vec![0.0; v.len()];
    let mut norm2 = 0.0;
    for &i in support {
        x[i] = v[i];
        norm2 += v[i] * v[i];
    }
    let norm = norm2.sqrt();
    if norm > 0.0 {
        for &i in support {
            x[i] /= norm;
        }
    }
    x
}

/// Maximizes xᵀ(M + shift·I)x over unit x with at most k non-zeros, from `start`.
/// Stops when the support no longer changes and the objective changes by less than
/// `params.tolerance` (relative), or after `params.max_iterations`.
pub fn truncated_power(
    op: &dyn SymmetricOperator,
    shift: f64,
    start: &[f64],
    k: usize,
    params: PowerParams,
) -> (TruncatedPowerReport, Vec<f64>) {
    let n = op.size();
    let k = k.clamp(1, n);
    let mut support = top_k_indices(start, k);
    let mut x = truncate_normalize(start, &support);
    let mut s = vec![0.0; n];
    let shifted = |x: &[f64], s: &mut [f64]| {
        op.apply(x, s);
        s.iter_mut().zip(x).for_each(|(si, xi)| *si += shift * xi);
    };
    shifted(&x, &mut s);
    let start_objective = deterministic_dot(&x, &s) - shift;
    let mut objective = start_objective;
    let mut iterations = 0;
    let mut converged = false;
    while iterations < params.max_iterations {
        iterations += 1;
        let new_support = top_k_indices(&s, k);
        let x_new = truncate_normalize(&s, &new_support);
        shifted(&x_new, &mut s);
        let new_objective = deterministic_dot(&x_new, &s) - shift;
        let same_support = new_support == support;
        let small_change = (new_objective - objective).abs()
            <= params.tolerance * (new_objective + shift).abs().max(f64::MIN_POSITIVE);
        x = x_new;
        support = new_support;
        objective = new_objective;
        if same_support && small_change {
            converged = true;
            break;
        }
    }
    (
        TruncatedPowerReport {
            k,
            shift,
            iterations,
            converged,
            objective,
            start_objective,
        },
        x,
    )
}

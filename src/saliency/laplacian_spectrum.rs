//! Every eigenpair of a weighted graph Laplacian L = D − W (SI's full spectrum), in double
//! precision or in single precision refined in double.
//!
//! faer's dense symmetric eigendecomposition of SI's 2,500-vertex Laplacian was 40% of SI's
//! time and the largest single step of `score` on the 50k armadillo; half of it reduces the
//! matrix to tridiagonal form, which streams the 50 MB matrix once per column. In f32 the
//! matrix is half as large and each SIMD register holds twice the lanes, so the same
//! decomposition takes about half the time. f32 alone is not accurate enough: its eigenvectors
//! mix with their neighbours in the spectrum by ~ε₃₂‖L‖/gap ≈ 10⁻⁴, which moved SI's map by up
//! to 0.027 (of its [0, 1] range) on the armadillo. A Rayleigh–Ritz step in f64 on overlapping
//! windows of consecutive eigenvectors undoes that mixing, since it is largest between near
//! neighbours: on each window V, the f64 problem (Vᵀ L V) y = μ (Vᵀ V) y is solved and V
//! replaced by its Ritz vectors. L's sparsity keeps L V cheap. With windows of 128 the
//! armadillo's SI map is within 9.0e-4 of the f64 one and its AUC-Judd and LCC within 2.2e-5
//! and 1.1e-4 at every blur (docs/baselines.md; tests/gaussian_sum.rs bounds the maps).
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

use super::rarity::pca::{symmetric_eigen, symmetric_eigen_in};
use serde::Serialize;

/// How SI's eigenpairs are computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Eigensolver {
    /// faer's f64 decomposition of the dense Laplacian.
    Double,
    /// faer's f32 decomposition, then the f64 Rayleigh–Ritz step on windows of `window`
    /// consecutive eigenvectors, each overlapping the next by half.
    SingleRefined {
        /// Eigenvectors per window (2 or more).
        window: usize,
    },
}

/// Eigenvalues (ascending), eigenvectors (the columns, in the same order) and how many of the
/// eigenvalues are zero (the constant modes).
pub struct LaplacianSpectrum {
    /// Eigenvalues, ascending.
    pub values: Vec<f64>,
    /// Unit eigenvectors, column k for value k.
    pub vectors: Mat<f64>,
    /// How many of the smallest values are the constant modes (zero).
    pub zero_modes: usize,
}

/// The spectrum of L for `n` vertices and the undirected `edges` (each once) with weights
/// `weight` (positive or zero).
pub fn laplacian_spectrum(
    n: usize,
    edges: &[(usize, usize)],
    weight: &dyn Fn(usize, usize) -> f64,
    solver: Eigensolver,
) -> Result<LaplacianSpectrum, String> {
    let mut sorted: Vec<(usize, usize)> =
        edges.iter().map(|&(a, b)| (a.min(b), a.max(b))).collect();
    sorted.sort_unstable();
    if let Some(w) = sorted.windows(2).find(|w| w[0] == w[1]) {
        return Err(format!("the edge {:?} is listed twice", w[0]));
    }
    if let Some(&(a, b)) = sorted.iter().find(|&&(a, b)| a == b || b >= n) {
        return Err(format!(
            "the edge ({a}, {b}) is a loop or names a vertex ≥ {n}"
        ));
    }
    let weights: Vec<f64> = edges.iter().map(|&(a, b)| weight(a, b)).collect();
    match solver {
        Eigensolver::Double => {
            let (values, vectors) = dense_evd::<f64>(n, edges, &weights, |w| w)?;
            // Eigenvalues at or below 10⁻¹² of the largest are the constant modes, as in
            // Song et al.'s MATLAB code; in f64 they come out near 10⁻¹⁵‖L‖.
            let largest = values.iter().cloned().fold(0.0, f64::max);
            let zero_modes = values.iter().filter(|&&l| l <= 1e-12 * largest).count();
            Ok(LaplacianSpectrum {
                values,
                vectors,
                zero_modes,
            })
        }
        Eigensolver::SingleRefined { window } => {
            if window < 2 {
                return Err(format!(
                    "the refinement window must hold 2 eigenvectors or more, got {window}"
                ));
            }
            let (_, vectors32) = dense_evd::<f32>(n, edges, &weights, |w| w as f32)?;
            let mut vectors = Mat::<f64>::from_fn(n, n, |r, c| vectors32[(r, c)] as f64);
            drop(vectors32);
            let laplacian = SparseLaplacian::new(n, edges, &weights);
            let mut values = vec![0.0; n];
            refine_in_windows(&laplacian, &mut vectors, &mut values, window)?;
            sort_ascending(&mut values, &mut vectors);
            // f32's constant modes keep ~10⁻¹⁰‖L‖ after refinement, so they are told by count:
            // L has one zero eigenvalue per connected component of its positive edges.
            let zero_modes = connected_components(n, edges, &weights);
            Ok(LaplacianSpectrum {
                values,
                vectors,
                zero_modes,
            })
        }
    }
}

/// faer's dense decomposition in precision T (f32 or f64).
fn dense_evd<T>(
    n: usize,
    edges: &[(usize, usize)],
    weights: &[f64],
    to: impl Fn(f64) -> T,
) -> Result<(Vec<f64>, Mat<T>), String>
where
    T: faer::traits::RealField + Copy + Into<f64>,
{
    let mut laplacian = Mat::<T>::zeros(n, n);
    // The diagonal is summed in f64 and rounded once, so a row of L sums to zero as closely
    // as T allows.
    let mut degree = vec![0.0f64; n];
    // Each edge is listed once, so each off-diagonal entry is set once.
    for (&(a, b), &w) in edges.iter().zip(weights) {
        laplacian[(a, b)] = to(-w);
        laplacian[(b, a)] = to(-w);
        degree[a] += w;
        degree[b] += w;
    }
    for (i, d) in degree.iter().enumerate() {
        laplacian[(i, i)] = to(*d);
    }
    // Always split in two, whatever the pool's size: faer partitions the work by this count,
    // not by the threads that run it, so the bytes are the same on 1, 2 or more threads
    // (tests/sms.rs) while 2 cores share the work (bunny 4.6 s -> 2.7 s).
    symmetric_eigen_in(laplacian.as_ref(), Par::rayon(2))
}

/// L in compressed rows: row i is d_i at the diagonal and −w_ij at its neighbours.
struct SparseLaplacian {
    degree: Vec<f64>,
    starts: Vec<usize>,
    neighbours: Vec<(usize, f64)>,
}

impl SparseLaplacian {
    fn new(n: usize, edges: &[(usize, usize)], weights: &[f64]) -> Self {
        let mut degree = vec![0.0; n];
        let mut count = vec![0usize; n + 1];
        for (&(a, b), &w) in edges.iter().zip(weights) {
            degree[a] += w;
            degree[b] += w;
            count[a + 1] += 1;
            count[b + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let starts = count.clone();
        let mut fill = count;
        let mut neighbours = vec![(0, 0.0); 2 * edges.len()];
        for (&(a, b), &w) in edges.iter().zip(weights) {
            neighbours[fill[a]] = (b, w);
            fill[a] += 1;
            neighbours[fill[b]] = (a, w);
            fill[b] += 1;
        }
        SparseLaplacian {
            degree,
            starts,
            neighbours,
        }
    }

    /// out = L x for one column.
    fn times(&self, x: &[f64], out: &mut [f64]) {
        for (i, o) in out.iter_mut().enumerate() {
            let mut s = self.degree[i] * x[i];
            for &(j, w) in &self.neighbours[self.starts[i]..self.starts[i + 1]] {
                s -= w * x[j];
            }
            *o = s;
        }
    }
}

/// The f64 Rayleigh–Ritz step on windows [k, k + window) for k = 0, window/2, …, the last
/// one ending at n. Each window's Ritz pairs replace its columns, so a column is final once
/// no later window holds it.
fn refine_in_windows(
    laplacian: &SparseLaplacian,
    vectors: &mut Mat<f64>,
    values: &mut [f64],
    window: usize,
) -> Result<(), String> {
    let n = vectors.nrows();
    if n == 0 {
        return Ok(());
    }
    let par = Par::rayon(2);
    let stride = (window / 2).max(1);
    let mut start = 0;
    loop {
        let m = window.min(n);
        let start_here = start.min(n - m);
        let v = vectors.subcols(start_here, m).to_owned();
        let mut lv = Mat::<f64>::zeros(n, m);
        for c in 0..m {
            let column = v
                .col(c)
                .try_as_col_major()
                .expect("an owned Mat is column-major");
            let out = lv
                .col_mut(c)
                .try_as_col_major_mut()
                .expect("an owned Mat is column-major");
            laplacian.times(column.as_slice(), out.as_slice_mut());
        }
        let mut gram = Mat::<f64>::zeros(m, m);
        matmul(
            gram.as_mut(),
            Accum::Replace,
            v.transpose(),
            v.as_ref(),
            1.0,
            par,
        );
        let mut projected = Mat::<f64>::zeros(m, m);
        matmul(
            projected.as_mut(),
            Accum::Replace,
            v.transpose(),
            lv.as_ref(),
            1.0,
            par,
        );
        // (Vᵀ L V) y = μ (Vᵀ V) y through G^{-1/2}: V G^{-1/2} is orthonormal, and the
        // eigenvectors Y of G^{-1/2} (Vᵀ L V) G^{-1/2} give the Ritz vectors V G^{-1/2} Y.
        let (g_values, g_vectors) = symmetric_eigen(&gram)?;
        if g_values.iter().any(|&s| s <= 0.5) {
            return Err(format!(
                "the single-precision eigenvectors {start_here}..{} are not independent \
                 (Gram eigenvalue {:.3e}): please report this mesh; Eigensolver::Double \
                 computes the spectrum in f64",
                start_here + m,
                g_values.iter().cloned().fold(f64::INFINITY, f64::min)
            ));
        }
        let inverse_root = Mat::<f64>::from_fn(m, m, |r, c| {
            (0..m)
                .map(|k| g_vectors[(r, k)] * g_vectors[(c, k)] / g_values[k].sqrt())
                .sum()
        });
        let half = &inverse_root * &projected * &inverse_root;
        let symmetric = Mat::<f64>::from_fn(m, m, |r, c| 0.5 * (half[(r, c)] + half[(c, r)]));
        let (ritz_values, ritz) = symmetric_eigen(&symmetric)?;
        let transform = &inverse_root * &ritz;
        // The window's columns are replaced by an orthonormal basis of the same space, so the
        // whole basis stays orthonormal however the windows overlap.
        let mut refined = vectors.subcols_mut(start_here, m);
        matmul(
            refined.as_mut(),
            Accum::Replace,
            v.as_ref(),
            transform.as_ref(),
            1.0,
            par,
        );
        values[start_here..start_here + m].copy_from_slice(&ritz_values);
        if start_here + m >= n {
            return Ok(());
        }
        start += stride;
    }
}

/// Eigenpairs in ascending order of value: windows end on their own Ritz values, so two
/// nearly equal values either side of a window's final column may come out swapped.
fn sort_ascending(values: &mut [f64], vectors: &mut Mat<f64>) {
    if values.windows(2).all(|w| w[0] <= w[1]) {
        return;
    }
    let mut order: Vec<usize> = (0..values.len()).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let sorted_values: Vec<f64> = order.iter().map(|&k| values[k]).collect();
    let sorted = Mat::<f64>::from_fn(vectors.nrows(), vectors.ncols(), |r, c| {
        vectors[(r, order[c])]
    });
    values.copy_from_slice(&sorted_values);
    *vectors = sorted;
}

/// Connected components of the graph of positive-weight edges (isolated vertices count).
fn connected_components(n: usize, edges: &[(usize, usize)], weights: &[f64]) -> usize {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut i: usize) -> usize {
        while parent[i] != i {
            parent[i] = parent[parent[i]];
            i = parent[i];
        }
        i
    }
    let mut components = n;
    for (&(a, b), &w) in edges.iter().zip(weights) {
        if w > 0.0 {
            let (ra, rb) = (root(&mut parent, a), root(&mut parent, b));
            if ra != rb {
                parent[ra.max(rb)] = ra.min(rb);
                components -= 1;
            }
        }
    }
    components
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// SI's kind of graph: a triangulated grid of points jittered by up to ±0.4 of the spacing,
    /// weighted 1/d² (so weights span two orders of magnitude), in `pieces` separate copies.
    fn grid(side: usize, pieces: usize, seed: u64) -> (usize, Vec<(usize, usize)>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut edges = Vec::new();
        let per = side * side;
        for p in 0..pieces {
            for r in 0..side {
                for c in 0..side {
                    let i = p * per + r * side + c;
                    if c + 1 < side {
                        edges.push((i, i + 1));
                    }
                    if r + 1 < side {
                        edges.push((i, i + side));
                    }
                    if r + 1 < side && c + 1 < side {
                        edges.push((i, i + side + 1));
                    }
                }
            }
        }
        let h = 1.0 / side as f64;
        let points: Vec<(f64, f64)> = (0..pieces * per)
            .map(|i| {
                let (r, c) = ((i % per) / side, i % side);
                let jitter = |rng: &mut ChaCha8Rng| (rng.random::<f64>() - 0.5) * 0.8;
                (
                    (c as f64 + jitter(&mut rng)) * h,
                    (r as f64 + jitter(&mut rng)) * h,
                )
            })
            .collect();
        let weights = edges
            .iter()
            .map(|&(a, b)| {
                let (dx, dy) = (points[a].0 - points[b].0, points[a].1 - points[b].1);
                1.0 / (dx * dx + dy * dy)
            })
            .collect();
        (pieces * per, edges, weights)
    }

    fn spectrum(
        n: usize,
        edges: &[(usize, usize)],
        weights: &[f64],
        s: Eigensolver,
    ) -> LaplacianSpectrum {
        let index: std::collections::HashMap<(usize, usize), f64> =
            edges.iter().cloned().zip(weights.iter().cloned()).collect();
        laplacian_spectrum(n, edges, &|a, b| index[&(a, b)], s).unwrap()
    }

    /// What SI sums, B diag(e) Bᵀ, for e an oscillating function of λ (a function of the
    /// eigenvalue, so a rotation within a repeated eigenvalue's space, which the grid has and
    /// which either solver may take, changes nothing), relative to its largest entry.
    fn weighted_error(got: &LaplacianSpectrum, reference: &LaplacianSpectrum) -> f64 {
        let n = reference.values.len();
        let largest = reference.values[n - 1];
        let weighted = |s: &LaplacianSpectrum| {
            let e: Vec<f64> = s
                .values
                .iter()
                .map(|l| 2.0 + (40.0 * l / largest).sin())
                .collect();
            let scaled = Mat::<f64>::from_fn(n, n, |r, c| s.vectors[(r, c)] * e[c]);
            &scaled * s.vectors.transpose()
        };
        let want = weighted(reference);
        (weighted(got) - &want).norm_max() / want.norm_max()
    }

    fn value_error(values: &[f64], reference: &[f64]) -> f64 {
        let largest = reference[reference.len() - 1];
        values
            .iter()
            .zip(reference)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / largest
    }

    /// The refinement takes the f32 spectrum most of the way to the f64 one on SI's kind of
    /// graph, and one window over the whole spectrum is an exact f64 Rayleigh–Ritz of all of
    /// Rⁿ, as good as the f64 solver.
    #[test]
    fn refinement_brings_single_precision_to_double() {
        let (n, edges, weights) = grid(20, 1, 1);
        let double = spectrum(n, &edges, &weights, Eigensolver::Double);
        let (raw_values, raw) = dense_evd::<f32>(n, &edges, &weights, |w| w as f32).unwrap();
        let raw = LaplacianSpectrum {
            vectors: Mat::<f64>::from_fn(n, n, |r, c| raw[(r, c)] as f64),
            values: raw_values,
            zero_modes: 1,
        };
        let raw_error = weighted_error(&raw, &double);
        let raw_value_error = value_error(&raw.values, &double.values);
        // A 400-vertex grid: f32 mixes each eigenvector over a good part of its spectrum, so
        // windows of 64 and 128 (16% and 32% of it) correct part of the error; on SI's 2,500
        // vertices a window of 64 brought the armadillo's map from 0.027 to 0.0019 of f64's.
        for (window, gain) in [(64, 3.0), (128, 20.0)] {
            let single = spectrum(n, &edges, &weights, Eigensolver::SingleRefined { window });
            let error = weighted_error(&single, &double);
            let value = value_error(&single.values, &double.values);
            eprintln!(
                "window {window}: B diag(e) Bᵀ error {error:.2e} (f32 alone {raw_error:.2e}), \
                 values {value:.2e} (f32 alone {raw_value_error:.2e}) of the largest"
            );
            assert!(error < raw_error / gain, "window {window}: {error:.2e}");
            assert!(
                value < raw_value_error / 5.0,
                "window {window}: {value:.2e}"
            );
            assert!(single.values.windows(2).all(|w| w[0] <= w[1]));
            assert_eq!(single.zero_modes, 1);
            let gram = single.vectors.transpose() * &single.vectors - Mat::<f64>::identity(n, n);
            assert!(
                gram.norm_max() < 2e-6,
                "orthogonality {:.2e}",
                gram.norm_max()
            );
        }
        let whole = spectrum(
            n,
            &edges,
            &weights,
            Eigensolver::SingleRefined { window: n },
        );
        let error = weighted_error(&whole, &double);
        assert!(error < 1e-9, "one window {error:.2e}");
        assert!(value_error(&whole.values, &double.values) < 1e-12);
    }

    /// One zero mode per connected component, by count in the refined solver and by
    /// threshold in the double one.
    #[test]
    fn zero_modes_are_the_components() {
        let (n, edges, weights) = grid(6, 3, 3);
        for solver in [
            Eigensolver::Double,
            Eigensolver::SingleRefined { window: 16 },
        ] {
            let s = spectrum(n, &edges, &weights, solver);
            assert_eq!(s.zero_modes, 3, "{solver:?}");
            assert!(s.values[..3]
                .iter()
                .all(|v| v.abs() < 1e-6 * s.values[n - 1]));
        }
    }

    #[test]
    fn refuses_repeated_and_bad_edges() {
        let w = |_: usize, _: usize| 1.0;
        let twice = laplacian_spectrum(3, &[(0, 1), (1, 0)], &w, Eigensolver::Double);
        assert!(twice.err().unwrap().contains("twice"));
        let outside = laplacian_spectrum(3, &[(0, 3)], &w, Eigensolver::Double);
        assert!(outside.err().unwrap().contains("≥ 3"));
    }

    #[test]
    fn refuses_a_window_of_one() {
        let (n, edges, weights) = grid(4, 1, 4);
        let index: std::collections::HashMap<(usize, usize), f64> =
            edges.iter().cloned().zip(weights.iter().cloned()).collect();
        let err = laplacian_spectrum(
            n,
            &edges,
            &|a, b| index[&(a, b)],
            Eigensolver::SingleRefined { window: 1 },
        )
        .err()
        .unwrap();
        assert!(err.contains("window"), "{err}");
    }

    /// The same bits on one thread as on three.
    #[test]
    fn same_bits_on_any_thread_count() {
        let (n, edges, weights) = grid(12, 1, 5);
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let s = spectrum(
                        n,
                        &edges,
                        &weights,
                        Eigensolver::SingleRefined { window: 24 },
                    );
                    (s.values, s.vectors)
                })
        };
        assert_eq!(run(1), run(3));
    }
}

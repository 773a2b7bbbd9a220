//! The paper's metric M_ij = Σ_k ‖f_i^k − f_j^k‖² as a matrix-free operator.
//!
//! Summing squared distances over scales equals the squared distance of the concatenated
//! descriptors F_i, so with g_i = ‖F_i‖²:  M x = g (1ᵀx) + 1 (gᵀx) − 2 F (Fᵀx).
//! That costs O(n·d) per product and O(n·d) memory, instead of an n×n matrix
//! (5000² doubles = 200 MB; at 50k samples, 20 GB).
use rayon::prelude::*;

use crate::saliency::sms::descriptors::Descriptors;

/// A symmetric linear map on R^n.
pub trait SymmetricOperator: Sync {
    /// n.
    fn size(&self) -> usize;
    /// y = A x.
    fn apply(&self, x: &[f64], y: &mut [f64]);
}

/// Rows per parallel chunk in reductions. Fixed, so sums are added in the same order on any
/// number of threads and results are bit-identical.
const CHUNK: usize = 256;

/// Σ a_i b_i, reduced in a fixed order.
pub fn deterministic_dot(a: &[f64], b: &[f64]) -> f64 {
    let partials: Vec<f64> = a
        .par_chunks(CHUNK)
        .zip(b.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(p, q)| p * q).sum())
        .collect();
    partials.iter().sum()
}

/// The paper's descriptor metric M as an operator: applied without forming the n × n matrix.
pub struct DescriptorMetric<'a> {
    f: &'a Descriptors,
    g: Vec<f64>,
}

impl<'a> DescriptorMetric<'a> {
    /// The metric of these descriptors.
    pub fn new(f: &'a Descriptors) -> Self {
        let g = (0..f.n)
            .into_par_iter()
            .map(|i| f.row(i).iter().map(|v| v * v).sum())
            .collect();
        DescriptorMetric { f, g }
    }

    /// Entry M_ij, for tests and small explicit checks.
    pub fn entry(&self, i: usize, j: usize) -> f64 {
        self.f
            .row(i)
            .iter()
            .zip(self.f.row(j))
            .map(|(a, b)| (a - b) * (a - b))
            .sum()
    }
}

impl SymmetricOperator for DescriptorMetric<'_> {
    fn size(&self) -> usize {
        self.f.n
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let d = self.f.dim;
        let ones_x: f64 = {
            let partials: Vec<f64> = x.par_chunks(CHUNK).map(|c| c.iter().sum()).collect();
            partials.iter().sum()
        };
        let g_x = deterministic_dot(&self.g, x);
        // w = Fᵀ x, as per-chunk partial vectors summed in chunk order.
        let partials: Vec<Vec<f64>> = self
            .f
            .data
            .par_chunks(CHUNK * d)
            .zip(x.par_chunks(CHUNK))
            .map(|(rows, xs)| {
                let mut w = vec![0.0; d];
                for (row, &xi) in rows.chunks_exact(d).zip(xs) {
                    if xi != 0.0 {
                        for (wk, fk) in w.iter_mut().zip(row) {
                            *wk += xi * fk;
                        }
                    }
                }
                w
            })
            .collect();
        let mut w = vec![0.0; d];
        for p in &partials {
            for (a, b) in w.iter_mut().zip(p) {
                *a += b;
            }
        }
        y.par_iter_mut()
            .zip(self.f.data.par_chunks(d))
            .zip(self.g.par_iter())
            .for_each(|((yi, row), gi)| {
                let fw: f64 = row.iter().zip(&w).map(|(a, b)| a * b).sum();
                *yi = gi * ones_x + g_x - 2.0 * fw;
            });
    }
}

/// An explicit dense symmetric matrix, for tests and small problems.
pub struct DenseSymmetric {
    /// n.
    pub n: usize,
    /// The n × n entries, row-major.
    pub data: Vec<f64>,
}

impl SymmetricOperator for DenseSymmetric {
    fn size(&self) -> usize {
        self.n
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        for (i, yi) in y.iter_mut().enumerate() {
            *yi = self.data[i * self.n..(i + 1) * self.n]
                .iter()
                .zip(x)
                .map(|(a, b)| a * b)
                .sum();
        }
    }
}

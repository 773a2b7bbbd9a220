//! Principal component projection of descriptor rows (SRI reduces its spin images this way):
//! centre the rows, take the covariance's leading eigenvectors (faer, sequential so the
//! result is the same bytes on any thread count) and project. The covariance and the
//! projection run in parallel, each number summed in the same order on any thread count.
use faer::Mat;
use rayon::prelude::*;

/// The rows projected onto their `dims` leading principal axes (fewer if the rows are
/// shorter). Each axis's sign is fixed so its largest-magnitude loading is positive.
pub fn pca_project(rows: &[Vec<f64>], dims: usize) -> Result<Vec<Vec<f64>>, String> {
    let n = rows.len();
    let d = rows.first().map_or(0, |r| r.len());
    if n == 0 || d == 0 {
        return Ok(vec![Vec::new(); n]);
    }
    if let Some(r) = rows.iter().position(|r| r.len() != d) {
        return Err(format!(
            "descriptor row {r} has {} values, row 0 has {d}",
            rows[r].len()
        ));
    }
    let mut mean = vec![0.0; d];
    for r in rows {
        for (m, x) in mean.iter_mut().zip(r) {
            *m += x / n as f64;
        }
    }
    // Each covariance entry sums its rows in row order, whichever thread computes it, so
    // the matrix is the same bytes on any thread count; rows of the matrix run in parallel.
    let centred: Vec<f64> = rows
        .iter()
        .flat_map(|r| r.iter().zip(&mean).map(|(x, m)| x - m))
        .collect();
    let upper: Vec<Vec<f64>> = (0..d)
        .into_par_iter()
        .map(|i| {
            let mut sums = vec![0.0; d - i];
            for row in centred.chunks_exact(d) {
                let ci = row[i];
                if ci == 0.0 {
                    continue;
                }
                for (sum, cj) in sums.iter_mut().zip(&row[i..]) {
                    *sum += ci * cj;
                }
            }
            sums
        })
        .collect();
    let mut cov = Mat::<f64>::zeros(d, d);
    for (i, sums) in upper.iter().enumerate() {
        for (j, &sum) in (i..d).zip(sums) {
            cov[(i, j)] = sum;
            cov[(j, i)] = sum;
        }
    }
    let (_, basis) = symmetric_eigen(&cov)?;
    // Ascending eigenvalues: the leading axes are the last columns.
    let k = dims.min(d);
    let axes: Vec<Vec<f64>> = (0..k)
        .map(|c| {
            let col = d - 1 - c;
            let mut axis: Vec<f64> = (0..d).map(|i| basis[(i, col)]).collect();
            let lead = axis
                .iter()
                .cloned()
                .fold(0.0f64, |m, x| if x.abs() > m.abs() { x } else { m });
            if lead < 0.0 {
                axis.iter_mut().for_each(|x| *x = -*x);
            }
            axis
        })
        .collect();
    Ok(rows
        .par_iter()
        .map(|r| {
            axes.iter()
                .map(|a| {
                    a.iter()
                        .zip(r)
                        .zip(&mean)
                        .map(|((a, x), m)| a * (x - m))
                        .sum()
                })
                .collect()
        })
        .collect())
}

/// Eigenvalues (ascending) and eigenvectors (columns) of a symmetric matrix.
pub fn symmetric_eigen(m: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>), String> {
    symmetric_eigen_in(m.as_ref(), faer::Par::Seq)
}

/// [`symmetric_eigen`] in precision T (f32 or f64; the values returned as f64) with faer's
/// parallelism `par` (lower triangle read).
pub fn symmetric_eigen_in<T>(
    m: faer::MatRef<'_, T>,
    par: faer::Par,
) -> Result<(Vec<f64>, Mat<T>), String>
where
    T: faer::traits::RealField + Copy + Into<f64>,
{
    let d = m.nrows();
    let mut eigenvalues = faer::diag::Diag::<T>::zeros(d);
    let mut basis = Mat::<T>::zeros(d, d);
    let scratch = faer::linalg::evd::self_adjoint_evd_scratch::<T>(
        d,
        faer::linalg::evd::ComputeEigenvectors::Yes,
        par,
        Default::default(),
    );
    let mut mem = faer::dyn_stack::MemBuffer::new(scratch);
    faer::linalg::evd::self_adjoint_evd(
        m,
        eigenvalues.as_mut(),
        Some(basis.as_mut()),
        par,
        faer::dyn_stack::MemStack::new(&mut mem),
        Default::default(),
    )
    .map_err(|e| format!("the eigendecomposition failed: {e:?}"))?;
    Ok((
        (0..d)
            .map(|i| eigenvalues.column_vector()[i].into())
            .collect(),
        basis,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_on_a_line_project_to_their_position_along_it() {
        let rows: Vec<Vec<f64>> = (0..10)
            .map(|i| {
                let t = i as f64 - 4.5;
                vec![3.0 * t / 5.0, 4.0 * t / 5.0, 7.0]
            })
            .collect();
        let p = pca_project(&rows, 2).unwrap();
        for (i, r) in p.iter().enumerate() {
            let t = i as f64 - 4.5;
            assert!((r[0] - t).abs() < 1e-9, "{r:?}");
            assert!(r[1].abs() < 1e-9);
        }
    }

    /// The covariance is summed row by row in one order whatever the thread count, so the
    /// projection is the same bytes on 1 and 3 threads.
    #[test]
    fn the_projection_does_not_depend_on_the_thread_count() {
        let rows: Vec<Vec<f64>> = (0..500)
            .map(|i| {
                (0..40)
                    .map(|k| ((i * 31 + k * 17) % 97) as f64 / 97.0 + (i as f64 * 0.1).sin())
                    .collect()
            })
            .collect();
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| pca_project(&rows, 8).unwrap())
        };
        assert_eq!(on(1), on(3));
    }

    #[test]
    fn rows_of_different_lengths_are_an_error_not_a_panic() {
        let err = pca_project(&[vec![1.0, 2.0], vec![3.0]], 1).unwrap_err();
        assert!(err.contains("row 1 has 1 values"), "{err}");
    }
}

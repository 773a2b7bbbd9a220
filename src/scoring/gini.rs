//! Gini index and Lorenz curve of a non-negative map (paper §3.4, after Hurley & Rickard
//! 2009): sort ascending, L(i/n) = share of the total held by the i smallest values,
//! Gini = 1 − 2 × (trapezoid area under L). 0 for a uniform map, (n−1)/n for a one-hot one.

/// Points (i/n, L(i/n)) for i = 0..=n. None if any value is negative or not finite.
pub fn lorenz_curve(values: &[f64]) -> Option<Vec<(f64, f64)>> {
    if values.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let total: f64 = sorted.iter().sum();
    let n = sorted.len() as f64;
    let mut out = Vec::with_capacity(sorted.len() + 1);
    out.push((0.0, 0.0));
    let mut acc = 0.0;
    for (i, v) in sorted.iter().enumerate() {
        acc += v;
        let share = if total > 0.0 {
            acc / total
        } else {
            (i + 1) as f64 / n
        };
        out.push(((i + 1) as f64 / n, share));
    }
    Some(out)
}

/// Gini index in [0, 1); NaN for an empty map or one with negative or non-finite values.
///
/// ```
/// use meshgaze::scoring::gini_index;
/// assert_eq!(gini_index(&[1.0, 1.0, 1.0, 1.0]), 0.0);
/// assert!((gini_index(&[0.0, 0.0, 0.0, 5.0]) - 0.75).abs() < 1e-12);
/// ```
pub fn gini_index(values: &[f64]) -> f64 {
    match lorenz_curve(values) {
        Some(curve) if curve.len() > 1 => {
            let area: f64 = curve
                .windows(2)
                .map(|w| (w[1].0 - w[0].0) * (w[1].1 + w[0].1) * 0.5)
                .sum();
            1.0 - 2.0 * area
        }
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_and_one_hot() {
        assert!(gini_index(&[3.0; 10]).abs() < 1e-12);
        let mut one_hot = vec![0.0; 10];
        one_hot[4] = 2.5;
        assert!((gini_index(&one_hot) - 0.9).abs() < 1e-12);
        assert!(gini_index(&[1.0, -1.0]).is_nan());
    }

    #[test]
    fn matches_closed_form() {
        // G = 1 − 2 Σ_k (c_(k)/Σc)·((n − k + ½)/n), k = 1..n
        let v = [0.1, 0.4, 0.0, 2.0, 0.7, 0.7, 1.3];
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len() as f64;
        let total: f64 = s.iter().sum();
        let closed = 1.0
            - 2.0
                * s.iter()
                    .enumerate()
                    .map(|(k, c)| c / total * ((n - (k as f64 + 1.0) + 0.5) / n))
                    .sum::<f64>();
        assert!((gini_index(&v) - closed).abs() < 1e-12);
    }
}

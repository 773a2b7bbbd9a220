//! Gini index and Lorenz curve of a non-negative map (paper §3.4, after Hurley & Rickard
//! 2009): sort ascending, L(i/n) = share of the total held by the i smallest values,
//! Gini = 1 − 2 × (trapezoid area under L). 0 for a uniform map, (n−1)/n for a one-hot one.

use crate::total_order_key::{from_total_order_key, total_order_key};

/// Points (i/n, L(i/n)) for i = 0..=n. None if any value is negative or not finite.
pub fn lorenz_curve(values: &[f64]) -> Option<Vec<(f64, f64)>> {
    let sorted = sorted_if_valid(values)?;
    let mut out = Vec::with_capacity(sorted.len() + 1);
    out.push((0.0, 0.0));
    for_each_lorenz_point(&sorted, |point| out.push(point));
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
    match sorted_if_valid(values) {
        Some(sorted) if !sorted.is_empty() => {
            // The trapezoids under the curve, point by point as `lorenz_curve` lists them
            // (scoring takes thousands of Gini indices: the curve is not kept).
            let (mut area, mut last) = (0.0, (0.0, 0.0));
            for_each_lorenz_point(&sorted, |point: (f64, f64)| {
                area += (point.0 - last.0) * (point.1 + last.1) * 0.5;
                last = point;
            });
            1.0 - 2.0 * area
        }
        _ => f64::NAN,
    }
}

/// The values in ascending order, or None if any is negative or not finite.
fn sorted_if_valid(values: &[f64]) -> Option<Vec<f64>> {
    if values.iter().any(|v| !v.is_finite() || *v < 0.0) {
        return None;
    }
    Some(sorted_ascending(values))
}

/// The Lorenz curve's points after (0, 0): ((i+1)/n, share of the i+1 smallest values).
fn for_each_lorenz_point(sorted: &[f64], mut point: impl FnMut((f64, f64))) {
    let total: f64 = sorted.iter().sum();
    let n = sorted.len() as f64;
    let mut acc = 0.0;
    for (i, v) in sorted.iter().enumerate() {
        acc += v;
        let share = if total > 0.0 {
            acc / total
        } else {
            (i + 1) as f64 / n
        };
        point(((i + 1) as f64 / n, share));
    }
}

/// `values` sorted as `f64::total_cmp` sorts them (so −0 before +0), by an unstable sort of
/// their bits mapped to that order. Values with equal keys have equal bits, so the result is
/// the comparison sort's. (On the 2-core AMD EPYC, 50,000 values: 0.98 ms, where an 11-bit
/// least-significant-digit radix sort of the same keys took 1.46 ms and a 16-bit one 1.12 ms:
/// each radix pass waits on its buckets' counters.)
fn sorted_ascending(values: &[f64]) -> Vec<f64> {
    let mut keys: Vec<i64> = values.iter().map(|&x| total_order_key(x)).collect();
    keys.sort_unstable();
    keys.into_iter().map(from_total_order_key).collect()
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

    /// The key sort puts values where the comparison sort does: ties, ±0, subnormals,
    /// infinities and NaNs of either sign, small and large inputs.
    #[test]
    fn key_order_is_the_total_order() {
        let specials = [
            0.0,
            -0.0,
            f64::MIN_POSITIVE / 4.0,
            -f64::MIN_POSITIVE / 4.0,
            1.0,
            1.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            -f64::NAN,
            f64::MAX,
            -1e300,
            0.5,
        ];
        for len in [0, 1, 13, 255, 256, 3000] {
            let values: Vec<f64> = (0..len)
                .map(|i: usize| {
                    if i.is_multiple_of(7) {
                        specials[i % specials.len()]
                    } else {
                        ((i * 2_654_435_761) % 1_000_003) as f64 / 1_000_003.0
                            * if i.is_multiple_of(11) { -3.0 } else { 1.0 }
                    }
                })
                .collect();
            let mut expected = values.clone();
            expected.sort_by(f64::total_cmp);
            let got = sorted_ascending(&values);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&got), bits(&expected), "{len} values");
        }
    }

    /// The index from streamed trapezoids is the one from the listed curve, bit for bit.
    #[test]
    fn index_equals_the_area_under_the_listed_curve() {
        for len in [1usize, 2, 7, 500, 4097] {
            let v: Vec<f64> = (0..len)
                .map(|i| (((i * 7919) % 1009) as f64 / 1009.0).powi(3))
                .collect();
            let curve = lorenz_curve(&v).unwrap();
            let area: f64 = curve
                .windows(2)
                .map(|w| (w[1].0 - w[0].0) * (w[1].1 + w[0].1) * 0.5)
                .sum();
            assert_eq!(gini_index(&v).to_bits(), (1.0 - 2.0 * area).to_bits());
        }
        assert!(gini_index(&[]).is_nan());
        assert_eq!(gini_index(&[0.0, 0.0]), 0.0);
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

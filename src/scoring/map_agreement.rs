//! Agreement between a saliency map and a human map on the same vertices (cvzoya's
//! saliency benchmark definitions, carried to meshes with optional per-vertex weights).

fn weight(weights: Option<&[f64]>, i: usize) -> f64 {
    weights.map_or(1.0, |w| w[i])
}

/// Σ of the first `n` weights, in index order. Without weights it is n: the float sum of n
/// ones is exact, so the same bits without the pass (scoring takes ~4,000 of these per mesh).
fn total_weight(n: usize, weights: Option<&[f64]>) -> f64 {
    match weights {
        None if n > 0 => n as f64,
        _ => (0..n).map(|i| weight(weights, i)).sum(),
    }
}

fn weighted_mean_std(x: &[f64], weights: Option<&[f64]>) -> (f64, f64) {
    let total = total_weight(x.len(), weights);
    let mean = (0..x.len()).map(|i| weight(weights, i) * x[i]).sum::<f64>() / total;
    let var = (0..x.len())
        .map(|i| weight(weights, i) * (x[i] - mean).powi(2))
        .sum::<f64>()
        / total;
    (mean, var.sqrt())
}

/// A map's weighted mean and standard deviation, computed once for every metric that z-scores
/// it (LCC and NSS of one map, LCC of many maps against one density).
#[derive(Debug, Clone, Copy)]
pub(crate) struct MeanStd {
    mean: f64,
    std: f64,
}

impl MeanStd {
    pub(crate) fn of(x: &[f64], weights: Option<&[f64]>) -> MeanStd {
        let (mean, std) = weighted_mean_std(x, weights);
        MeanStd { mean, std }
    }
}

/// Linear correlation coefficient (Pearson), weighted; NaN if either map is constant.
pub fn lcc(s: &[f64], h: &[f64], weights: Option<&[f64]>) -> f64 {
    assert_eq!(s.len(), h.len());
    lcc_of(
        s,
        MeanStd::of(s, weights),
        h,
        MeanStd::of(h, weights),
        weights,
    )
}

/// [`lcc`] with both maps' statistics already known.
pub(crate) fn lcc_of(
    s: &[f64],
    s_stats: MeanStd,
    h: &[f64],
    h_stats: MeanStd,
    weights: Option<&[f64]>,
) -> f64 {
    let (ms, ss) = (s_stats.mean, s_stats.std);
    let (mh, sh) = (h_stats.mean, h_stats.std);
    if ss == 0.0 || sh == 0.0 {
        return f64::NAN;
    }
    let total = total_weight(s.len(), weights);
    (0..s.len())
        .map(|i| weight(weights, i) * (s[i] - ms) * (h[i] - mh))
        .sum::<f64>()
        / total
        / (ss * sh)
}

/// Normalized scanpath saliency: the z-scored map averaged over fixations (a vertex fixated
/// twice counts twice). NaN for a constant map.
pub fn nss(s: &[f64], fixated: &[usize], weights: Option<&[f64]>) -> f64 {
    nss_of(s, MeanStd::of(s, weights), fixated)
}

/// [`nss`] with the map's statistics already known.
pub(crate) fn nss_of(s: &[f64], stats: MeanStd, fixated: &[usize]) -> f64 {
    let (m, sd) = (stats.mean, stats.std);
    if sd == 0.0 || fixated.is_empty() {
        return f64::NAN;
    }
    fixated.iter().map(|&i| (s[i] - m) / sd).sum::<f64>() / fixated.len() as f64
}

/// The map as a distribution over vertices (weighted, negatives clipped); None when it sums
/// to zero.
pub(crate) fn as_distribution(x: &[f64], weights: Option<&[f64]>) -> Option<Vec<f64>> {
    let v: Vec<f64> = (0..x.len())
        .map(|i| weight(weights, i) * x[i].max(0.0))
        .collect();
    let total: f64 = v.iter().sum();
    (total > 0.0).then(|| v.iter().map(|a| a / total).collect())
}

/// Similarity (histogram intersection) of the two maps as distributions, in [0, 1].
pub fn sim(s: &[f64], h: &[f64], weights: Option<&[f64]>) -> f64 {
    sim_of(
        as_distribution(s, weights).as_deref(),
        as_distribution(h, weights).as_deref(),
    )
}

/// [`sim`] of two maps already made distributions by [`as_distribution`].
pub(crate) fn sim_of(p: Option<&[f64]>, q: Option<&[f64]>) -> f64 {
    match (p, q) {
        (Some(p), Some(q)) => p.iter().zip(q).map(|(a, b)| a.min(*b)).sum(),
        _ => f64::NAN,
    }
}

/// Kullback–Leibler divergence KL(h ‖ s) of the maps as distributions, with cvzoya's
/// regularizer ε = 2.2204e-16: Σ h log(ε + h / (s + ε)). 0 when equal; lower is better.
pub fn kl_divergence(s: &[f64], h: &[f64], weights: Option<&[f64]>) -> f64 {
    kl_divergence_of(
        as_distribution(s, weights).as_deref(),
        as_distribution(h, weights).as_deref(),
    )
}

/// [`kl_divergence`] of the saliency map `p` and the human map `q`, already distributions.
pub(crate) fn kl_divergence_of(p: Option<&[f64]>, q: Option<&[f64]>) -> f64 {
    const EPS: f64 = 2.2204e-16;
    match (p, q) {
        (Some(p), Some(q)) => {
            // Where the human map is zero (most vertices at small blur) the term is ±0 times
            // ln ε: the logarithm once, not per vertex; the same bits as the formula.
            let ln_eps = EPS.ln();
            q.iter()
                .zip(p)
                .map(|(&qi, pi)| {
                    if qi == 0.0 {
                        qi * ln_eps
                    } else {
                        qi * (EPS + qi / (pi + EPS)).ln()
                    }
                })
                .sum()
        }
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    /// The count of an unweighted map is the float sum of its ones, bit for bit (an empty
    /// map's sum stays the sum of nothing).
    #[test]
    fn the_count_is_the_sum_of_ones() {
        for n in [0usize, 1, 2, 3, 1000, 49_990, 1 << 20] {
            let ones = vec![1.0; n];
            let summed: f64 = (0..n).map(|i| ones[i]).sum();
            assert_eq!(
                super::total_weight(n, None).to_bits(),
                summed.to_bits(),
                "{n}"
            );
            assert_eq!(
                super::total_weight(n, Some(&ones)).to_bits(),
                summed.to_bits(),
                "{n}"
            );
        }
    }

    use super::*;

    /// The zero terms skip the logarithm: the sum must be the formula's bits, zeros of
    /// either sign included.
    #[test]
    fn kl_skips_no_bit_of_the_formula_where_the_human_map_is_zero() {
        const EPS: f64 = 2.2204e-16;
        let q = [0.0, 0.25, -0.0, 0.5, 0.0, 0.25];
        for p in [
            [0.1, 0.2, 0.3, 0.0, 0.15, 0.25],
            [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
            [1e-300, 0.5, 0.0, 0.25, 0.25, 0.0],
        ] {
            let formula: f64 = q
                .iter()
                .zip(&p)
                .map(|(qi, pi)| qi * (EPS + qi / (pi + EPS)).ln())
                .sum();
            let got = kl_divergence_of(Some(&p), Some(&q));
            assert_eq!(got.to_bits(), formula.to_bits(), "p {p:?}");
        }
        let zeros = [0.0, -0.0, 0.0];
        let formula: f64 = zeros
            .iter()
            .map(|qi| qi * (EPS + qi / (0.5 + EPS)).ln())
            .sum();
        let got = kl_divergence_of(Some(&[0.5; 3]), Some(&zeros));
        assert_eq!(got.to_bits(), formula.to_bits());
    }

    #[test]
    fn hand_computed_values() {
        let s = [1.0, 2.0, 3.0, 4.0];
        assert!((lcc(&s, &s, None) - 1.0).abs() < 1e-15);
        assert!((lcc(&s, &[4.0, 3.0, 2.0, 1.0], None) + 1.0).abs() < 1e-15);
        assert!(lcc(&s, &[1.0; 4], None).is_nan());
        // z-scores of 1..4: mean 2.5, sd √1.25; at vertex 3: 1.5/√1.25.
        assert!((nss(&s, &[3], None) - 1.5 / 1.25f64.sqrt()).abs() < 1e-12);
        assert!((sim(&s, &s, None) - 1.0).abs() < 1e-15);
        assert!((sim(&[1.0, 0.0], &[0.0, 1.0], None)).abs() < 1e-15);
        assert!(kl_divergence(&s, &s, None).abs() < 1e-12);
        // KL([½,½] ‖ [¾,¼]) = ½ ln(2/3) + ½ ln 2
        let kl = kl_divergence(&[3.0, 1.0], &[1.0, 1.0], None);
        assert!((kl - (0.5 * (2.0f64 / 3.0).ln() + 0.5 * 2f64.ln())).abs() < 1e-12);
        // Weights act like repeated vertices.
        let w = [2.0, 1.0, 1.0];
        let a = lcc(&[1.0, 2.0, 5.0], &[2.0, 1.0, 7.0], Some(&w));
        let b = lcc(&[1.0, 1.0, 2.0, 5.0], &[2.0, 2.0, 1.0, 7.0], None);
        assert!((a - b).abs() < 1e-12);
    }
}

//! Area under the ROC curve of a saliency map against fixated vertices.
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// AUC-Judd on a mesh: positives are the fixated vertices (each once), negatives every other
/// vertex; the ROC is integrated over every threshold, with tied values forming a diagonal
/// segment. That equals P(s_pos > s_neg) + ½ P(s_pos = s_neg): the expectation of Judd's random
/// tie-breaking jitter, so a map with many exact zeros (SMS) is not penalized for its ties.
/// (Judd's code puts thresholds only at fixated values and interpolates, which adds up to
/// 0.5/N_fixated; integrating at every value is the limit of that.)
///
/// `weights` (e.g. vertex areas) weight positives and negatives; `None` counts vertices.
/// Returns NaN when there is no positive or no negative.
pub fn auc_judd(saliency: &[f64], positive: &[bool], weights: Option<&[f64]>) -> f64 {
    assert_eq!(saliency.len(), positive.len());
    let w = |i: usize| weights.map_or(1.0, |w| w[i]);
    let mut order: Vec<usize> = (0..saliency.len()).collect();
    order.sort_by(|&a, &b| saliency[a].total_cmp(&saliency[b]));
    let (mut total_pos, mut total_neg) = (0.0, 0.0);
    for (i, &is_positive) in positive.iter().enumerate() {
        if is_positive {
            total_pos += w(i);
        } else {
            total_neg += w(i);
        }
    }
    if total_pos <= 0.0 || total_neg <= 0.0 {
        return f64::NAN;
    }
    // Walk tie groups in ascending order: each positive beats the negatives below its group
    // and half of those in it.
    let mut neg_below = 0.0;
    let mut area = 0.0;
    let mut i = 0;
    while i < order.len() {
        let mut j = i;
        let (mut pos_here, mut neg_here) = (0.0, 0.0);
        while j < order.len() && saliency[order[j]] == saliency[order[i]] {
            let k = order[j];
            if positive[k] {
                pos_here += w(k);
            } else {
                neg_here += w(k);
            }
            j += 1;
        }
        area += pos_here * (neg_below + 0.5 * neg_here);
        neg_below += neg_here;
        i = j;
    }
    area / (total_pos * total_neg)
}

/// AUC-Borji: the saliency at fixated vertices against the saliency at as many vertices drawn
/// at random from the whole mesh (uniform, or by `weights`), thresholds 0, 0.1, …, 1 of the
/// map rescaled to [0, 1], trapezoid rule; mean over `splits` draws from a seeded generator.
pub fn auc_borji(
    saliency: &[f64],
    fixated: &[usize],
    weights: Option<&[f64]>,
    splits: usize,
    seed: u64,
) -> f64 {
    if fixated.is_empty() || saliency.is_empty() || splits == 0 {
        return f64::NAN;
    }
    let lo = saliency.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = saliency.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let span = if hi > lo { hi - lo } else { 1.0 };
    let norm = |v: f64| (v - lo) / span;
    let cumulative: Option<Vec<f64>> = weights.map(|w| {
        let mut acc = 0.0;
        w.iter()
            .map(|x| {
                acc += x;
                acc
            })
            .collect()
    });
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let pos: Vec<f64> = fixated.iter().map(|&i| norm(saliency[i])).collect();
    let thresholds: Vec<f64> = (0..=10).map(|k| k as f64 / 10.0).collect();
    let mut sum = 0.0;
    for _ in 0..splits {
        let neg: Vec<f64> = (0..fixated.len())
            .map(|_| {
                let i = match &cumulative {
                    None => rng.random_range(0..saliency.len()),
                    Some(c) => {
                        let t = rng.random::<f64>() * c[c.len() - 1];
                        c.partition_point(|&x| x <= t).min(c.len() - 1)
                    }
                };
                norm(saliency[i])
            })
            .collect();
        // ROC points from the highest threshold down, starting at (0, 0), ending at (1, 1).
        let mut points = vec![(0.0, 0.0)];
        for &t in thresholds.iter().rev() {
            let tp = pos.iter().filter(|&&v| v >= t).count() as f64 / pos.len() as f64;
            let fp = neg.iter().filter(|&&v| v >= t).count() as f64 / neg.len() as f64;
            points.push((fp, tp));
        }
        points.push((1.0, 1.0));
        sum += points
            .windows(2)
            .map(|p| (p[1].0 - p[0].0) * (p[1].1 + p[0].1) * 0.5)
            .sum::<f64>();
    }
    sum / splits as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn perfect_inverted_and_constant_maps() {
        let positive = [true, true, false, false, false];
        assert_eq!(auc_judd(&[0.9, 0.8, 0.1, 0.2, 0.3], &positive, None), 1.0);
        assert_eq!(auc_judd(&[0.0, 0.1, 0.8, 0.9, 1.0], &positive, None), 0.0);
        assert_eq!(auc_judd(&[0.5; 5], &positive, None), 0.5);
        assert!(auc_judd(&[0.5; 3], &[true; 3], None).is_nan());
    }

    #[test]
    fn ties_are_split_evenly() {
        // Positive at 0 ties with two of four negatives at 0, beats none: (0 + ½·2)/4 = 0.25.
        let s = [0.0, 0.0, 0.0, 1.0, 1.0];
        let p = [true, false, false, false, false];
        assert_eq!(auc_judd(&s, &p, None), 0.25);
        // Hand count with weights: positive (w 2) at 0.5 beats negative (w 1) at 0.1, ties the
        // negative (w 3) at 0.5, loses to the negative (w 4) at 0.9: 2·(1 + 1.5)/(2·8).
        let s = [0.5, 0.1, 0.5, 0.9];
        let p = [true, false, false, false];
        let w = [2.0, 1.0, 3.0, 4.0];
        assert!((auc_judd(&s, &p, Some(&w)) - 5.0 / 16.0).abs() < 1e-15);
    }

    #[test]
    fn borji_is_one_for_a_perfect_map_and_seeded() {
        let mut s = vec![0.0; 1000];
        let fixated: Vec<usize> = (0..10).collect();
        for &i in &fixated {
            s[i] = 1.0;
        }
        // Random negatives are almost never fixated vertices: AUC close to 1.
        let a = auc_borji(&s, &fixated, None, 100, 3);
        assert!(a > 0.98, "{a}");
        assert_eq!(a, auc_borji(&s, &fixated, None, 100, 3));
        let flat = vec![0.3; 1000];
        assert!((auc_borji(&flat, &fixated, None, 20, 1) - 0.5).abs() < 1e-12);
    }
}

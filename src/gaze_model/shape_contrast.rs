//! Point-cloud stand-ins for what the classical saliency methods compute, as per-object ranks
//! so a model can follow them on any object whatever its scale: multi-scale curvature (MC),
//! centre-surround curvature difference (Lee et al.'s MS) and the rarity of a point's local
//! shape among the object's (the global-rarity family: GR, MR).
//!
//! They are computed from the local-shape columns (`local_shape`), so they need no mesh and
//! cost little beyond them: ranks are O(n log n), rarity O(n × REFERENCES).
use super::features::ranks;

/// How many reference points rarity compares each point with (evenly spaced in input order,
/// so the result is deterministic and needs no seed).
pub const REFERENCES: usize = 256;

/// `convexity[s][i]` (per scale, per point) -> one rank column per scale.
pub fn curvature_ranks(convexity: &[&[f64]]) -> Vec<Vec<f64>> {
    convexity.iter().map(|c| ranks(c)).collect()
}

/// Lee et al.'s centre-surround operator on point curvature: for each pair of neighbouring
/// scales, |convexity at r − convexity at 2r| ranked, and the mean of those ranks, ranked
/// again (a point that stands out from its surroundings at some scale ranks high).
pub fn centre_surround(convexity: &[&[f64]]) -> Vec<f64> {
    let n = convexity.first().map_or(0, |c| c.len());
    let mut sum = vec![0.0; n];
    for pair in convexity.windows(2) {
        let difference: Vec<f64> = pair[0]
            .iter()
            .zip(pair[1])
            .map(|(a, b)| (a - b).abs())
            .collect();
        for (s, r) in sum.iter_mut().zip(ranks(&difference)) {
            *s += r;
        }
    }
    ranks(&sum)
}

/// How unlike the object's other points a point's local shape is: each descriptor column is
/// standardised over the object, and a point's rarity is its mean Euclidean distance to
/// `REFERENCES` reference points; returned as ranks.
pub fn descriptor_rarity(descriptor: &[&[f64]]) -> Vec<f64> {
    let n = descriptor.first().map_or(0, |c| c.len());
    if n == 0 {
        return Vec::new();
    }
    let standardised: Vec<Vec<f64>> = descriptor
        .iter()
        .map(|c| {
            let mean = c.iter().sum::<f64>() / n as f64;
            let var = c.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n as f64;
            let sd = var.sqrt();
            c.iter()
                .map(|v| if sd > 0.0 { (v - mean) / sd } else { 0.0 })
                .collect()
        })
        .collect();
    let k = REFERENCES.min(n);
    let references: Vec<usize> = (0..k).map(|j| j * n / k).collect();
    let rarity: Vec<f64> = (0..n)
        .map(|i| {
            references
                .iter()
                .map(|&j| {
                    standardised
                        .iter()
                        .map(|c| (c[i] - c[j]).powi(2))
                        .sum::<f64>()
                        .sqrt()
                })
                .sum::<f64>()
                / k as f64
        })
        .collect();
    ranks(&rarity)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bump_on_a_flat_field_stands_out() {
        // 100 points of zero curvature at every scale, one with a sharp fine-scale bump.
        let mut fine = vec![0.0; 100];
        fine[37] = 1.0;
        let coarse = vec![0.0; 100];
        let scales: Vec<&[f64]> = vec![&fine, &coarse, &coarse];
        let contrast = centre_surround(&scales);
        assert_eq!(contrast[37], 1.0);
        assert!(contrast
            .iter()
            .enumerate()
            .all(|(i, &c)| i == 37 || c < 1.0));
        let rarity = descriptor_rarity(&scales);
        assert_eq!(rarity[37], 1.0);
    }

    #[test]
    fn constant_descriptors_are_all_equally_rare() {
        let flat = vec![2.0; 10];
        let rarity = descriptor_rarity(&[&flat, &flat]);
        assert!(rarity.iter().all(|&r| r == 0.5));
    }
}

//! Area under the ROC curve of a saliency map against fixated vertices.
use crate::total_order_key::total_order_key;
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
    auc_judd_counts(saliency, positive, None, weights).0
}

/// [`auc_judd`] twice from one pass: over every negative, and over the negatives with `seen`
/// set (the positives are the same in both). The second equals [`auc_judd`] of the map
/// restricted to the positives and the seen vertices, bit for bit: its sums take the same
/// terms in the same order.
pub fn auc_judd_and_seen(
    saliency: &[f64],
    positive: &[bool],
    seen: &[bool],
    weights: Option<&[f64]>,
) -> (f64, f64) {
    assert_eq!(saliency.len(), seen.len());
    let (all, in_view) = auc_judd_counts(saliency, positive, Some(seen), weights);
    (all, in_view.unwrap_or(f64::NAN))
}

/// AUC-Judd over every negative, and over the seen ones when `seen` is given.
fn auc_judd_counts(
    saliency: &[f64],
    positive: &[bool],
    seen: Option<&[bool]>,
    weights: Option<&[f64]>,
) -> (f64, Option<f64>) {
    assert_eq!(saliency.len(), positive.len());
    let w = |i: usize| weights.map_or(1.0, |w| w[i]);
    // Positives are few (fixated vertices): sort them alone and place each negative among them,
    // O(n) for the whole map instead of sorting it. Values are compared as integer keys in
    // f64::total_cmp order; a table of buckets over the positives' key range gives most
    // negatives their place in one load (`PositivePlaces`).
    let mut pos: Vec<(i64, f64)> = (0..saliency.len())
        .filter(|&i| positive[i])
        .map(|i| (total_order_key(saliency[i]), w(i)))
        .collect();
    pos.sort_by_key(|p| p.0);
    let keys: Vec<i64> = pos.iter().map(|p| p.0).collect();
    let total_pos: f64 = pos.iter().map(|p| p.1).sum();
    let places = PositivePlaces::new(&keys);
    let ratio = |area: f64, total_neg: f64| {
        if total_pos <= 0.0 || total_neg <= 0.0 {
            f64::NAN
        } else {
            area / (total_pos * total_neg)
        }
    };
    let Some(weights) = weights else {
        // Every vertex weighs 1, so each negative adds (positives above) + ½ (tied ones): in
        // half units an integer, summed without the float adds' latency. The float sum of
        // these half-integers was exact too (far below 2^52), so the result is the same bits.
        let (all, in_view) = match seen {
            Some(seen) => {
                let (all, in_view) = places.half_units_with_seen(saliency, positive, seen);
                (all, Some(in_view))
            }
            None => (
                unweighted_half_units(saliency, positive, &keys, &places),
                None,
            ),
        };
        let auc = |c: HalfUnits| ratio(c.half_units as f64 * 0.5, c.negatives as f64);
        return (auc(all), in_view.map(auc));
    };
    // above[j]: weight of positives j.. (those at or above the j-th value).
    let mut above = vec![0.0; pos.len() + 1];
    for j in (0..pos.len()).rev() {
        above[j] = above[j + 1] + pos[j].1;
    }
    let (mut total_neg, mut area) = (0.0, 0.0);
    let (mut seen_neg, mut seen_area) = (0.0, 0.0);
    let mut last = (i64::MIN, places.places(i64::MIN));
    for (i, &x) in saliency.iter().enumerate() {
        if positive[i] {
            continue;
        }
        let wi = weights[i];
        let key = total_order_key(x);
        // Sparse maps repeat a value (0) from vertex to vertex: its places are kept.
        if key != last.0 {
            last = (key, places.places(key));
        }
        let (first_tie, first_above) = last.1;
        // Positives above this negative beat it; tied ones get half.
        let term = wi * (above[first_above] + 0.5 * (above[first_tie] - above[first_above]));
        total_neg += wi;
        area += term;
        if seen.is_some_and(|s| s[i]) {
            seen_neg += wi;
            seen_area += term;
        }
    }
    (
        ratio(area, total_neg),
        seen.map(|_| ratio(seen_area, seen_neg)),
    )
}

/// Negatives counted and the half units they add (2 per positive above, 1 per tied one).
#[derive(Clone, Copy, Default)]
struct HalfUnits {
    negatives: u64,
    half_units: u64,
}

/// The unweighted count of every negative: eight lanes at a time where the CPU has AVX-512,
/// else (and for the tail) one at a time from the bucket table.
fn unweighted_half_units(
    saliency: &[f64],
    positive: &[bool],
    keys: &[i64],
    places: &PositivePlaces,
) -> HalfUnits {
    #[cfg(target_arch = "x86_64")]
    let (lanes, from) = if std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx512dq")
    {
        // SAFETY: this CPU has AVX-512F and AVX-512DQ, checked just above.
        let (negatives, half_units, from) =
            unsafe { half_units_avx512(saliency, positive, &KeyPlaces::new(keys)) };
        (
            HalfUnits {
                negatives,
                half_units,
            },
            from,
        )
    } else {
        (HalfUnits::default(), 0)
    };
    #[cfg(not(target_arch = "x86_64"))]
    let (lanes, from) = {
        let _ = keys;
        (HalfUnits::default(), 0)
    };
    let rest = places.half_units(&saliency[from..], &positive[from..]);
    HalfUnits {
        negatives: lanes.negatives + rest.negatives,
        half_units: lanes.half_units + rest.half_units,
    }
}

/// The positives' sorted keys with a table of buckets over their range, each a power of two
/// of keys wide, so a key's bucket is a subtraction and a shift. A bucket that holds no
/// positive's key places every key in it alike (after `start[b]` positives, tied with none),
/// so the table keeps what a negative there adds; only keys in the few buckets that hold a
/// positive's key are compared with those keys. (On the 2-core AMD EPYC, 20 dense maps of
/// 50,000 values and 120 positives: 13.8 ns a value by the search of `KeyPlaces`, 4.2 ns from
/// this table. Scoring a mesh with 8 subjects places about 130 million values.)
struct PositivePlaces {
    keys: Vec<i64>,
    lowest: i64,
    shift: u32,
    last_bucket: u64,
    /// `start[b]`: positives in buckets before b.
    start: Vec<usize>,
    /// What a negative in bucket b adds in half units, 2 (positives − start[b]), or
    /// [`PositivePlaces::MIXED`] where the bucket holds a positive's key.
    half_units: Vec<u32>,
}

impl PositivePlaces {
    const MIXED: u32 = u32::MAX;
    /// About 64 buckets per positive leave few negatives in a bucket with a positive, and
    /// at most 2^14 of them keep the table in L1 and its build small beside a map.
    const BUCKETS_PER_KEY: u64 = 64;
    const MAX_BUCKETS: u64 = 1 << 14;

    fn new(keys: &[i64]) -> PositivePlaces {
        // The buckets span the keys without their outer 1/32 at each end: one far key (a 0
        // among values near 1 is a thousand binades away in key order) would otherwise
        // crowd every other key into a few buckets.
        let trim = keys.len() / 32;
        let (lowest, highest) = match (keys.get(trim), keys.len().checked_sub(1 + trim)) {
            (Some(&l), Some(h)) => (l, keys[h]),
            _ => (0, 0),
        };
        // highest − lowest can exceed i64 but never u64.
        let span = highest.wrapping_sub(lowest) as u64;
        let wanted = (keys.len() as u64 * Self::BUCKETS_PER_KEY).clamp(1, Self::MAX_BUCKETS);
        let mut shift = 0;
        while shift < 63 && span >> shift >= wanted {
            shift += 1;
        }
        let buckets = (span >> shift) as usize + 1;
        let mut places = PositivePlaces {
            keys: keys.to_vec(),
            lowest,
            shift,
            last_bucket: buckets as u64 - 1,
            start: vec![0; buckets + 1],
            half_units: Vec::new(),
        };
        for &k in keys {
            let b = places.bucket(k);
            places.start[b + 1] += 1;
        }
        for b in 1..=buckets {
            places.start[b] += places.start[b - 1];
        }
        // Half units that do not fit below MIXED (2^31 positives, more than a map's memory
        // would hold) leave every bucket to the search.
        places.half_units = (0..buckets)
            .map(|b| {
                let add = 2 * (keys.len() - places.start[b]);
                match u32::try_from(add) {
                    Ok(add) if add < Self::MIXED && places.start[b + 1] == places.start[b] => add,
                    _ => Self::MIXED,
                }
            })
            .collect();
        places
    }

    /// The bucket of a key: keys below the lowest fall in the first, above the highest in
    /// the last.
    #[inline(always)]
    fn bucket(&self, key: i64) -> usize {
        ((key.max(self.lowest).wrapping_sub(self.lowest) as u64 >> self.shift)
            .min(self.last_bucket)) as usize
    }

    /// (first tied positive, first positive above) of a key: how many keys are below it,
    /// and how many at or below.
    #[inline]
    fn places(&self, key: i64) -> (usize, usize) {
        let b = self.bucket(key);
        let (from, to) = (self.start[b], self.start[b + 1]);
        let inside = &self.keys[from..to];
        (
            from + inside.partition_point(|&k| k < key),
            from + inside.partition_point(|&k| k <= key),
        )
    }

    /// What a negative with this key adds, in half units.
    #[inline]
    fn searched(&self, key: i64) -> u64 {
        let (first_tie, first_above) = self.places(key);
        (2 * self.keys.len() - first_tie - first_above) as u64
    }

    /// The unweighted count over every negative.
    fn half_units(&self, saliency: &[f64], positive: &[bool]) -> HalfUnits {
        let (mut half_units, mut positives) = (0u64, 0u64);
        // Sparse maps repeat a value (0) from vertex to vertex, often tied with positives:
        // the search of the last such key is kept.
        let mut kept = (i64::MIN, self.searched(i64::MIN));
        for (&x, &is_positive) in saliency.iter().zip(positive) {
            let key = total_order_key(x);
            let b = self.bucket(key);
            let add = self.half_units[b];
            let negative = u64::from(!is_positive);
            positives += u64::from(is_positive);
            if add != Self::MIXED {
                half_units += u64::from(add) * negative;
            } else if !is_positive {
                if key != kept.0 {
                    kept = (key, self.searched(key));
                }
                half_units += kept.1;
            }
        }
        HalfUnits {
            negatives: saliency.len().min(positive.len()) as u64 - positives,
            half_units,
        }
    }

    /// [`PositivePlaces::half_units`] over every negative and over the seen ones, one pass.
    fn half_units_with_seen(
        &self,
        saliency: &[f64],
        positive: &[bool],
        seen: &[bool],
    ) -> (HalfUnits, HalfUnits) {
        let (mut all, mut in_view) = (HalfUnits::default(), HalfUnits::default());
        let mut kept = (i64::MIN, self.searched(i64::MIN));
        for ((&x, &is_positive), &is_seen) in saliency.iter().zip(positive).zip(seen) {
            let key = total_order_key(x);
            let b = self.bucket(key);
            let negative = u64::from(!is_positive);
            let add = match self.half_units[b] {
                Self::MIXED if !is_positive => {
                    if key != kept.0 {
                        kept = (key, self.searched(key));
                    }
                    kept.1
                }
                Self::MIXED => 0,
                add => u64::from(add) * negative,
            };
            let counted = negative & u64::from(is_seen);
            all.negatives += negative;
            all.half_units += add;
            in_view.negatives += counted;
            in_view.half_units += add * counted;
        }
        (all, in_view)
    }
}

/// The unweighted count of [`auc_judd`] over the first `8 ⌊n/8⌋` vertices, eight at a time:
/// (negatives, half units, vertices done). Each lane computes the scalar code's key, bucket
/// and branch-free count of its bucket's keys (the same integer and float operations, so the
/// same places). A lane whose bucket holds more keys than are counted, or whose value ties a
/// key, is placed by a search, and that key's place is kept: a lane with the kept key takes
/// it (a sparse map's zeros, tied with many positives, are placed once), and when only one
/// or two lanes are left they are searched alone. The sums are
/// integers: the same result as the scalar loop whatever the order. (Placing one value at a
/// time waited on each step's load; eight lanes' gathers overlap: scoring places about 100
/// million values per mesh.)
///
/// # Safety
/// The CPU must have AVX-512F and AVX-512DQ.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq")]
unsafe fn half_units_avx512(
    saliency: &[f64],
    positive: &[bool],
    places: &KeyPlaces,
) -> (u64, u64, usize) {
    use std::arch::x86_64::*;
    let n = saliency.len().min(positive.len());
    let done = n / 8 * 8;
    let positives = (places.padded.len() - KeyPlaces::COUNTED) as i64;
    // What a negative with this key adds, in half units: 2 (above) + (tied).
    let searched = |key: i64| {
        let first_tie = places.first_not_below(key) as i64;
        let first_above = if places.padded[first_tie as usize] == key {
            places.first_above(key) as i64
        } else {
            first_tie
        };
        2 * positives - first_above - first_tie
    };
    let (mut kept_key, mut kept_add) = (i64::MIN, searched(i64::MIN));
    let lowest = _mm512_set1_epi64(places.lowest);
    let scale = _mm512_set1_pd(places.scale);
    let last_bucket = _mm512_set1_epi64((places.start.len() - 2) as i64);
    let one = _mm512_set1_epi64(1);
    let counted = _mm512_set1_epi64(KeyPlaces::COUNTED as i64);
    let two_positives = _mm512_set1_epi64(2 * positives);
    let start = places.start.as_ptr().cast::<i32>();
    let padded = places.padded.as_ptr();
    let mut sums = _mm512_setzero_si512();
    let mut searched_sum = 0i64;
    let mut negatives = 0u64;
    let mut i = 0;
    while i < done {
        // SAFETY: i + 8 <= n, so the eight loads are inside `saliency` and `positive`.
        let (x, flags) = unsafe {
            (
                _mm512_loadu_pd(saliency.as_ptr().add(i)),
                positive.as_ptr().add(i).cast::<u64>().read_unaligned(),
            )
        };
        // A bool is one byte, 0 or 1: lane k is a negative when byte k is 0.
        let mut negative: __mmask8 = 0;
        for k in 0..8 {
            negative |= u8::from((flags >> (8 * k)) & 0xff == 0) << k;
        }
        negatives += u64::from(negative.count_ones());
        let bits = _mm512_castpd_si512(x);
        // total_order_key: bits ^ ((bits >> 63 as u64) >> 1).
        let key = _mm512_xor_si512(bits, _mm512_srli_epi64::<1>(_mm512_srai_epi64::<63>(bits)));
        let kept = negative & _mm512_cmpeq_epi64_mask(key, _mm512_set1_epi64(kept_key));
        sums = _mm512_mask_add_epi64(sums, kept, sums, _mm512_set1_epi64(kept_add));
        let open = negative & !kept;
        if open.count_ones() <= 2 {
            // A sparse map's few values among its kept zeros: one search each costs less
            // than the eight lanes' gathers.
            for k in 0..8 {
                if open >> k & 1 == 1 {
                    searched_sum += searched(total_order_key(saliency[i + k]));
                }
            }
            i += 8;
            continue;
        }
        // bucket: ((max(key, lowest) − lowest) as u64 as f64 × scale) as usize, at most the last.
        let offset = _mm512_sub_epi64(_mm512_max_epi64(key, lowest), lowest);
        let scaled = _mm512_mul_pd(_mm512_cvtepu64_pd(offset), scale);
        let bucket = _mm512_min_epu64(_mm512_cvttpd_epu64(scaled), last_bucket);
        // SAFETY: bucket ≤ start.len() − 2, so bucket and bucket + 1 index `start`.
        let (from, to) = unsafe {
            (
                _mm512_cvtepu32_epi64(_mm512_i64gather_epi32::<4>(bucket, start)),
                _mm512_cvtepu32_epi64(_mm512_i64gather_epi32::<4>(
                    _mm512_add_epi64(bucket, one),
                    start,
                )),
            )
        };
        let full = _mm512_cmpgt_epi64_mask(_mm512_sub_epi64(to, from), counted);
        let mut below = _mm512_setzero_si512();
        for t in 0..KeyPlaces::COUNTED as i64 {
            let at = _mm512_add_epi64(from, _mm512_set1_epi64(t));
            // SAFETY: from ≤ keys, so from + t < keys + COUNTED = padded.len().
            let k = unsafe { _mm512_i64gather_epi64::<8>(at, padded) };
            let inside = _mm512_cmplt_epi64_mask(at, to);
            let less = _mm512_mask_cmplt_epi64_mask(inside, k, key);
            below = _mm512_mask_add_epi64(below, less, below, one);
        }
        let first_tie = _mm512_add_epi64(from, below);
        // SAFETY: first_tie ≤ keys < padded.len().
        let at_tie = unsafe { _mm512_i64gather_epi64::<8>(first_tie, padded) };
        let tied = _mm512_cmpeq_epi64_mask(at_tie, key);
        let by_search = open & (full | tied);
        // No tie: first_above = first_tie, so the lane adds 2 (positives − first_tie).
        let add = _mm512_sub_epi64(two_positives, _mm512_add_epi64(first_tie, first_tie));
        sums = _mm512_mask_add_epi64(sums, open & !by_search, sums, add);
        if by_search != 0 {
            let mut keys = [0i64; 8];
            // SAFETY: `keys` holds eight i64, what one unaligned 512-bit store writes.
            unsafe { _mm512_storeu_si512(keys.as_mut_ptr().cast(), key) };
            for (k, &lane_key) in keys.iter().enumerate() {
                if by_search >> k & 1 == 1 {
                    if lane_key != kept_key {
                        (kept_key, kept_add) = (lane_key, searched(lane_key));
                    }
                    searched_sum += kept_add;
                }
            }
        }
        i += 8;
    }
    let half_units = _mm512_reduce_add_epi64(sums) + searched_sum;
    (negatives, half_units as u64, done)
}

/// The AVX-512 lanes' placement (kept for them: their gathers were measured on that machine,
/// and [`PositivePlaces`] was measured only where AVX-512 is absent). Sorted keys with a table
/// of equal-width buckets over their range: `start[b]` is the number of keys in buckets
/// before b. The bucket of a key is monotone in the key, so every key of an
/// earlier bucket is below it and every key of a later one at or above it: only its own
/// bucket's keys need comparing, and those are counted without branches (the outcome of each
/// compare is random, so a branch on it would be mispredicted half the time).
#[cfg(target_arch = "x86_64")]
struct KeyPlaces {
    /// The sorted keys, then [`KeyPlaces::COUNTED`] copies of `i64::MAX` so a bucket's
    /// compares never run off the end.
    padded: Vec<i64>,
    start: Vec<u32>,
    lowest: i64,
    scale: f64,
}

#[cfg(target_arch = "x86_64")]
impl KeyPlaces {
    /// Eight buckets per key leave most buckets with one key or none.
    const BUCKETS_PER_KEY: usize = 8;
    /// Keys of a bucket compared without branches; a fuller bucket is searched by halves.
    const COUNTED: usize = 4;

    fn new(keys: &[i64]) -> KeyPlaces {
        let mut padded = keys.to_vec();
        padded.extend([i64::MAX; Self::COUNTED]);
        // The buckets span the keys without their outer 1/32 at each end: one far key (a 0
        // among values near 1 is a thousand binades away in key order) would otherwise
        // crowd every other key into a few buckets.
        let trim = keys.len() / 32;
        let (lowest, highest) = match (keys.get(trim), keys.len().checked_sub(1 + trim)) {
            (Some(&l), Some(h)) => (l, keys[h]),
            _ => (0, 0),
        };
        let buckets = keys.len().max(1) * Self::BUCKETS_PER_KEY;
        // The span as u64: highest − lowest can exceed i64 but never u64.
        let span = highest.wrapping_sub(lowest) as u64 as f64;
        let mut places = KeyPlaces {
            padded,
            start: vec![0; buckets + 1],
            lowest,
            scale: buckets as f64 / (span + 1.0),
        };
        let mut start = vec![0u32; buckets + 1];
        for &k in keys {
            start[places.bucket(k) + 1] += 1;
        }
        for b in 1..=buckets {
            start[b] += start[b - 1];
        }
        places.start = start;
        places
    }

    /// The bucket of a key: keys below the lowest fall in the first, above the highest in
    /// the last.
    fn bucket(&self, key: i64) -> usize {
        let offset = key.max(self.lowest).wrapping_sub(self.lowest) as u64 as f64;
        ((offset * self.scale) as usize).min(self.start.len() - 2)
    }

    /// How many keys are below `key` (the first index not below it).
    fn first_not_below(&self, key: i64) -> usize {
        let b = self.bucket(key);
        let (from, to) = (self.start[b] as usize, self.start[b + 1] as usize);
        if to - from > Self::COUNTED {
            return from + self.padded[from..to].partition_point(|&k| k < key);
        }
        let mut below = 0;
        for t in 0..Self::COUNTED {
            below += usize::from((from + t < to) & (self.padded[from + t] < key));
        }
        from + below
    }

    /// How many keys are at or below `key` (the first index above it).
    fn first_above(&self, key: i64) -> usize {
        match key.checked_add(1) {
            Some(next) => self.first_not_below(next),
            None => self.padded.len() - Self::COUNTED,
        }
    }
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

    /// The definition: every (positive, negative) pair, a win 1, a tie ½, weighted.
    fn auc_by_pairs(s: &[f64], p: &[bool], w: &[f64]) -> f64 {
        let (mut area, mut wp, mut wn) = (0.0, 0.0, 0.0);
        for i in 0..s.len() {
            if p[i] {
                wp += w[i];
            } else {
                wn += w[i];
            }
            for j in 0..s.len() {
                if p[i] && !p[j] {
                    let win = if s[i] > s[j] {
                        1.0
                    } else if s[i] == s[j] {
                        0.5
                    } else {
                        0.0
                    };
                    area += w[i] * w[j] * win;
                }
            }
        }
        area / (wp * wn)
    }

    #[test]
    fn the_fast_count_equals_the_pair_definition_with_many_ties() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..200 {
            let n = rng.random_range(2..60);
            let s: Vec<f64> = (0..n).map(|_| rng.random_range(0..6) as f64).collect();
            let p: Vec<bool> = (0..n).map(|_| rng.random_bool(0.3)).collect();
            let w: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..2.0)).collect();
            let fast = auc_judd(&s, &p, Some(&w));
            let slow = auc_by_pairs(&s, &p, &w);
            if slow.is_nan() {
                assert!(fast.is_nan());
            } else {
                assert!((fast - slow).abs() < 1e-12, "{fast} vs {slow}");
            }
            let ones = vec![1.0; n];
            let unweighted = auc_judd(&s, &p, None);
            let slow = auc_by_pairs(&s, &p, &ones);
            assert!(unweighted == slow || (unweighted.is_nan() && slow.is_nan()));
            // The integer count of the unweighted case is the float sum with unit weights,
            // bit for bit.
            let ones_as_weights = auc_judd(&s, &p, Some(&ones));
            assert!(
                unweighted.to_bits() == ones_as_weights.to_bits()
                    || (unweighted.is_nan() && ones_as_weights.is_nan())
            );
        }
        // The same on maps of 50,000 dense values with 120 positives, as scoring meets them.
        let n = 50_000;
        let s: Vec<f64> = (0..n).map(|_| rng.random::<f64>().powi(3)).collect();
        let mut p = vec![false; n];
        for _ in 0..120 {
            p[rng.random_range(0..n)] = true;
        }
        let ones = vec![1.0; n];
        assert_eq!(
            auc_judd(&s, &p, None).to_bits(),
            auc_judd(&s, &p, Some(&ones)).to_bits()
        );
    }

    /// The unweighted count (eight lanes at a time where the CPU allows) against the weighted
    /// one with unit weights (one value at a time), bit for bit, on maps that send lanes every
    /// way: ties with positives, buckets fuller than the lanes count, zeros, infinities, −0,
    /// NaN, lengths that leave a tail.
    #[test]
    fn eight_lanes_count_as_one_value_at_a_time() {
        let mut rng = ChaCha8Rng::seed_from_u64(29);
        let specials = [
            f64::NEG_INFINITY,
            -0.0,
            0.0,
            f64::INFINITY,
            f64::NAN,
            1e-310,
        ];
        for round in 0..120 {
            let n = rng.random_range(1..3000);
            let s: Vec<f64> = (0..n)
                .map(|_| match round % 4 {
                    0 => rng.random_range(0..7) as f64,
                    1 => rng.random::<f64>().powi(4),
                    2 if rng.random_bool(0.9) => 0.0,
                    2 => rng.random::<f64>(),
                    _ if rng.random_bool(0.1) => specials[rng.random_range(0..specials.len())],
                    _ => rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-200..200)),
                })
                .collect();
            let p: Vec<bool> = (0..n).map(|_| rng.random_bool(0.05)).collect();
            let ones = vec![1.0; n];
            let lanes = auc_judd(&s, &p, None);
            let one_by_one = auc_judd(&s, &p, Some(&ones));
            assert!(
                lanes.to_bits() == one_by_one.to_bits() || (lanes.is_nan() && one_by_one.is_nan()),
                "round {round}: {lanes} vs {one_by_one}"
            );
        }
    }

    /// Values at the ends of f64's total order and around zero, for the placement tests.
    const SPECIALS: [f64; 8] = [
        f64::NEG_INFINITY,
        -1e300,
        -0.0,
        0.0,
        1e-310,
        1e300,
        f64::INFINITY,
        f64::NAN,
    ];

    /// The table's places against a search of the sorted keys, on keys clustered in one
    /// bucket, spread over many exponents, or special values, and on any key at all.
    #[test]
    fn table_places_equal_a_search_of_the_sorted_keys() {
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let mut shifts = std::collections::BTreeSet::new();
        for round in 0..400 {
            let count = rng.random_range(0..300);
            let draw = |rng: &mut ChaCha8Rng| match round % 4 {
                0 => rng.random_range(0..5) as f64 * 1e-3,
                1 => rng.random_range(-1.0f64..1.0) * 10f64.powi(rng.random_range(-30..30)),
                2 => rng.random::<f64>(),
                _ => SPECIALS[rng.random_range(0..SPECIALS.len())],
            };
            let mut keys: Vec<i64> = (0..count)
                .map(|_| total_order_key(draw(&mut rng)))
                .collect();
            keys.sort_unstable();
            let places = PositivePlaces::new(&keys);
            shifts.insert(places.shift);
            assert!(places.half_units.len() as u64 <= PositivePlaces::MAX_BUCKETS);
            for _ in 0..200 {
                let key = if rng.random_bool(0.2) {
                    [i64::MIN, i64::MAX, 0, -1][rng.random_range(0..4)]
                } else if rng.random_bool(0.3) && !keys.is_empty() {
                    keys[rng.random_range(0..keys.len())]
                } else {
                    total_order_key(draw(&mut rng))
                };
                let first_tie = keys.partition_point(|&k| k < key);
                let first_above = keys.partition_point(|&k| k <= key);
                assert_eq!(
                    places.places(key),
                    (first_tie, first_above),
                    "{keys:?} {key}"
                );
                let add = places.half_units[places.bucket(key)];
                if add != PositivePlaces::MIXED {
                    assert_eq!(first_tie, first_above);
                    assert_eq!(add as usize, 2 * (keys.len() - first_tie));
                }
            }
        }
        // The rounds reach buckets one key wide and buckets of 2^40 keys and more.
        assert!(
            shifts.contains(&0) && shifts.iter().any(|&s| s > 40),
            "{shifts:?}"
        );
    }

    /// AUC-Judd over the seen negatives, taken in the same pass as the plain one, against
    /// AUC-Judd of the map cut down to the positives and the seen vertices: the same bits,
    /// weighted or not, with ties, sparse maps and vertices nobody saw.
    #[test]
    fn the_seen_count_equals_the_map_cut_to_what_was_seen() {
        let mut rng = ChaCha8Rng::seed_from_u64(31);
        for round in 0..200 {
            let n = rng.random_range(1..4000);
            let s: Vec<f64> = (0..n)
                .map(|_| match round % 3 {
                    0 => rng.random_range(0..7) as f64,
                    1 if rng.random_bool(0.9) => 0.0,
                    _ => rng.random::<f64>().powi(3),
                })
                .collect();
            let p: Vec<bool> = (0..n).map(|_| rng.random_bool(0.04)).collect();
            let seen: Vec<bool> = (0..n).map(|_| rng.random_bool(0.7)).collect();
            let w: Vec<f64> = (0..n).map(|_| rng.random_range(0.5..2.0)).collect();
            let keep: Vec<usize> = (0..n).filter(|&i| p[i] || seen[i]).collect();
            let cut = |x: &[f64]| keep.iter().map(|&i| x[i]).collect::<Vec<f64>>();
            let cut_p: Vec<bool> = keep.iter().map(|&i| p[i]).collect();
            for weights in [None, Some(w.as_slice())] {
                let (all, visible) = auc_judd_and_seen(&s, &p, &seen, weights);
                let plain = auc_judd(&s, &p, weights);
                let cut_w = weights.map(cut);
                let expected = auc_judd(&cut(&s), &cut_p, cut_w.as_deref());
                let same =
                    |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
                assert!(same(all, plain), "round {round}: {all} vs {plain}");
                assert!(
                    same(visible, expected),
                    "round {round}: {visible} vs {expected}"
                );
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn bucketed_places_equal_a_search_of_the_sorted_keys() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for round in 0..300 {
            let count = rng.random_range(0..40);
            // Values clustered (full buckets), spread over many exponents, or with specials.
            let draw = |rng: &mut ChaCha8Rng| match round % 3 {
                0 => rng.random_range(0..5) as f64 * 1e-3,
                1 => rng.random_range(-1.0f64..1.0) * 10f64.powi(rng.random_range(-30..30)),
                _ => SPECIALS[rng.random_range(0..SPECIALS.len())],
            };
            let mut keys: Vec<i64> = (0..count)
                .map(|_| total_order_key(draw(&mut rng)))
                .collect();
            keys.sort_unstable();
            let places = KeyPlaces::new(&keys);
            for _ in 0..200 {
                let key = if rng.random_bool(0.2) {
                    [i64::MIN, i64::MAX, 0, -1][rng.random_range(0..4)]
                } else {
                    total_order_key(draw(&mut rng))
                };
                let expected = keys.partition_point(|&k| k < key);
                assert_eq!(places.first_not_below(key), expected, "{keys:?} {key}");
                let expected = keys.partition_point(|&k| k <= key);
                assert_eq!(places.first_above(key), expected, "{keys:?} {key}");
            }
        }
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

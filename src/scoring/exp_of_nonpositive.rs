//! e^x for x ≤ 0 in f64, written so a loop over several x at once becomes vector code: the
//! blur's sparse sums (the subjects' fixation maps, one exp per source-target pair) spent most
//! of their time in glibc's exp, which is called one value at a time.
//!
//! 2^n · e^r with n = round(x / ln 2), r = x − n ln 2 (ln 2 in two parts, so r is exact to
//! well below an ulp) and e^r from its Taylor polynomial of degree 13 (|r| ≤ ln2/2: the
//! truncation is under 5·10⁻¹⁸ of the value). Every step is an add, a multiply or a fused
//! multiply-add, each exactly rounded wherever it runs, so the portable code and the AVX2 code
//! give the same bits. Within 2 ulp of the correctly rounded e^x (tested against `f64::exp`).

/// 1.5 · 2⁵²: adding it to a value of magnitude below 2⁵¹ rounds that value to an integer.
const ROUND: f64 = 6_755_399_441_055_744.0;
/// ln 2's leading bits (its last 32 bits zero, so n · LN2_HIGH is exact for |n| < 2²⁰).
const LN2_HIGH: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
/// ln 2 − LN2_HIGH.
const LN2_LOW: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
/// Below this, 2ⁿ would leave the normal range; e^−708 ≈ 3·10⁻³⁰⁸ is returned instead of a
/// smaller value (the blur's arguments stay above −12.5: the kernel is cut at 5σ at most).
const LOWEST: f64 = -708.0;

/// 1/k! for k = 13 down to 0: the Horner coefficients of e^r.
const TAYLOR: [f64; 14] = [
    1.0 / 6_227_020_800.0,
    1.0 / 479_001_600.0,
    1.0 / 39_916_800.0,
    1.0 / 3_628_800.0,
    1.0 / 362_880.0,
    1.0 / 40_320.0,
    1.0 / 5_040.0,
    1.0 / 720.0,
    1.0 / 120.0,
    1.0 / 24.0,
    1.0 / 6.0,
    0.5,
    1.0,
    1.0,
];

/// e^x for x ≤ 0 (x below −708 gives e^−708; x above 0 is not supported, a NaN gives
/// e^−708). Inlined so that callers looping over lanes get vector code.
#[inline(always)]
pub(crate) fn exp_of_nonpositive(x: f64) -> f64 {
    let x = x.max(LOWEST);
    let t = x.mul_add(std::f64::consts::LOG2_E, ROUND);
    let n = t - ROUND;
    let n_bits = (t.to_bits() as i64).wrapping_sub(ROUND.to_bits() as i64);
    let r = (-n).mul_add(LN2_LOW, (-n).mul_add(LN2_HIGH, x));
    let mut p = TAYLOR[0];
    for &c in &TAYLOR[1..] {
        p = p.mul_add(r, c);
    }
    f64::from_bits(((n_bits + 1023) << 52) as u64) * p
}

/// [`exp_of_nonpositive`] on four lanes: the same operations in the same order (the max
/// gives its second operand for a NaN, as `f64::max` does), so the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
pub(crate) fn exp_of_nonpositive_avx2(x: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let x = _mm256_max_pd(x, _mm256_set1_pd(LOWEST));
    let round = _mm256_set1_pd(ROUND);
    let t = _mm256_fmadd_pd(x, _mm256_set1_pd(std::f64::consts::LOG2_E), round);
    let n = _mm256_sub_pd(t, round);
    let n_bits = _mm256_sub_epi64(
        _mm256_castpd_si256(t),
        _mm256_set1_epi64x(ROUND.to_bits() as i64),
    );
    let minus_n = _mm256_xor_pd(n, _mm256_set1_pd(-0.0));
    let high = _mm256_fmadd_pd(minus_n, _mm256_set1_pd(LN2_HIGH), x);
    let r = _mm256_fmadd_pd(minus_n, _mm256_set1_pd(LN2_LOW), high);
    let mut p = _mm256_set1_pd(TAYLOR[0]);
    for &c in &TAYLOR[1..] {
        p = _mm256_fmadd_pd(p, r, _mm256_set1_pd(c));
    }
    let scale = _mm256_slli_epi64::<52>(_mm256_add_epi64(n_bits, _mm256_set1_epi64x(1023)));
    _mm256_mul_pd(_mm256_castsi256_pd(scale), p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in ulps between two positive finite values.
    fn ulps(a: f64, b: f64) -> u64 {
        (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs()
    }

    #[test]
    fn within_two_ulp_of_the_library_exp() {
        let mut worst = (0, 0.0);
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut check = |x: f64| {
            let d = ulps(exp_of_nonpositive(x), x.exp());
            if d > worst.0 {
                worst = (d, x);
            }
        };
        // A fine grid over the blur's range, and random values down to the normal range's end.
        for i in 0..=2_000_000 {
            check(-12.5 * i as f64 / 2_000_000.0);
        }
        for _ in 0..1_000_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            check(-708.0 * (state >> 11) as f64 / (1u64 << 53) as f64);
        }
        // Around the points where n changes and r is at its largest.
        for n in 0..1000 {
            let edge = -(n as f64 + 0.5) * std::f64::consts::LN_2;
            for x in [edge, edge.next_up(), edge.next_down()] {
                check(x);
            }
        }
        assert!(worst.0 <= 2, "{} ulp at x = {:e}", worst.0, worst.1);
    }

    #[test]
    fn exact_at_zero_and_bounded_below() {
        assert_eq!(exp_of_nonpositive(0.0), 1.0);
        assert_eq!(exp_of_nonpositive(-0.0), 1.0);
        assert_eq!(exp_of_nonpositive(-1e-300), 1.0);
        let floor = exp_of_nonpositive(LOWEST);
        assert!(ulps(floor, LOWEST.exp()) <= 2);
        assert_eq!(exp_of_nonpositive(-1e6), floor);
        assert_eq!(exp_of_nonpositive(f64::NEG_INFINITY), floor);
    }
}

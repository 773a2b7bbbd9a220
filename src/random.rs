//! Seeded random deviates the crate needs beyond uniform ones (rand's own distributions live
//! in rand_distr, which the crate does not otherwise need for one formula).
use rand::RngExt;

/// One standard normal deviate by Box–Muller from two uniforms; u1 is taken in (0, 1] so the
/// logarithm is finite. The same formula everywhere, so a seed means the same draw.
pub fn standard_normal(rng: &mut impl RngExt) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

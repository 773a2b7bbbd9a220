//! Zernike coefficients of a local height map (Maximo et al. 2011, the descriptor GR and MR
//! build on): the surface within `radius` of a vertex, seen from its tangent plane, is a
//! height field h(ρ, θ) over the unit disc (h and ρ in units of the radius); its moments
//! against the Zernike polynomials V_nm = R_nm(ρ) e^{imθ}, area-weighted, are
//! Z_nm = (n+1) Σ a h R_nm e^{−imθ} / Σ a.
//! The descriptor keeps Z_n0 (real, signed: a bump and a dent differ) and |Z_nm| for m > 0,
//! which do not change when the tangent frame turns, so it needs no reference direction.
use glam::DVec3;
use rayon::prelude::*;

use super::working_copy::WorkingCopy;

/// The (n, m) pairs with 0 ≤ m ≤ n ≤ order and n − m even, and R_nm's coefficients.
pub struct ZernikeBasis {
    terms: Vec<(usize, usize)>,
    /// For each term, the coefficients of ρ^{n-2k}, k = 0..=(n−m)/2, with their power of ρ,
    /// term after term in one table for the loop over a height map's points.
    flat: Vec<(f64, usize)>,
    /// Per term: (end of its coefficients in `flat`, m, n + 1).
    ends: Vec<(usize, usize, f64)>,
}

impl ZernikeBasis {
    pub fn new(order: usize) -> ZernikeBasis {
        let fact = |k: usize| (1..=k).fold(1.0f64, |f, i| f * i as f64);
        let mut terms = Vec::new();
        let mut radial: Vec<Vec<f64>> = Vec::new();
        for n in 0..=order {
            for m in (n % 2..=n).step_by(2) {
                terms.push((n, m));
                radial.push(
                    (0..=(n - m) / 2)
                        .map(|k| {
                            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                            sign * fact(n - k)
                                / (fact(k) * fact((n + m) / 2 - k) * fact((n - m) / 2 - k))
                        })
                        .collect(),
                );
            }
        }
        let mut flat = Vec::new();
        let mut ends = Vec::new();
        for (&(n, m), coefficients) in terms.iter().zip(&radial) {
            flat.extend(
                coefficients
                    .iter()
                    .enumerate()
                    .map(|(k, &c)| (c, n - 2 * k)),
            );
            ends.push((flat.len(), m, (n + 1) as f64));
        }
        ZernikeBasis { terms, flat, ends }
    }

    pub fn len(&self) -> usize {
        self.terms.len()
    }

    /// R_nm(ρ) of one term from the flat table, as `describe` sums it.
    #[cfg(test)]
    fn radial_value(&self, term: usize, rho_powers: &[f64]) -> f64 {
        let from = if term == 0 { 0 } else { self.ends[term - 1].0 };
        self.flat[from..self.ends[term].0]
            .iter()
            .map(|&(c, power)| c * rho_powers[power])
            .sum()
    }

    /// The descriptor of the height field around `centre` (normal `normal`) formed by the
    /// points `(position, area)` within `radius`.
    pub fn describe(
        &self,
        centre: DVec3,
        normal: DVec3,
        radius: f64,
        points: impl Iterator<Item = (DVec3, f64)>,
    ) -> Vec<f64> {
        let order = self.terms.last().map_or(0, |t| t.0);
        let (t1, t2) = normal.any_orthonormal_pair();
        let mut re = vec![0.0; self.len()];
        let mut im = vec![0.0; self.len()];
        let mut weight = 0.0;
        let mut rho_powers = vec![1.0; order + 1];
        let mut phase = vec![(1.0, 0.0); order + 1];
        for (p, a) in points {
            let d = (p - centre) / radius;
            let (u, v, h) = (d.dot(t1), d.dot(t2), d.dot(normal));
            let rho = (u * u + v * v).sqrt();
            if rho > 1.0 {
                continue;
            }
            weight += a;
            for k in 1..=order {
                rho_powers[k] = rho_powers[k - 1] * rho;
            }
            // e^{iθ} without trigonometry; at the centre θ is undefined but every m > 0 term
            // carries ρ^m = 0 there.
            let (c, s) = if rho > 0.0 {
                (u / rho, v / rho)
            } else {
                (1.0, 0.0)
            };
            for m in 1..=order {
                let (pc, ps) = phase[m - 1];
                phase[m] = (pc * c - ps * s, pc * s + ps * c);
            }
            let mut from = 0;
            for ((&(to, m, scale), re), im) in self.ends.iter().zip(&mut re).zip(&mut im) {
                // As `radial_value` sums (f64's sum starts at −0.0).
                let mut radial = -0.0;
                for &(c, power) in &self.flat[from..to] {
                    radial += c * rho_powers[power];
                }
                from = to;
                let r = radial * h * a * scale;
                let (pc, ps) = phase[m];
                *re += r * pc;
                *im -= r * ps;
            }
        }
        if weight <= 0.0 {
            return vec![0.0; self.len()];
        }
        self.terms
            .iter()
            .enumerate()
            .map(|(t, &(_, m))| {
                if m == 0 {
                    re[t] / weight
                } else {
                    (re[t] * re[t] + im[t] * im[t]).sqrt() / weight
                }
            })
            .collect()
    }
}

/// The descriptor of every working vertex at each radius, concatenated over radii (row-major,
/// one row per vertex).
pub fn zernike_descriptors(work: &WorkingCopy, radii: &[f64], order: usize) -> Vec<Vec<f64>> {
    let basis = ZernikeBasis::new(order);
    (0..work.len())
        .into_par_iter()
        .map(|v| {
            let c = work.mesh.positions[v];
            let mut row = Vec::with_capacity(basis.len() * radii.len());
            for &r in radii {
                let near = work.within(c, r);
                row.extend(
                    basis.describe(
                        c,
                        work.normals[v],
                        r,
                        near.iter()
                            .map(|&u| (work.mesh.positions[u], work.areas[u])),
                    ),
                );
            }
            row
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn disc(height: impl Fn(f64, f64) -> f64) -> Vec<(DVec3, f64)> {
        let mut pts = Vec::new();
        for i in -30..=30 {
            for j in -30..=30 {
                let (x, y) = (i as f64 / 30.0, j as f64 / 30.0);
                pts.push((DVec3::new(x, y, height(x, y)), 1.0));
            }
        }
        pts
    }

    #[test]
    fn basis_has_the_expected_terms_and_radial_polynomials() {
        let b = ZernikeBasis::new(8);
        assert_eq!(b.len(), 25);
        // R_20 = 2ρ² − 1, R_42 = 4ρ⁴ − 3ρ².
        let powers: Vec<f64> = (0..=8).map(|k| 0.5f64.powi(k)).collect();
        let t20 = b.terms.iter().position(|&t| t == (2, 0)).unwrap();
        let t42 = b.terms.iter().position(|&t| t == (4, 2)).unwrap();
        assert!((b.radial_value(t20, &powers) - (2.0 * 0.25 - 1.0)).abs() < 1e-12);
        assert!((b.radial_value(t42, &powers) - (4.0 * 0.0625 - 3.0 * 0.25)).abs() < 1e-12);
    }

    #[test]
    fn flat_is_zero_bump_and_dent_differ_and_turning_the_frame_changes_nothing() {
        let b = ZernikeBasis::new(6);
        let flat = b.describe(DVec3::ZERO, DVec3::Z, 1.0, disc(|_, _| 0.0).into_iter());
        assert!(flat.iter().all(|v| v.abs() < 1e-12));
        let bump = |x: f64, y: f64| 0.3 * (-(x * x + 2.0 * y * y) * 4.0).exp();
        let up = b.describe(DVec3::ZERO, DVec3::Z, 1.0, disc(bump).into_iter());
        let down = b.describe(
            DVec3::ZERO,
            DVec3::Z,
            1.0,
            disc(|x, y| -bump(x, y)).into_iter(),
        );
        assert!((up[0] + down[0]).abs() < 1e-12 && up[0] > 0.01);
        // The same anisotropic bump turned by 90° about the normal: same |Z|.
        let turned = b.describe(
            DVec3::ZERO,
            DVec3::Z,
            1.0,
            disc(|x, y| bump(y, x)).into_iter(),
        );
        for (a, c) in up.iter().zip(&turned) {
            assert!((a - c).abs() < 1e-9, "{a} vs {c}");
        }
    }
}

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
        let (t1, t2) = normal.any_orthonormal_pair();
        let mut disc = DiscPoints::default();
        let mut weight = 0.0;
        for (p, a) in points {
            let d = (p - centre) / radius;
            let (u, v, h) = (d.dot(t1), d.dot(t2), d.dot(normal));
            let rho = (u * u + v * v).sqrt();
            if rho > 1.0 {
                continue;
            }
            weight += a;
            disc.push(u, v, h, a, rho);
        }
        let (re, im) = self.moments(&disc);
        self.descriptor(&re, &im, weight)
    }

    /// The descriptor from the moments and the disc's area: Z_n0 signed, |Z_nm| for m > 0,
    /// each over the area; zeros for a disc without area.
    fn descriptor(&self, re: &[f64], im: &[f64], weight: f64) -> Vec<f64> {
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

    /// Σ a h R_nm(ρ) (n+1) cos mθ and Σ of the sines, negated, term by term, over the disc's
    /// points in their order.
    fn moments(&self, disc: &DiscPoints) -> (Vec<f64>, Vec<f64>) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { self.moments_avx2(disc) };
        }
        self.moments_portable(disc)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn moments_avx2(&self, disc: &DiscPoints) -> (Vec<f64>, Vec<f64>) {
        self.moments_portable(disc)
    }

    /// Each point's terms are computed [`POINT_LANES`] points at a time, every lane by the same
    /// operations in the same order as one point alone (no fused multiply-add), and added to
    /// the sums point after point: the same bits as summing one point at a time, whatever the
    /// SIMD width. (One point at a time, the table-driven radial sums left most of the work
    /// waiting on loads: GR and MR describe 10,000 vertices at three radii, 3 million points.)
    #[inline(always)]
    fn moments_portable(&self, disc: &DiscPoints) -> (Vec<f64>, Vec<f64>) {
        const L: usize = POINT_LANES;
        let order = self.terms.last().map_or(0, |t| t.0);
        let terms = self.len();
        let mut re = vec![0.0; terms];
        let mut im = vec![0.0; terms];
        let mut rho_powers = vec![[1.0; L]; order + 1];
        let mut phase_re = vec![[1.0; L]; order + 1];
        let mut phase_im = vec![[0.0; L]; order + 1];
        let mut re_terms = vec![[0.0; L]; terms];
        let mut im_terms = vec![[0.0; L]; terms];
        let count = disc.rho.len();
        for first in (0..count).step_by(L) {
            let lanes = L.min(count - first);
            // Lanes past the end repeat the last point; their terms are never added.
            let lane = |column: &[f64], l: usize| column[first + l.min(lanes - 1)];
            let (mut c, mut s, mut height) = ([0.0; L], [0.0; L], [0.0; L]);
            let rho: [f64; L] = std::array::from_fn(|l| lane(&disc.rho, l));
            for l in 0..L {
                let (u, v, rho) = (lane(&disc.u, l), lane(&disc.v, l), rho[l]);
                // e^{iθ} without trigonometry; at the centre θ is undefined but every m > 0
                // term carries ρ^m = 0 there.
                (c[l], s[l]) = if rho > 0.0 {
                    (u / rho, v / rho)
                } else {
                    (1.0, 0.0)
                };
                height[l] = lane(&disc.h, l);
            }
            for k in 1..=order {
                for l in 0..L {
                    rho_powers[k][l] = rho_powers[k - 1][l] * rho[l];
                }
            }
            for m in 1..=order {
                for l in 0..L {
                    let (pc, ps) = (phase_re[m - 1][l], phase_im[m - 1][l]);
                    phase_re[m][l] = pc * c[l] - ps * s[l];
                    phase_im[m][l] = pc * s[l] + ps * c[l];
                }
            }
            let area: [f64; L] = std::array::from_fn(|l| lane(&disc.area, l));
            let mut from = 0;
            for (t, &(to, m, scale)) in self.ends.iter().enumerate() {
                // As `radial_value` sums (f64's sum starts at −0.0).
                let mut radial = [-0.0; L];
                for &(coefficient, power) in &self.flat[from..to] {
                    for l in 0..L {
                        radial[l] += coefficient * rho_powers[power][l];
                    }
                }
                from = to;
                for l in 0..L {
                    let r = radial[l] * height[l] * area[l] * scale;
                    re_terms[t][l] = r * phase_re[m][l];
                    im_terms[t][l] = r * phase_im[m][l];
                }
            }
            for l in 0..lanes {
                for t in 0..terms {
                    re[t] += re_terms[t][l];
                    im[t] -= im_terms[t][l];
                }
            }
        }
        (re, im)
    }
}

/// Points per pass of [`ZernikeBasis::moments_portable`]: four f64 lanes of AVX2, twice.
const POINT_LANES: usize = 8;

/// The points of a height map inside the unit disc, by column: tangent coordinates u, v,
/// height h, area and radius ρ = √(u² + v²).
#[derive(Default)]
struct DiscPoints {
    u: Vec<f64>,
    v: Vec<f64>,
    h: Vec<f64>,
    area: Vec<f64>,
    rho: Vec<f64>,
}

impl DiscPoints {
    fn push(&mut self, u: f64, v: f64, h: f64, area: f64, rho: f64) {
        self.u.push(u);
        self.v.push(v);
        self.h.push(h);
        self.area.push(area);
        self.rho.push(rho);
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
impl ZernikeBasis {
    /// `describe` as it was written first, one point at a time: the reference its lanes
    /// must match bit for bit.
    fn describe_one_point_at_a_time(
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
        self.descriptor(&re, &im, weight)
    }
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

    /// The lanes give the bits of one point at a time, on a real mesh's height maps at the
    /// three radii GR and MR use (every size of the last pass of lanes), and on orders 0 to 8.
    #[test]
    fn lanes_describe_as_one_point_at_a_time() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("stimuli/meshes/bun_zipper_res2.ply");
        let (mesh, _) = crate::mesh::load_mesh(&path).unwrap();
        let work = WorkingCopy::new(&mesh, 4000).unwrap();
        let mut tails = std::collections::BTreeSet::new();
        for order in [0, 1, 3, 8] {
            let b = ZernikeBasis::new(order);
            for v in (0..work.len()).step_by(97) {
                let c = work.mesh.positions[v];
                for r in [0.05, 0.1, 0.2] {
                    let near = work.within(c, r);
                    let points = || {
                        near.iter()
                            .map(|&u| (work.mesh.positions[u], work.areas[u]))
                    };
                    let lanes = b.describe(c, work.normals[v], r, points());
                    let one = b.describe_one_point_at_a_time(c, work.normals[v], r, points());
                    let bits = |x: &[f64]| x.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                    assert_eq!(
                        bits(&lanes),
                        bits(&one),
                        "vertex {v}, radius {r}, order {order}"
                    );
                    tails.insert(near.len() % POINT_LANES);
                }
            }
        }
        assert!(tails.len() >= POINT_LANES / 2, "{tails:?}");
        // A point at the centre (θ undefined) and an empty disc.
        let b = ZernikeBasis::new(8);
        let centre = vec![(DVec3::ZERO, 1.0), (DVec3::new(0.3, 0.1, 0.2), 2.0)];
        let lanes = b.describe(DVec3::ZERO, DVec3::Z, 1.0, centre.clone().into_iter());
        let one = b.describe_one_point_at_a_time(DVec3::ZERO, DVec3::Z, 1.0, centre.into_iter());
        assert_eq!(lanes, one);
        assert_eq!(
            b.describe(DVec3::ZERO, DVec3::Z, 1.0, std::iter::empty()),
            vec![0.0; 25]
        );
    }
}

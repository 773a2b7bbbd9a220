//! Real orthonormal spherical harmonics up to a small band limit, and a Gauss–Legendre ×
//! uniform-longitude quadrature on the unit sphere to project a function onto them.
use glam::DVec3;

/// Real orthonormal spherical harmonics Y_lm for l < bands, evaluated at unit vector `u`,
/// in the order (l, m) = (0,0), (1,-1), (1,0), (1,1), (2,-2), ... (bands² values).
/// Signs follow no particular phase convention: band norms do not depend on it.
pub fn real_spherical_harmonics(u: DVec3, bands: usize, out: &mut [f64]) {
    assert_eq!(out.len(), bands * bands);
    let z = u.z.clamp(-1.0, 1.0);
    let sin_theta = (1.0 - z * z).max(0.0).sqrt();
    let phi = u.y.atan2(u.x);
    // Associated Legendre P_l^m(z) without the Condon–Shortley phase, by the standard
    // three-term recurrence in l for each m.
    let mut p = vec![0.0; bands * bands];
    let idx = |l: usize, m: usize| l * bands + m;
    let mut pmm = 1.0;
    for m in 0..bands {
        if m > 0 {
            pmm *= (2 * m - 1) as f64 * sin_theta;
        }
        p[idx(m, m)] = pmm;
        if m + 1 < bands {
            p[idx(m + 1, m)] = z * (2 * m + 1) as f64 * pmm;
        }
        for l in m + 2..bands {
            p[idx(l, m)] = ((2 * l - 1) as f64 * z * p[idx(l - 1, m)]
                - (l + m - 1) as f64 * p[idx(l - 2, m)])
                / (l - m) as f64;
        }
    }
    for l in 0..bands {
        for m in 0..=l {
            // K_lm = sqrt((2l+1)/(4π) · (l-m)!/(l+m)!)
            let mut ratio = 1.0;
            for k in (l - m + 1)..=(l + m) {
                ratio /= k as f64;
            }
            let k_lm = ((2 * l + 1) as f64 / (4.0 * std::f64::consts::PI) * ratio).sqrt();
            let base = l * l + l; // index of m = 0
            if m == 0 {
                out[base] = k_lm * p[idx(l, 0)];
            } else {
                let s = std::f64::consts::SQRT_2 * k_lm * p[idx(l, m)];
                out[base + m] = s * (m as f64 * phi).cos();
                out[base - m] = s * (m as f64 * phi).sin();
            }
        }
    }
}

/// Gauss–Legendre nodes and weights on [-1, 1] (Newton on the Legendre polynomial).
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 0 {
                1.0
            } else if n == 1 {
                x
            } else {
                p1
            };
            let pn1 = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * pn - pn1) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        nodes[i] = x;
        weights[i] = 2.0 / ((1.0 - x * x) * dp * dp);
    }
    (nodes, weights)
}

/// Directions and weights of a product quadrature: `rings` Gauss–Legendre nodes in cos θ times
/// `2 * rings` equally spaced longitudes. Exact for spherical polynomials of degree < 2·rings,
/// so projections onto bands l < 8 alias only content above degree 2·rings - 8.
#[derive(Debug, Clone)]
pub struct SphereQuadrature {
    pub directions: Vec<DVec3>,
    pub weights: Vec<f64>,
}

impl SphereQuadrature {
    pub fn gauss_legendre_product(rings: usize) -> SphereQuadrature {
        let (nodes, gl_weights) = gauss_legendre(rings);
        let longitudes = 2 * rings;
        let mut directions = Vec::with_capacity(rings * longitudes);
        let mut weights = Vec::with_capacity(rings * longitudes);
        for (z, w) in nodes.iter().zip(&gl_weights) {
            let s = (1.0 - z * z).sqrt();
            for j in 0..longitudes {
                let phi = 2.0 * std::f64::consts::PI * j as f64 / longitudes as f64;
                directions.push(DVec3::new(s * phi.cos(), s * phi.sin(), *z));
                weights.push(w * 2.0 * std::f64::consts::PI / longitudes as f64);
            }
        }
        SphereQuadrature {
            directions,
            weights,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        let (x, w) = gauss_legendre(16);
        assert!((w.iter().sum::<f64>() - 2.0).abs() < 1e-13);
        // ∫ x^30 dx over [-1, 1] = 2/31, exact for 16 nodes (degree ≤ 31).
        let v: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(30)).sum();
        assert!((v - 2.0 / 31.0).abs() < 1e-13);
    }

    #[test]
    fn harmonics_are_orthonormal_under_the_quadrature() {
        let q = SphereQuadrature::gauss_legendre_product(16);
        let bands = 8;
        let mut table = vec![vec![0.0; bands * bands]; q.directions.len()];
        for (d, row) in q.directions.iter().zip(table.iter_mut()) {
            real_spherical_harmonics(*d, bands, row);
        }
        for a in 0..bands * bands {
            for b in 0..bands * bands {
                let s: f64 = table
                    .iter()
                    .zip(&q.weights)
                    .map(|(y, w)| w * y[a] * y[b])
                    .sum();
                let expect = if a == b { 1.0 } else { 0.0 };
                assert!((s - expect).abs() < 1e-12, "<Y{a}, Y{b}> = {s}");
            }
        }
    }

    #[test]
    fn known_low_order_values() {
        let mut y = vec![0.0; 4];
        real_spherical_harmonics(DVec3::Z, 2, &mut y);
        let c0 = 0.5 / std::f64::consts::PI.sqrt();
        let c1 = (3.0 / (4.0 * std::f64::consts::PI)).sqrt();
        assert!((y[0] - c0).abs() < 1e-15);
        assert!((y[2] - c1).abs() < 1e-15); // Y_10 = c1 z
        assert!(y[1].abs() < 1e-15 && y[3].abs() < 1e-15);
    }
}

//! Small geometric building blocks shared by the stages.
use glam::{DMat3, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::mesh::Mesh;

/// The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision Detection §5.1.5).
pub fn closest_point_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return a + ab * v;
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return a + ac * w;
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return b + (c - b) * w;
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    a + ab * v + ac * w
}

/// The six distinct entries of d dᵀ (xx, yy, zz, xy, xz, yz): what a second moment sums.
pub(crate) fn symmetric_outer(d: DVec3) -> [f64; 6] {
    [
        d.x * d.x,
        d.y * d.y,
        d.z * d.z,
        d.x * d.y,
        d.x * d.z,
        d.y * d.z,
    ]
}

/// Eigen-decomposition of a symmetric 3x3 matrix by cyclic Jacobi rotations.
/// Returns eigenvalues (descending) and the matching unit eigenvectors as columns.
pub fn symmetric_eigen3(m: DMat3) -> ([f64; 3], DMat3) {
    let mut a = m.to_cols_array_2d(); // a[col][row]; symmetric, so a[i][j] = a[j][i]
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for _sweep in 0..50 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        let scale = a[0][0].powi(2) + a[1][1].powi(2) + a[2][2].powi(2);
        if off <= 1e-30 * scale.max(f64::MIN_POSITIVE) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q].abs() < 1e-300 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            for k in 0..3 {
                a[p][k] = c * row_p[k] - s * row_q[k];
                a[q][k] = s * row_p[k] + c * row_q[k];
            }
            for row in &mut v {
                let vp = row[p];
                let vq = row[q];
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| a[j][j].total_cmp(&a[i][i]));
    let vals = order.map(|i| a[i][i]);
    let col = |i: usize| DVec3::new(v[0][i], v[1][i], v[2][i]);
    (
        vals,
        DMat3::from_cols(col(order[0]), col(order[1]), col(order[2])),
    )
}

/// Which bounding box defines the mesh "radius" (half its diagonal) in the normalization.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum BoundingBox {
    /// Box along the principal axes of the surface: the same for any rotation of the mesh,
    /// so the saliency map is rotation invariant.
    Oriented,
    /// Box along the coordinate axes: changes when the mesh is rotated.
    Axis,
}

/// Maps input coordinates to the normalized frame: area-weighted surface centroid at the
/// origin and half the bounding-box diagonal equal to 1 (paper §3.2).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Normalization {
    /// The area-weighted surface centroid, input units.
    pub center: [f64; 3],
    /// Multiply (p - center) by this.
    pub scale: f64,
    /// The box whose half diagonal becomes 1.
    pub bounding_box: BoundingBox,
    /// Half the bounding-box diagonal in input units.
    pub radius: f64,
}

/// Triangles whose moment terms are computed together before being summed in order.
const MOMENT_BLOCK: usize = 1 << 16;

impl Normalization {
    /// The normalization of `mesh` by `bbox`.
    pub fn of_mesh(mesh: &Mesh, bbox: BoundingBox) -> Normalization {
        // Area-weighted centroid and second moments of the surface. Each triangle's terms are
        // computed in parallel, a block at a time, and summed in triangle order: the same
        // bits as one sequential loop, on any thread count.
        let count = mesh.triangles.len();
        let blocks = || {
            (0..count)
                .step_by(MOMENT_BLOCK)
                .map(move |start| start..(start + MOMENT_BLOCK).min(count))
        };
        let mut area_sum = 0.0;
        let mut first = DVec3::ZERO;
        let mut first_terms: Vec<(f64, DVec3)> = Vec::new();
        for block in blocks() {
            block
                .into_par_iter()
                .map(|t| {
                    let [a, b, c] = mesh.triangle(t);
                    let area = 0.5 * (b - a).cross(c - a).length();
                    (area, area * (a + b + c) / 3.0)
                })
                .collect_into_vec(&mut first_terms);
            for &(area, term) in &first_terms {
                area_sum += area;
                first += term;
            }
        }
        let center = if area_sum > 0.0 {
            first / area_sum
        } else {
            DVec3::ZERO
        };
        let axes = match bbox {
            BoundingBox::Axis => DMat3::IDENTITY,
            BoundingBox::Oriented => {
                let mut cov = DMat3::ZERO;
                let mut terms: Vec<DMat3> = Vec::new();
                for block in blocks() {
                    block
                        .into_par_iter()
                        .map(|t| {
                            let [a, b, c] = mesh.triangle(t).map(|p| p - center);
                            let area = 0.5 * (b - a).cross(c - a).length();
                            let s = a + b + c;
                            // Exact second moment of a uniform density on the triangle.
                            let outer = |u: DVec3| DMat3::from_cols(u * u.x, u * u.y, u * u.z);
                            (outer(a) + outer(b) + outer(c) + outer(s)) * (area / 12.0)
                        })
                        .collect_into_vec(&mut terms);
                    for term in &terms {
                        cov += *term;
                    }
                }
                symmetric_eigen3(cov).1
            }
        };
        // Minima and maxima do not depend on the order they are taken in.
        let to_frame = axes.transpose();
        let (lo, hi) = mesh
            .triangles
            .par_iter()
            .map(|tri| {
                tri.iter().fold(
                    (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                    |(lo, hi), &i| {
                        let q = to_frame * (mesh.positions[i as usize] - center);
                        (lo.min(q), hi.max(q))
                    },
                )
            })
            .reduce(
                || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo_a, hi_a), (lo_b, hi_b)| (lo_a.min(lo_b), hi_a.max(hi_b)),
            );
        let radius = 0.5 * (hi - lo).length();
        let radius = if radius > 0.0 && radius.is_finite() {
            radius
        } else {
            1.0
        };
        Normalization {
            center: center.to_array(),
            scale: 1.0 / radius,
            bounding_box: bbox,
            radius,
        }
    }

    /// `p` in the normalized frame.
    pub fn apply(&self, p: DVec3) -> DVec3 {
        (p - DVec3::from_array(self.center)) * self.scale
    }

    /// A copy of the mesh in the normalized frame.
    pub fn normalized_mesh(&self, mesh: &Mesh) -> Mesh {
        Mesh {
            positions: mesh.positions.iter().map(|&p| self.apply(p)).collect(),
            triangles: mesh.triangles.clone(),
        }
    }
}

/// Pearson correlation of two equally long series; 0 when either is constant.
pub fn pearson(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let n = a.len() as f64;
    if a.is_empty() {
        return 0.0;
    }
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa == 0.0 || sbb == 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The normalization as one sequential loop computes it: the parallel blocks must give
    /// the same bits, on any thread count.
    #[test]
    fn the_normalization_is_the_sequential_one_to_the_bit_on_any_thread_count() {
        // More triangles than one block, off-centre and stretched so every term matters.
        let mut mesh = crate::mesh::test_meshes::icosphere(1.0, 6);
        assert!(mesh.triangles.len() > MOMENT_BLOCK);
        for p in mesh.positions.iter_mut() {
            *p = DVec3::new(3.0 * p.x + 0.1, p.y - 2.0, 0.5 * p.z + 0.3 * p.x);
        }
        let (mut area_sum, mut first) = (0.0, DVec3::ZERO);
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.triangle(t);
            let area = 0.5 * (b - a).cross(c - a).length();
            area_sum += area;
            first += area * (a + b + c) / 3.0;
        }
        let center = first / area_sum;
        let mut cov = DMat3::ZERO;
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.triangle(t).map(|p| p - center);
            let area = 0.5 * (b - a).cross(c - a).length();
            let s = a + b + c;
            let outer = |u: DVec3| DMat3::from_cols(u * u.x, u * u.y, u * u.z);
            cov += (outer(a) + outer(b) + outer(c) + outer(s)) * (area / 12.0);
        }
        let axes = symmetric_eigen3(cov).1;
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for p in &mesh.positions {
            let q = axes.transpose() * (*p - center);
            lo = lo.min(q);
            hi = hi.max(q);
        }
        let radius = 0.5 * (hi - lo).length();
        for threads in [1, 2, 3] {
            let norm = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| Normalization::of_mesh(&mesh, BoundingBox::Oriented));
            assert_eq!(norm.center, center.to_array(), "{threads} threads");
            assert_eq!(norm.radius.to_bits(), radius.to_bits(), "{threads} threads");
        }
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (DVec3::ZERO, DVec3::X, DVec3::Y);
        let inside = closest_point_on_triangle(DVec3::new(0.2, 0.2, 1.0), a, b, c);
        assert!((inside - DVec3::new(0.2, 0.2, 0.0)).length() < 1e-15);
        assert_eq!(
            closest_point_on_triangle(DVec3::new(-1.0, -1.0, 0.0), a, b, c),
            a
        );
        assert_eq!(
            closest_point_on_triangle(DVec3::new(2.0, -0.1, 0.0), a, b, c),
            b
        );
        let q = closest_point_on_triangle(DVec3::new(1.0, 1.0, 0.0), a, b, c);
        assert!((q - DVec3::new(0.5, 0.5, 0.0)).length() < 1e-12);
    }

    #[test]
    fn jacobi_recovers_known_eigensystem() {
        let m = DMat3::from_cols(
            DVec3::new(4.0, 1.0, 0.5),
            DVec3::new(1.0, 3.0, 0.2),
            DVec3::new(0.5, 0.2, 1.0),
        );
        let (vals, vecs) = symmetric_eigen3(m);
        assert!(vals[0] >= vals[1] && vals[1] >= vals[2]);
        for (i, &val) in vals.iter().enumerate() {
            let v = vecs.col(i);
            assert!(((m * v) - v * val).length() < 1e-10);
            assert!((v.length() - 1.0).abs() < 1e-12);
        }
        assert!((vals.iter().sum::<f64>() - 8.0).abs() < 1e-10);
    }
}

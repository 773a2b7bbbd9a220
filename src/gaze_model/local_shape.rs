//! Multi-scale local shape of oriented points, with no connectivity: for each point and each
//! ball radius, how flat the neighbourhood is (surface variation), how far it bulges out
//! along the normal (a signed, curvature-like convexity), and how much the normals agree.
use glam::{DMat3, DVec3};
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

use super::surface_points::SurfacePoints;
use crate::mesh::geometry::symmetric_eigen3;

/// The three numbers of one scale at one point.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LocalShape {
    /// λ_min / (λ_0 + λ_1 + λ_2) of the neighbourhood's covariance: 0 on a plane, 1/3 at most.
    pub variation: f64,
    /// −mean((q − p)·n) / r: positive where the surface curves away from the normal (a tip or
    /// ridge), negative in a hollow; 0 on a plane.
    pub convexity: f64,
    /// mean(n_q · n_p): 1 where the normals agree, lower on creases and thin parts.
    pub normal_agreement: f64,
}

/// `LocalShape` of every point at every radius (outer index: radius). Large balls are summed
/// over a fixed, evenly strided subset of the points so each ball holds tens of points, not
/// thousands; the subset depends only on the point order, so results are deterministic.
pub fn local_shape(points: &SurfacePoints, radii: &[f64]) -> Vec<Vec<LocalShape>> {
    let n = points.len();
    if n == 0 {
        return radii.iter().map(|_| Vec::new()).collect();
    }
    let smallest = radii.iter().copied().fold(f64::INFINITY, f64::min);
    radii
        .iter()
        .map(|&r| {
            let stride = (((r / smallest).powi(2) / 2.0).floor() as usize).clamp(1, n);
            let subset: Vec<usize> = (0..n).step_by(stride).collect();
            let coords: Vec<[f64; 3]> = subset
                .iter()
                .map(|&i| points.positions[i].to_array())
                .collect();
            let tree: ImmutableKdTree<f64, 3> =
                ImmutableKdTree::new_from_slice(&coords).expect("fewer than 2^32 points");
            (0..n)
                .into_par_iter()
                .map(|i| {
                    let p = points.positions[i];
                    let hits = tree
                        .query(&p.to_array())
                        .within::<SquaredEuclidean<f64>>(r * r)
                        .unsorted()
                        .execute();
                    let members: Vec<usize> =
                        hits.iter().map(|h| subset[h.item as usize]).collect();
                    shape_of(points, i, &members, r)
                })
                .collect()
        })
        .collect()
}

/// The local shape of point `i` from the points `members` within radius `r`. The members
/// are summed in index order, so the bytes do not depend on the tree's traversal.
fn shape_of(points: &SurfacePoints, i: usize, members: &[usize], r: f64) -> LocalShape {
    let mut members = members.to_vec();
    members.sort_unstable();
    if members.len() < 3 {
        return LocalShape {
            variation: 0.0,
            convexity: 0.0,
            normal_agreement: 1.0,
        };
    }
    let p = points.positions[i];
    let n = points.normals[i];
    let k = members.len() as f64;
    let mean = members
        .iter()
        .fold(DVec3::ZERO, |s, &j| s + points.positions[j])
        / k;
    let mut cov = DMat3::ZERO;
    let mut agreement = 0.0;
    for &j in &members {
        let d = points.positions[j] - mean;
        cov += DMat3::from_cols(d * d.x, d * d.y, d * d.z);
        agreement += points.normals[j].dot(n);
    }
    let (values, _) = symmetric_eigen3(cov / k);
    let total: f64 = values.iter().map(|v| v.max(0.0)).sum();
    let smallest = values
        .iter()
        .copied()
        .fold(f64::INFINITY, f64::min)
        .max(0.0);
    LocalShape {
        variation: if total > 0.0 { smallest / total } else { 0.0 },
        convexity: -(mean - p).dot(n) / r,
        normal_agreement: agreement / k,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sphere(n: usize) -> SurfacePoints {
        let positions = crate::gaze_model::view_visibility::fibonacci_directions(n);
        SurfacePoints {
            normals: positions.clone(),
            positions,
        }
    }

    #[test]
    fn a_sphere_bulges_out_evenly_and_a_plane_not_at_all() {
        let s = sphere(4000);
        let shapes = local_shape(&s, &[0.2, 0.4]);
        for scale in &shapes {
            let c: Vec<f64> = scale.iter().map(|l| l.convexity).collect();
            let lo = c.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = c.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert!(lo > 0.0 && hi - lo < 0.35 * hi, "{lo} {hi}");
        }
        // A sphere of radius 1 and a ball of radius r: the cap's centroid lies about r²/4
        // below the point along the normal, so convexity ≈ r/4 (a little less, from the
        // cap's curvature).
        let mid = shapes[0][2000].convexity;
        assert!((mid - 0.05).abs() < 0.01, "{mid}");
        let plane = SurfacePoints {
            positions: (0..400)
                .map(|i| DVec3::new((i % 20) as f64 * 0.05, (i / 20) as f64 * 0.05, 0.0))
                .collect(),
            normals: vec![DVec3::Z; 400],
        };
        let flat = local_shape(&plane, &[0.2]);
        assert!(flat[0]
            .iter()
            .all(|l| l.convexity.abs() < 1e-12 && l.variation < 1e-12));
    }
}

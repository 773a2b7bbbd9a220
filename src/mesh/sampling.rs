//! Random points on a surface, uniform by area (paper §3.2, step 1).
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::Mesh;

/// A random point on the surface and the triangle it lies in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSample {
    /// The point.
    pub point: DVec3,
    /// Its triangle.
    pub triangle: u32,
}

/// `n` points drawn uniformly by area with a seeded ChaCha8 generator: a triangle with
/// probability proportional to its area, then a uniform point in it. Same mesh, `n` and seed
/// give the same points, on any machine and thread count.
pub fn sample_surface(mesh: &Mesh, n: usize, seed: u64) -> Vec<SurfaceSample> {
    let mut cumulative = Vec::with_capacity(mesh.triangles.len());
    let mut total = 0.0;
    for t in 0..mesh.triangles.len() {
        total += mesh.triangle_area(t);
        cumulative.push(total);
    }
    if total <= 0.0 {
        return Vec::new();
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let target = rng.random::<f64>() * total;
            // First triangle whose running area exceeds the target; zero-area triangles
            // never win because their running total equals the previous one.
            let t = cumulative
                .partition_point(|&c| c <= target)
                .min(cumulative.len() - 1);
            let r1: f64 = rng.random();
            let r2: f64 = rng.random();
            let s = r1.sqrt();
            let [a, b, c] = mesh.triangle(t);
            SurfaceSample {
                point: a * (1.0 - s) + b * (s * (1.0 - r2)) + c * (s * r2),
                triangle: t as u32,
            }
        })
        .collect()
}

/// How surface samples are placed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Sampling {
    /// Independent uniform points by area (the paper's "random points", §3.2).
    #[default]
    Uniform,
    /// Poisson-disk: the same uniform draw of `POISSON_CANDIDATES` × n candidates thinned to
    /// n by weighted sample elimination (Yuksel 2015), so no two samples crowd each other.
    Poisson,
}

/// Candidates per kept sample for Poisson-disk elimination (Yuksel recommends 3–5).
pub const POISSON_CANDIDATES: usize = 4;

/// `n` samples placed by `sampling`, seeded as [`sample_surface`].
pub fn sample_surface_with(
    mesh: &Mesh,
    n: usize,
    seed: u64,
    sampling: Sampling,
) -> Vec<SurfaceSample> {
    match sampling {
        Sampling::Uniform => sample_surface(mesh, n, seed),
        Sampling::Poisson => {
            let candidates = sample_surface(mesh, n * POISSON_CANDIDATES, seed);
            let area: f64 = (0..mesh.triangles.len())
                .map(|t| mesh.triangle_area(t))
                .sum();
            let kept = eliminate_to(&candidates, n, area);
            kept.into_iter().map(|i| candidates[i]).collect()
        }
    }
}

/// Weighted sample elimination (Yuksel, "Sample Elimination for Generating Poisson Disk
/// Sample Sets", Eurographics 2015) on a surface of `area`: every candidate weighs
/// Σ (1 − d/2r)^8 over its neighbours within 2r, r the largest Poisson radius n points can
/// have on that area (hexagonal packing); the heaviest (most crowded) candidate is removed
/// and its neighbours lightened until n remain. Ties go to the higher index, so the result is
/// one fixed set. Returns the kept indices in ascending order.
pub fn eliminate_to(candidates: &[SurfaceSample], n: usize, area: f64) -> Vec<usize> {
    use kiddo::{ImmutableKdTree, SquaredEuclidean};
    use std::collections::BinaryHeap;
    let m = candidates.len();
    if n >= m {
        return (0..m).collect();
    }
    let r_max = (area / (2.0 * 3f64.sqrt() * n as f64)).sqrt();
    let reach = 2.0 * r_max;
    let points: Vec<[f64; 3]> = candidates.iter().map(|c| c.point.to_array()).collect();
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&points).expect("fewer than 2^32 candidates");
    let weight_of = |d2: f64| (1.0 - d2.sqrt() / reach).max(0.0).powi(8);
    let neighbours: Vec<Vec<(u32, f64)>> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut v: Vec<(u32, f64)> = tree
                .query(p)
                .within::<SquaredEuclidean<f64>>(reach * reach)
                .unsorted()
                .execute()
                .into_iter()
                .filter(|h| h.item as usize != i)
                .map(|h| (h.item, weight_of(h.distance)))
                .collect();
            v.sort_unstable_by_key(|&(j, _)| j);
            v
        })
        .collect();
    let mut weight: Vec<f64> = neighbours
        .iter()
        .map(|v| v.iter().map(|&(_, w)| w).sum())
        .collect();
    #[derive(PartialEq)]
    struct Entry(f64, usize);
    impl Eq for Entry {}
    impl PartialOrd for Entry {
        fn partial_cmp(&self, o: &Self) -> Option<std::cmp::Ordering> {
            Some(self.cmp(o))
        }
    }
    impl Ord for Entry {
        fn cmp(&self, o: &Self) -> std::cmp::Ordering {
            self.0.total_cmp(&o.0).then(self.1.cmp(&o.1))
        }
    }
    let mut heap: BinaryHeap<Entry> = (0..m).map(|i| Entry(weight[i], i)).collect();
    let mut removed = vec![false; m];
    let mut left = m;
    while left > n {
        let Some(Entry(w, i)) = heap.pop() else { break };
        if removed[i] || w != weight[i] {
            continue; // a stale entry: the candidate was lightened since it was pushed
        }
        removed[i] = true;
        left -= 1;
        for &(j, wij) in &neighbours[i] {
            let j = j as usize;
            if !removed[j] {
                weight[j] -= wij;
                heap.push(Entry(weight[j], j));
            }
        }
    }
    (0..m).filter(|&i| !removed[i]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two_triangles(big: f64) -> Mesh {
        Mesh {
            positions: vec![
                DVec3::ZERO,
                DVec3::X,
                DVec3::Y,
                DVec3::new(10.0, 0.0, 0.0),
                DVec3::new(10.0 + big, 0.0, 0.0),
                DVec3::new(10.0, big, 0.0),
            ],
            triangles: vec![[0, 1, 2], [3, 4, 5]],
        }
    }

    #[test]
    fn sampling_follows_area_and_seed() {
        let mesh = two_triangles(3.0); // areas 0.5 and 4.5
        let s = sample_surface(&mesh, 20_000, 7);
        let on_big = s.iter().filter(|p| p.triangle == 1).count() as f64 / s.len() as f64;
        assert!(
            (on_big - 0.9).abs() < 0.01,
            "fraction on the big triangle {on_big}"
        );
        assert_eq!(s, sample_surface(&mesh, 20_000, 7));
        assert_ne!(s, sample_surface(&mesh, 20_000, 8));
        for p in &s {
            let [a, b, c] = mesh.triangle(p.triangle as usize);
            let area = |x: DVec3, y: DVec3, z: DVec3| 0.5 * (y - x).cross(z - x).length();
            let inside = area(p.point, b, c) + area(a, p.point, c) + area(a, b, p.point);
            assert!((inside - area(a, b, c)).abs() < 1e-9);
        }
    }

    /// Poisson-disk samples keep their distance: on a unit square the closest pair of 1,000
    /// Poisson samples is several times farther apart than that of 1,000 uniform ones, and
    /// the set is the same for the same seed.
    #[test]
    fn poisson_samples_keep_their_distance() {
        let square = Mesh {
            positions: vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        let closest = |s: &[SurfaceSample]| {
            let mut best = f64::INFINITY;
            for i in 0..s.len() {
                for j in i + 1..s.len() {
                    best = best.min((s[i].point - s[j].point).length());
                }
            }
            best
        };
        let uniform = sample_surface_with(&square, 1000, 3, Sampling::Uniform);
        let poisson = sample_surface_with(&square, 1000, 3, Sampling::Poisson);
        assert_eq!(poisson.len(), 1000);
        assert_eq!(
            poisson,
            sample_surface_with(&square, 1000, 3, Sampling::Poisson)
        );
        // Hexagonal packing of 1,000 points on area 1 spaces them 0.034 apart; elimination
        // typically keeps about 0.75 of that.
        let (u, p) = (closest(&uniform), closest(&poisson));
        assert!(p > 0.02, "poisson closest pair {p}");
        assert!(p > 5.0 * u, "poisson {p} vs uniform {u}");
    }
}

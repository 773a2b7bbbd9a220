//! Random points on a surface, uniform by area (paper §3.2, step 1).
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::Mesh;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceSample {
    pub point: DVec3,
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
}

//! Gaussian blur of per-vertex maps over the surface: s_b(v) = Σ_u a_u s(u) K(u,v) / Σ_u a_u K(u,v)
//! with K = exp(−‖u−v‖²/2σ²) cut at 3σ (Euclidean, summed over a grid of 3σ cubes) and a_u the vertex area (a third of
//! its triangles' areas), so dense tessellation does not weigh more. The blur is linear, so
//! a sum of maps blurs to the sum of the blurred maps (used for split-half human maps).
//! σ is in normalized units (half the bounding-box diagonal = 1).
use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::Mesh;

/// Vertex areas: one third of the area of each incident triangle.
pub fn vertex_areas(mesh: &Mesh) -> Vec<f64> {
    let mut a = vec![0.0; mesh.positions.len()];
    for t in 0..mesh.triangles.len() {
        let third = mesh.triangle_area(t) / 3.0;
        for &i in &mesh.triangles[t] {
            a[i as usize] += third;
        }
    }
    a
}

pub struct SurfaceBlur {
    positions: Vec<DVec3>,
    areas: Vec<f64>,
    /// Sources: vertices with area (unreferenced vertices carry no surface), in index order.
    sources: Vec<usize>,
}

/// Sources bucketed into cubes of side 3σ, so every source within 3σ of a point lies in the
/// 27 cubes around the point's own. Cubes hold sources in index order and are visited in a
/// fixed order, so each sum runs in the same order on any number of threads.
struct SourceGrid {
    cell: f64,
    /// Occupied cells, sorted by key; `starts[i]..starts[i + 1]` indexes `members`.
    keys: Vec<[i64; 3]>,
    starts: Vec<usize>,
    members: Vec<usize>,
}

impl SourceGrid {
    fn key(&self, p: DVec3) -> [i64; 3] {
        let c = (p / self.cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    fn new(positions: &[DVec3], sources: &[usize], cell: f64) -> SourceGrid {
        let mut grid = SourceGrid {
            cell,
            keys: Vec::new(),
            starts: Vec::new(),
            members: Vec::new(),
        };
        let mut keyed: Vec<([i64; 3], usize)> = sources
            .iter()
            .map(|&u| (grid.key(positions[u]), u))
            .collect();
        keyed.sort_unstable();
        for (i, (k, u)) in keyed.iter().enumerate() {
            if i == 0 || keyed[i - 1].0 != *k {
                grid.keys.push(*k);
                grid.starts.push(grid.members.len());
            }
            grid.members.push(*u);
        }
        grid.starts.push(grid.members.len());
        grid
    }

    fn cell_members(&self, key: [i64; 3]) -> &[usize] {
        match self.keys.binary_search(&key) {
            Ok(i) => &self.members[self.starts[i]..self.starts[i + 1]],
            Err(_) => &[],
        }
    }
}

impl SurfaceBlur {
    /// `positions` in normalized units, one area per vertex.
    pub fn new(positions: Vec<DVec3>, areas: Vec<f64>) -> SurfaceBlur {
        let sources: Vec<usize> = (0..positions.len()).filter(|&i| areas[i] > 0.0).collect();
        SurfaceBlur {
            positions,
            areas,
            sources,
        }
    }

    /// Blurs every map at σ; σ = 0 returns copies.
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Vec<Vec<f64>> {
        if sigma <= 0.0 || maps.is_empty() {
            return maps.iter().map(|m| m.to_vec()).collect();
        }
        let radius2 = 9.0 * sigma * sigma;
        let inv = 1.0 / (2.0 * sigma * sigma);
        let k = maps.len();
        let n = self.positions.len();
        // Row-major values (one row of k per vertex): the inner loop reads one contiguous row
        // per neighbour instead of k scattered values.
        let mut rows = vec![0.0; n * k];
        for (m, map) in maps.iter().enumerate() {
            for (v, x) in map.iter().enumerate() {
                rows[v * k + m] = *x;
            }
        }
        let grid = SourceGrid::new(&self.positions, &self.sources, 3.0 * sigma);
        let mut out = vec![0.0; n * k];
        out.par_chunks_mut(k).enumerate().for_each(|(v, num)| {
            let p = self.positions[v];
            let [cx, cy, cz] = grid.key(p);
            let mut den = 0.0;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for &u in grid.cell_members([cx + dx, cy + dy, cz + dz]) {
                            let d2 = self.positions[u].distance_squared(p);
                            if d2 > radius2 {
                                continue;
                            }
                            let w = self.areas[u] * (-d2 * inv).exp();
                            den += w;
                            for (acc, x) in num.iter_mut().zip(&rows[u * k..(u + 1) * k]) {
                                *acc += w * x;
                            }
                        }
                    }
                }
            }
            if den > 0.0 {
                num.iter_mut().for_each(|x| *x /= den);
            } else {
                num.copy_from_slice(&rows[v * k..(v + 1) * k]);
            }
        });
        (0..k)
            .map(|m| (0..n).map(|v| out[v * k + m]).collect())
            .collect()
    }
}

/// Which kernel blurs maps over the surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum BlurKernel {
    /// Euclidean Gaussian (cut at 3σ): fast, but leaks between parts that are close
    /// in space and far along the surface.
    Euclidean,
    /// Heat diffusion along the surface, one implicit step (M − tΔ)u = M s with t = σ²/2
    /// (cotangent Laplacian, lumped mass): a geodesic surrogate whose variance is σ² per axis.
    Heat,
}

/// A blur of per-vertex maps with either kernel, built once per mesh and applied at any σ.
pub enum MeshBlur {
    Euclidean(SurfaceBlur),
    Heat(HeatBlur),
}

impl MeshBlur {
    /// `mesh` should already be normalized: σ is in the mesh's units.
    pub fn new(mesh: &Mesh, kernel: BlurKernel) -> MeshBlur {
        match kernel {
            BlurKernel::Euclidean => {
                MeshBlur::Euclidean(SurfaceBlur::new(mesh.positions.clone(), vertex_areas(mesh)))
            }
            BlurKernel::Heat => MeshBlur::Heat(HeatBlur::new(mesh)),
        }
    }

    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Result<Vec<Vec<f64>>, String> {
        match self {
            MeshBlur::Euclidean(b) => Ok(b.blur(maps, sigma)),
            MeshBlur::Heat(b) => b.blur(maps, sigma),
        }
    }
}

/// Blurs `maps` on `mesh` (normalized) with `kernel` at σ = `sigma`.
pub fn blur_on_mesh(
    mesh: &Mesh,
    kernel: BlurKernel,
    maps: &[&[f64]],
    sigma: f64,
) -> Result<Vec<Vec<f64>>, String> {
    MeshBlur::new(mesh, kernel).blur(maps, sigma)
}

/// Heat-diffusion blur: the cotangent Laplacian and lumped masses of a mesh, factorized anew
/// for each σ (sparse Cholesky, faer), all maps solved at once.
pub struct HeatBlur {
    n: usize,
    /// Off-diagonal cotangent weights w_ij (i < j); Δ_ij = w_ij, Δ_ii = −Σ_j w_ij.
    edges: Vec<(usize, usize, f64)>,
    mass: Vec<f64>,
}

impl HeatBlur {
    pub fn new(mesh: &Mesh) -> HeatBlur {
        let mut edges: Vec<(usize, usize, f64)> = Vec::new();
        for t in 0..mesh.triangles.len() {
            let idx = mesh.triangles[t].map(|i| i as usize);
            let p = idx.map(|i| mesh.positions[i]);
            for k in 0..3 {
                let (a, b, o) = (k, (k + 1) % 3, (k + 2) % 3);
                // Corner o faces edge (a, b): half its cotangent goes to that edge.
                let (u, v) = (p[a] - p[o], p[b] - p[o]);
                let s = u.cross(v).length();
                if s > 0.0 {
                    let (i, j) = (idx[a].min(idx[b]), idx[a].max(idx[b]));
                    edges.push((i, j, 0.5 * u.dot(v) / s));
                }
            }
        }
        edges.sort_by_key(|e| (e.0, e.1));
        let mut merged: Vec<(usize, usize, f64)> = Vec::with_capacity(edges.len());
        for e in edges {
            match merged.last_mut() {
                Some(last) if last.0 == e.0 && last.1 == e.1 => last.2 += e.2,
                _ => merged.push(e),
            }
        }
        HeatBlur {
            n: mesh.positions.len(),
            edges: merged,
            mass: vertex_areas(mesh),
        }
    }

    /// Diffuses every map for time t = σ²/2; σ = 0 returns copies. Vertices without area
    /// (unreferenced) keep their values.
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Result<Vec<Vec<f64>>, String> {
        if sigma <= 0.0 {
            return Ok(maps.iter().map(|m| m.to_vec()).collect());
        }
        use faer::sparse::{SparseColMat, Triplet};
        let t = 0.5 * sigma * sigma;
        let mut diag: Vec<f64> = self.mass.clone();
        let mut triplets = Vec::with_capacity(self.edges.len() + self.n);
        for &(i, j, w) in &self.edges {
            diag[i] += t * w;
            diag[j] += t * w;
            // Lower triangle only: the factorization reads Side::Lower.
            triplets.push(Triplet::new(j, i, -t * w));
        }
        for (i, d) in diag.iter_mut().enumerate() {
            if self.mass[i] <= 0.0 {
                *d = 1.0;
            }
            triplets.push(Triplet::new(i, i, *d));
        }
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(self.n, self.n, &triplets)
            .map_err(|e| format!("cannot assemble the heat operator: {e:?}"))?;
        let llt = a.sp_cholesky(faer::Side::Lower).map_err(|e| {
            format!("the heat operator is not positive definite (σ_b = {sigma}): {e:?}")
        })?;
        let mut rhs = faer::Mat::<f64>::zeros(self.n, maps.len());
        for (c, m) in maps.iter().enumerate() {
            for i in 0..self.n {
                rhs[(i, c)] = if self.mass[i] > 0.0 {
                    self.mass[i] * m[i]
                } else {
                    m[i]
                };
            }
        }
        faer::linalg::solvers::Solve::solve_in_place(&llt, rhs.as_mut());
        Ok((0..maps.len())
            .map(|c| (0..self.n).map(|i| rhs[(i, c)]).collect())
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plate(n: usize) -> Mesh {
        crate::mesh::mean_curvature::test_meshes::height_field(n, -0.5, |_, _| 0.0)
    }

    #[test]
    fn heat_blur_keeps_mass_and_spreads_a_spike_by_sigma_squared() {
        let n = 121;
        let mesh = plate(n);
        let heat = HeatBlur::new(&mesh);
        let centre = (n / 2) * n + n / 2;
        let mut spike = vec![0.0; n * n];
        spike[centre] = 1.0 / heat.mass[centre];
        let sigma = 0.05;
        let u = heat.blur(&[&spike], sigma).unwrap().remove(0);
        let mass: f64 = u.iter().zip(&heat.mass).map(|(a, m)| a * m).sum();
        assert!((mass - 1.0).abs() < 1e-9, "mass {mass}");
        let var_x: f64 = u
            .iter()
            .zip(&heat.mass)
            .zip(&mesh.positions)
            .map(|((a, m), p)| a * m * p.x * p.x)
            .sum();
        assert!(
            (var_x / (sigma * sigma) - 1.0).abs() < 0.05,
            "variance per axis {var_x}, expected {}",
            sigma * sigma
        );
        let constant = vec![0.7; n * n];
        let c = heat.blur(&[&constant], 0.1).unwrap().remove(0);
        assert!(c.iter().all(|v| (v - 0.7).abs() < 1e-9));
    }

    #[test]
    fn euclidean_blur_keeps_constants_and_averages_locally() {
        let mesh = plate(41);
        let blur = SurfaceBlur::new(mesh.positions.clone(), vertex_areas(&mesh));
        let constant = vec![2.0; 41 * 41];
        let c = blur.blur(&[&constant], 0.05).remove(0);
        assert!(c.iter().all(|v| (v - 2.0).abs() < 1e-12));
        let ramp: Vec<f64> = mesh.positions.iter().map(|p| p.x).collect();
        let r = blur.blur(&[&ramp], 0.03).remove(0);
        // A linear ramp is unchanged away from the border.
        let centre = 20 * 41 + 20;
        assert!((r[centre] - ramp[centre]).abs() < 1e-9);
    }

    #[test]
    fn euclidean_blur_equals_the_direct_sum_over_all_pairs() {
        let mesh = crate::mesh::mean_curvature::test_meshes::icosphere(1.0, 3);
        let areas = vertex_areas(&mesh);
        let blur = SurfaceBlur::new(mesh.positions.clone(), areas.clone());
        let map: Vec<f64> = (0..mesh.positions.len())
            .map(|i| ((i * 7919) % 101) as f64)
            .collect();
        for sigma in [0.05, 0.2, 0.7] {
            let fast = blur.blur(&[&map, &areas], sigma);
            for (v, p) in mesh.positions.iter().enumerate() {
                let (mut num, mut den) = (0.0, 0.0);
                for (u, q) in mesh.positions.iter().enumerate() {
                    let d2 = p.distance_squared(*q);
                    if d2 <= 9.0 * sigma * sigma {
                        let w = areas[u] * (-d2 / (2.0 * sigma * sigma)).exp();
                        num += w * map[u];
                        den += w;
                    }
                }
                let direct = num / den;
                assert!(
                    (fast[0][v] - direct).abs() <= 1e-9 * direct.abs().max(1.0),
                    "σ {sigma}, vertex {v}: {} vs {direct}",
                    fast[0][v]
                );
            }
        }
    }
}

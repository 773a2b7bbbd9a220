//! Signed mean curvature per vertex by the cotangent formula of Meyer, Desbrun, Schröder and
//! Barr 2003 ("Discrete differential-geometry operators for triangulated 2-manifolds"):
//! K(v) = 1/(2 A_mixed) Σ_j (cot α_ij + cot β_ij)(v − v_j) = 2 H n, so |H| = |K|/2 with the sign
//! of K · n (positive where the surface is convex with outward normals).
use glam::DVec3;
use serde::Serialize;

use crate::mesh::Mesh;

#[derive(Debug, Clone, Serialize, Default)]
pub struct CurvatureReport {
    /// Vertices on a boundary edge: the cotangent formula there measures the boundary curve,
    /// so they take the mean of their interior neighbours instead.
    pub boundary_vertices: usize,
    /// Boundary vertices with no interior neighbour: set to 0.
    pub boundary_vertices_without_interior_neighbour: usize,
    /// Vertices with zero mixed area (only unreferenced ones, normally): set to 0.
    pub vertices_without_area: usize,
}

/// Vertex adjacency (1-ring) as compressed rows: neighbours of v are
/// `targets[offsets[v]..offsets[v + 1]]`, sorted, without duplicates.
pub struct VertexAdjacency {
    pub offsets: Vec<usize>,
    pub targets: Vec<u32>,
}

impl VertexAdjacency {
    pub fn of_mesh(mesh: &Mesh) -> VertexAdjacency {
        let n = mesh.positions.len();
        let mut pairs: Vec<(u32, u32)> = Vec::with_capacity(mesh.triangles.len() * 6);
        for t in &mesh.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                pairs.push((a, b));
                pairs.push((b, a));
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let mut offsets = vec![0usize; n + 1];
        for &(a, _) in &pairs {
            offsets[a as usize + 1] += 1;
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        VertexAdjacency {
            offsets,
            targets: pairs.into_iter().map(|(_, b)| b).collect(),
        }
    }

    pub fn neighbours(&self, v: usize) -> &[u32] {
        &self.targets[self.offsets[v]..self.offsets[v + 1]]
    }
}

/// Vertices on an edge used by exactly one triangle.
pub fn boundary_vertices(mesh: &Mesh) -> Vec<bool> {
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(mesh.triangles.len() * 3);
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    let mut boundary = vec![false; mesh.positions.len()];
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && edges[j] == edges[i] {
            j += 1;
        }
        if j - i == 1 {
            boundary[edges[i].0 as usize] = true;
            boundary[edges[i].1 as usize] = true;
        }
        i = j;
    }
    boundary
}

fn cot(u: DVec3, v: DVec3) -> f64 {
    let s = u.cross(v).length();
    if s > 0.0 {
        u.dot(v) / s
    } else {
        0.0
    }
}

/// Signed mean curvature H of every vertex (input order and count; in 1/input units).
pub fn mean_curvature(mesh: &Mesh) -> (Vec<f64>, CurvatureReport) {
    let n = mesh.positions.len();
    let mut laplace = vec![DVec3::ZERO; n];
    let mut area = vec![0.0; n];
    for t in 0..mesh.triangles.len() {
        let idx = mesh.triangles[t].map(|i| i as usize);
        let p = idx.map(|i| mesh.positions[i]);
        // Cotangent of the angle at each corner.
        let c: [f64; 3] = std::array::from_fn(|k| {
            let (a, b, o) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            cot(b - a, o - a)
        });
        let tri_area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let obtuse = (0..3).find(|&k| {
            let (a, b, o) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
            (b - a).dot(o - a) < 0.0
        });
        for k in 0..3 {
            let (i, j, l) = (k, (k + 1) % 3, (k + 2) % 3);
            // Edge (j, l) is opposite corner i and carries cot at i.
            laplace[idx[j]] += c[i] * (p[j] - p[l]);
            laplace[idx[l]] += c[i] * (p[l] - p[j]);
            area[idx[i]] += match obtuse {
                None => {
                    // Voronoi region of corner i: (|ij|² cot l + |il|² cot j) / 8
                    ((p[j] - p[i]).length_squared() * c[l] + (p[l] - p[i]).length_squared() * c[j])
                        / 8.0
                }
                Some(o) if o == i => tri_area / 2.0,
                Some(_) => tri_area / 4.0,
            };
        }
    }
    let normals = mesh.vertex_normals();
    let boundary = boundary_vertices(mesh);
    let mut report = CurvatureReport::default();
    let mut h: Vec<f64> = (0..n)
        .map(|v| {
            if area[v] <= 0.0 {
                report.vertices_without_area += 1;
                return 0.0;
            }
            let k = laplace[v] / (2.0 * area[v]);
            0.5 * k.length() * k.dot(normals[v]).signum()
        })
        .collect();
    let adjacency = VertexAdjacency::of_mesh(mesh);
    let interior = h.clone();
    for v in 0..n {
        if !boundary[v] {
            continue;
        }
        report.boundary_vertices += 1;
        let inner: Vec<f64> = adjacency
            .neighbours(v)
            .iter()
            .filter(|&&u| !boundary[u as usize])
            .map(|&u| interior[u as usize])
            .collect();
        h[v] = if inner.is_empty() {
            report.boundary_vertices_without_interior_neighbour += 1;
            0.0
        } else {
            inner.iter().sum::<f64>() / inner.len() as f64
        };
    }
    (h, report)
}

/// Small synthetic meshes with known geometry, for tests and examples.
pub mod test_meshes {
    use super::*;

    /// Icosphere of radius r with `levels` midpoint subdivisions, projected to the sphere.
    pub fn icosphere(r: f64, levels: usize) -> Mesh {
        let t = (1.0 + 5f64.sqrt()) / 2.0;
        let mut positions: Vec<DVec3> = [
            (-1.0, t, 0.0),
            (1.0, t, 0.0),
            (-1.0, -t, 0.0),
            (1.0, -t, 0.0),
            (0.0, -1.0, t),
            (0.0, 1.0, t),
            (0.0, -1.0, -t),
            (0.0, 1.0, -t),
            (t, 0.0, -1.0),
            (t, 0.0, 1.0),
            (-t, 0.0, -1.0),
            (-t, 0.0, 1.0),
        ]
        .iter()
        .map(|&(x, y, z)| DVec3::new(x, y, z).normalize() * r)
        .collect();
        let triangles = vec![
            [0, 11, 5],
            [0, 5, 1],
            [0, 1, 7],
            [0, 7, 10],
            [0, 10, 11],
            [1, 5, 9],
            [5, 11, 4],
            [11, 10, 2],
            [10, 7, 6],
            [7, 1, 8],
            [3, 9, 4],
            [3, 4, 2],
            [3, 2, 6],
            [3, 6, 8],
            [3, 8, 9],
            [4, 9, 5],
            [2, 4, 11],
            [6, 2, 10],
            [8, 6, 7],
            [9, 8, 1],
        ];
        let mut mesh = Mesh {
            positions: std::mem::take(&mut positions),
            triangles,
        };
        for _ in 0..levels {
            mesh = crate::mesh::subdivide_midpoint(&mesh);
            for p in &mut mesh.positions {
                *p = p.normalize() * r;
            }
        }
        mesh
    }

    /// A unit square height field z = height(x, y) of n × n vertices, x and y from `origin` to
    /// `origin + 1`.
    pub fn height_field(n: usize, origin: f64, height: impl Fn(f64, f64) -> f64) -> Mesh {
        let mut positions = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let x = origin + i as f64 / (n - 1) as f64;
                let y = origin + j as f64 / (n - 1) as f64;
                positions.push(DVec3::new(x, y, height(x, y)));
            }
        }
        let mut triangles = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
                triangles.push([a, b, d]);
                triangles.push([a, d, c]);
            }
        }
        Mesh {
            positions,
            triangles,
        }
    }

    /// Open cylinder of radius r around z, `around` × `along` vertices.
    pub fn cylinder(r: f64, height: f64, around: usize, along: usize) -> Mesh {
        let mut positions = Vec::new();
        for j in 0..along {
            for i in 0..around {
                let a = 2.0 * std::f64::consts::PI * i as f64 / around as f64;
                positions.push(DVec3::new(
                    r * a.cos(),
                    r * a.sin(),
                    height * j as f64 / (along - 1) as f64,
                ));
            }
        }
        let mut triangles = Vec::new();
        for j in 0..along - 1 {
            for i in 0..around {
                let a = (j * around + i) as u32;
                let b = (j * around + (i + 1) % around) as u32;
                let c = a + around as u32;
                let d = b + around as u32;
                triangles.push([a, b, d]);
                triangles.push([a, d, c]);
            }
        }
        Mesh {
            positions,
            triangles,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_meshes::*;
    use super::*;

    #[test]
    fn sphere_has_mean_curvature_one_over_r() {
        let mesh = icosphere(2.0, 4);
        let (h, report) = mean_curvature(&mesh);
        assert_eq!(report.boundary_vertices, 0);
        for v in h {
            assert!((v - 0.5).abs() <= 0.01 * 0.5, "H = {v}, expected 0.5");
        }
    }

    #[test]
    fn cylinder_has_mean_curvature_one_over_2r() {
        let mesh = cylinder(0.5, 3.0, 128, 60);
        let (h, report) = mean_curvature(&mesh);
        assert_eq!(report.boundary_vertices, 2 * 128);
        for v in h {
            assert!((v - 1.0).abs() <= 0.02, "H = {v}, expected 1.0");
        }
    }
}

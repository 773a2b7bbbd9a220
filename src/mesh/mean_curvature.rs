//! Signed mean curvature per vertex by the cotangent formula of Meyer, Desbrun, Schröder and
//! Barr 2003 ("Discrete differential-geometry operators for triangulated 2-manifolds"):
//! K(v) = 1/(2 A_mixed) Σ_j (cot α_ij + cot β_ij)(v − v_j) = 2 H n, so |H| = |K|/2 with the sign
//! of K · n (positive where the surface is convex with outward normals).
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::mesh::Mesh;

/// What the curvature estimate met on the mesh.
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

/// The triangles around each vertex as compressed rows, in increasing triangle order: built
/// by counting (no sort), so per-vertex sums over it add the same terms in the same order as
/// a sequential loop over triangles would, and can run in parallel with the same bytes out.
pub struct VertexTriangles {
    offsets: Vec<usize>,
    /// triangle index × 3 + the vertex's corner in it.
    corners: Vec<u32>,
}

impl VertexTriangles {
    /// The triangles around each vertex of `mesh`.
    pub fn of_mesh(mesh: &Mesh) -> VertexTriangles {
        let n = mesh.positions.len();
        let mut offsets = vec![0usize; n + 1];
        for t in &mesh.triangles {
            for &v in t {
                offsets[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut fill = offsets.clone();
        let mut corners = vec![0u32; offsets[n]];
        for (t, tri) in mesh.triangles.iter().enumerate() {
            for (k, &v) in tri.iter().enumerate() {
                corners[fill[v as usize]] = (t * 3 + k) as u32;
                fill[v as usize] += 1;
            }
        }
        VertexTriangles { offsets, corners }
    }

    /// (triangle, corner) pairs of vertex v, triangles increasing.
    pub fn of_vertex(&self, v: usize) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.corners[self.offsets[v]..self.offsets[v + 1]]
            .iter()
            .map(|&c| (c as usize / 3, c as usize % 3))
    }

    /// The other vertex of every edge at v, once per triangle using that edge, sorted: a
    /// neighbour listed once sits on a boundary edge with v.
    fn edge_partners(&self, mesh: &Mesh, v: usize, out: &mut Vec<u32>) {
        out.clear();
        for (t, k) in self.of_vertex(v) {
            let tri = mesh.triangles[t];
            out.push(tri[(k + 1) % 3]);
            out.push(tri[(k + 2) % 3]);
        }
        out.sort_unstable();
    }
}

/// Vertex adjacency (1-ring) as compressed rows: neighbours of v are
/// `targets[offsets[v]..offsets[v + 1]]`, sorted, without duplicates.
pub struct VertexAdjacency {
    /// Where each vertex's neighbours start in `targets` (one more entry than vertices).
    pub offsets: Vec<usize>,
    /// Every vertex's neighbours, one row after another.
    pub targets: Vec<u32>,
}

impl VertexAdjacency {
    /// The 1-ring of every vertex of `mesh`.
    pub fn of_mesh(mesh: &Mesh) -> VertexAdjacency {
        VertexAdjacency::from_incidence(mesh, &VertexTriangles::of_mesh(mesh))
    }

    /// The 1-ring from an incidence already built.
    pub fn from_incidence(mesh: &Mesh, incidence: &VertexTriangles) -> VertexAdjacency {
        let n = mesh.positions.len();
        let rows: Vec<Vec<u32>> = (0..n)
            .into_par_iter()
            .map_init(Vec::new, |scratch, v| {
                incidence.edge_partners(mesh, v, scratch);
                let mut row = scratch.clone();
                row.dedup();
                row
            })
            .collect();
        let mut offsets = Vec::with_capacity(n + 1);
        offsets.push(0);
        let mut targets = Vec::with_capacity(rows.iter().map(Vec::len).sum());
        for row in rows {
            targets.extend_from_slice(&row);
            offsets.push(targets.len());
        }
        VertexAdjacency { offsets, targets }
    }

    /// The neighbours of `v`, sorted.
    pub fn neighbours(&self, v: usize) -> &[u32] {
        &self.targets[self.offsets[v]..self.offsets[v + 1]]
    }
}

/// Vertices on an edge used by exactly one triangle.
pub fn boundary_vertices(mesh: &Mesh) -> Vec<bool> {
    boundary_vertices_from(mesh, &VertexTriangles::of_mesh(mesh))
}

fn boundary_vertices_from(mesh: &Mesh, incidence: &VertexTriangles) -> Vec<bool> {
    (0..mesh.positions.len())
        .into_par_iter()
        .map_init(Vec::new, |partners, v| {
            incidence.edge_partners(mesh, v, partners);
            partners.chunk_by(|a, b| a == b).any(|run| run.len() == 1)
        })
        .collect()
}

/// The gather waits on memory: a vertex's triangles and their corners' positions are spread
/// over the arrays. So it asks for them ahead of use: the triangles of the vertex visited
/// `FAR` steps later, and the positions of the one `NEAR` steps later, whose triangles were
/// asked for earlier. Prefetches change no value.
#[inline(always)]
fn prefetch_ahead(mesh: &Mesh, incidence: &VertexTriangles, order: &[(u32, u32)], i: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        const NEAR: usize = 8;
        const FAR: usize = 20;
        if let Some(&(_, far)) = order.get(i + FAR) {
            for (t, _) in incidence.of_vertex(far as usize) {
                // SAFETY: SSE is in every x86_64 CPU; a prefetch is a hint that reads nothing
                // into the program and cannot fault.
                unsafe { _mm_prefetch::<_MM_HINT_T0>(mesh.triangles[t].as_ptr().cast()) };
            }
        }
        if let Some(&(_, near)) = order.get(i + NEAR) {
            for (t, _) in incidence.of_vertex(near as usize) {
                for &c in &mesh.triangles[t] {
                    let at: *const DVec3 = &mesh.positions[c as usize];
                    // SAFETY: as above.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>(at.cast()) };
                }
            }
        }
    }
}

fn cot(u: DVec3, v: DVec3) -> f64 {
    let s = u.cross(v).length();
    if s > 0.0 {
        u.dot(v) / s
    } else {
        0.0
    }
}

/// One triangle's cotangents (of the angle at each corner) and each corner's mixed area.
fn triangle_terms(p: [DVec3; 3]) -> ([f64; 3], [f64; 3]) {
    let c: [f64; 3] = std::array::from_fn(|k| {
        let (a, b, o) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
        cot(b - a, o - a)
    });
    let tri_area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
    let obtuse = (0..3).find(|&k| {
        let (a, b, o) = (p[k], p[(k + 1) % 3], p[(k + 2) % 3]);
        (b - a).dot(o - a) < 0.0
    });
    let area = std::array::from_fn(|i| {
        let (j, l) = ((i + 1) % 3, (i + 2) % 3);
        match obtuse {
            None => {
                // Voronoi region of corner i: (|ij|² cot l + |il|² cot j) / 8
                ((p[j] - p[i]).length_squared() * c[l] + (p[l] - p[i]).length_squared() * c[j])
                    / 8.0
            }
            Some(o) if o == i => tri_area / 2.0,
            Some(_) => tri_area / 4.0,
        }
    });
    (c, area)
}

/// Corner q's two terms of K, c_i (p_q − p_other) for the other corners i in increasing
/// order, as a loop over the triangle's edges (j, l) opposite each corner i adds them.
fn corner_laplace_terms(p: [DVec3; 3], c: [f64; 3], q: usize) -> [DVec3; 2] {
    let (a, b) = ((q + 1) % 3, (q + 2) % 3);
    let (first, second) = if a < b { (a, b) } else { (b, a) };
    // The term from corner i pairs q with the corner that is neither q nor i.
    [
        c[first] * (p[q] - p[3 - q - first]),
        c[second] * (p[q] - p[3 - q - second]),
    ]
}

/// Signed mean curvature H of every vertex (input order and count; in 1/input units).
pub fn mean_curvature(mesh: &Mesh) -> (Vec<f64>, CurvatureReport) {
    mean_curvature_with(mesh, &VertexTriangles::of_mesh(mesh))
}

/// [`mean_curvature`] over an incidence the caller built (and may use again).
pub fn mean_curvature_with(
    mesh: &Mesh,
    incidence: &VertexTriangles,
) -> (Vec<f64>, CurvatureReport) {
    let n = mesh.positions.len();
    // Each vertex gathers its triangles' terms in triangle order: the sums a sequential
    // scatter over triangles makes, bit for bit, on any number of threads. The same walk over
    // its triangles tells whether it sits on a boundary edge. Vertices are visited in the
    // order of their first triangle, so neighbouring visits read neighbouring triangles,
    // positions and terms from cache (the results do not depend on the visiting order).
    let mut order: Vec<(u32, u32)> = (0..n)
        .into_par_iter()
        .map(|v| {
            let first = incidence
                .of_vertex(v)
                .next()
                .map_or(u32::MAX, |(t, _)| t as u32);
            (first, v as u32)
        })
        .collect();
    order.par_sort_unstable();
    let visited: Vec<(f64, bool, bool)> = (0..order.len())
        .into_par_iter()
        .map_init(Vec::new, |partners, i| {
            prefetch_ahead(mesh, incidence, &order, i);
            let v = order[i].1 as usize;
            let mut laplace = DVec3::ZERO;
            let mut area = 0.0;
            let mut normal = DVec3::ZERO;
            partners.clear();
            for (t, k) in incidence.of_vertex(v) {
                let tri = mesh.triangles[t];
                let p = tri.map(|i| mesh.positions[i as usize]);
                // Recomputed at each of the triangle's three corners rather than stored:
                // the positions are loaded here anyway, and a table of every triangle's
                // terms (48 bytes each) costs more in memory traffic than the arithmetic.
                let (c, areas) = triangle_terms(p);
                let [first, second] = corner_laplace_terms(p, c, k);
                laplace += first;
                laplace += second;
                area += areas[k];
                normal += (p[1] - p[0]).cross(p[2] - p[0]);
                partners.push(tri[(k + 1) % 3]);
                partners.push(tri[(k + 2) % 3]);
            }
            partners.sort_unstable();
            let on_boundary = partners.chunk_by(|a, b| a == b).any(|run| run.len() == 1);
            if area <= 0.0 {
                return (0.0, false, on_boundary);
            }
            let k = laplace / (2.0 * area);
            (
                0.5 * k.length() * k.dot(normal.normalize_or_zero()).signum(),
                true,
                on_boundary,
            )
        })
        .collect();
    // The interior formula's value of every vertex, then the boundary vertices (few) replaced
    // by the mean over their interior neighbours, which the replacement leaves unchanged.
    let mut h = vec![0.0; n];
    let mut boundary = vec![false; n];
    let mut report = CurvatureReport::default();
    for (&(_, v), &(value, has_area, on_boundary)) in order.iter().zip(&visited) {
        h[v as usize] = value;
        boundary[v as usize] = on_boundary;
        report.vertices_without_area += usize::from(!has_area);
        report.boundary_vertices += usize::from(on_boundary);
    }
    let on_boundary: Vec<usize> = (0..n).filter(|&v| boundary[v]).collect();
    let replaced: Vec<Option<f64>> = on_boundary
        .par_iter()
        .map_init(Vec::new, |partners, &v| {
            incidence.edge_partners(mesh, v, partners);
            partners.dedup();
            let inner: Vec<f64> = partners
                .iter()
                .filter(|&&u| !boundary[u as usize])
                .map(|&u| h[u as usize])
                .collect();
            (!inner.is_empty()).then(|| inner.iter().sum::<f64>() / inner.len() as f64)
        })
        .collect();
    for (&v, value) in on_boundary.iter().zip(replaced) {
        if value.is_none() {
            report.boundary_vertices_without_interior_neighbour += 1;
        }
        h[v] = value.unwrap_or(0.0);
    }
    (h, report)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_meshes::*;

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

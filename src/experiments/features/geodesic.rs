//! Geodesic distances on a mesh by Dijkstra on a Steiner-point graph (Lanthier et al.; the
//! "subdivision Dijkstra" of Kirsanov's toolbox): every edge carries `steiner` evenly spaced
//! extra points, and all points on a triangle's boundary are joined by straight segments
//! across the triangle. Paths stay on the surface, so distances are never below the true
//! polyhedral geodesic; with 0 Steiner points this is plain edge Dijkstra (up to +15% on a
//! regular lattice), with 3 the error is about 1% (tests/features.rs measures it on a sphere).
//! Dijkstra stops at a radius, so bounded queries (feature separation, matching) stay local.
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

use glam::DVec3;

use crate::mesh::Mesh;

/// A graph for geodesic distances on a mesh: its edges, plus Steiner points on them when asked.
pub struct GeodesicGraph {
    /// Graph nodes: mesh vertices first (node v = vertex v), then Steiner points.
    positions: Vec<DVec3>,
    vertices: usize,
    offsets: Vec<usize>,
    targets: Vec<u32>,
    lengths: Vec<f64>,
}

#[derive(PartialEq)]
struct Entry(f64, u32);
impl Eq for Entry {}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        // Min-heap on distance, ties by node for a deterministic order.
        o.0.total_cmp(&self.0).then(o.1.cmp(&self.1))
    }
}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

impl GeodesicGraph {
    /// The graph of `mesh` with `steiner` points on each edge (0: the plain edge graph).
    pub fn new(mesh: &Mesh, steiner: usize) -> GeodesicGraph {
        let n = mesh.positions.len();
        let mut positions = mesh.positions.clone();
        // Steiner points per undirected edge, in order from the lower vertex index.
        let mut edge_points: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
        let mut pairs: Vec<(u32, u32)> = Vec::new();
        for t in &mesh.triangles {
            let mut boundary: Vec<u32> = Vec::with_capacity(3 + 3 * steiner);
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                let key = (a.min(b), a.max(b));
                let pts = edge_points.entry(key).or_insert_with(|| {
                    let (p, q) = (
                        mesh.positions[key.0 as usize],
                        mesh.positions[key.1 as usize],
                    );
                    (1..=steiner)
                        .map(|i| {
                            positions.push(p.lerp(q, i as f64 / (steiner + 1) as f64));
                            (positions.len() - 1) as u32
                        })
                        .collect()
                });
                boundary.push(a);
                boundary.extend(pts.iter().copied());
            }
            for i in 0..boundary.len() {
                for j in i + 1..boundary.len() {
                    pairs.push((boundary[i], boundary[j]));
                    pairs.push((boundary[j], boundary[i]));
                }
            }
        }
        pairs.sort_unstable();
        pairs.dedup();
        let m = positions.len();
        let mut offsets = vec![0usize; m + 1];
        for &(a, _) in &pairs {
            offsets[a as usize + 1] += 1;
        }
        for i in 0..m {
            offsets[i + 1] += offsets[i];
        }
        let targets: Vec<u32> = pairs.iter().map(|p| p.1).collect();
        let lengths = pairs
            .iter()
            .map(|&(a, b)| positions[a as usize].distance(positions[b as usize]))
            .collect();
        GeodesicGraph {
            positions,
            vertices: n,
            offsets,
            targets,
            lengths,
        }
    }

    /// Nodes: the mesh's vertices, then the Steiner points.
    pub fn node_count(&self) -> usize {
        self.positions.len()
    }

    /// Distances from vertex `source` to every mesh vertex within `max_distance` (others
    /// absent), as (vertex, distance) sorted by vertex.
    pub fn distances_from(&self, source: usize, max_distance: f64) -> Vec<(usize, f64)> {
        let mut dist: HashMap<u32, f64> = HashMap::new();
        let mut heap = BinaryHeap::new();
        dist.insert(source as u32, 0.0);
        heap.push(Entry(0.0, source as u32));
        let mut out = Vec::new();
        while let Some(Entry(d, u)) = heap.pop() {
            if d > dist[&u] {
                continue;
            }
            if (u as usize) < self.vertices {
                out.push((u as usize, d));
            }
            let u = u as usize;
            for k in self.offsets[u]..self.offsets[u + 1] {
                let (v, nd) = (self.targets[k], d + self.lengths[k]);
                if nd <= max_distance && dist.get(&v).is_none_or(|&old| nd < old) {
                    dist.insert(v, nd);
                    heap.push(Entry(nd, v));
                }
            }
        }
        out.sort_unstable_by_key(|x| x.0);
        out
    }

    /// Distances from `source` to every vertex (infinite where unreachable).
    pub fn all_distances_from(&self, source: usize) -> Vec<f64> {
        let mut d = vec![f64::INFINITY; self.vertices];
        for (v, x) in self.distances_from(source, f64::INFINITY) {
            d[v] = x;
        }
        d
    }

    /// The mesh diameter by a double sweep: the farthest vertex from vertex 0's farthest
    /// vertex. A lower bound on the true diameter (exact on many shapes); the component of
    /// vertex 0 only.
    pub fn diameter_double_sweep(&self) -> f64 {
        if self.vertices == 0 {
            return 0.0;
        }
        let far = |s: usize| {
            self.all_distances_from(s)
                .iter()
                .enumerate()
                .filter(|x| x.1.is_finite())
                .max_by(|a, b| a.1.total_cmp(b.1))
                .map_or((s, 0.0), |(i, &d)| (i, d))
        };
        let (a, _) = far(0);
        far(a).1
    }
}

//! The mesh's edges as a weighted graph (edge length), and shortest paths along it: the
//! "geodesic" distance of the methods that measure along the surface's connectivity (SRI,
//! GR, MR), which is also why those methods suffer from holes and broken meshes.
use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::DVec3;

use crate::mesh::Mesh;

/// Compressed adjacency: the neighbours of vertex `v` are
/// `neighbours[offsets[v]..offsets[v + 1]]`, sorted by index, with their edge lengths.
#[derive(Debug, Clone)]
pub struct EdgeGraph {
    pub offsets: Vec<usize>,
    pub neighbours: Vec<u32>,
    pub lengths: Vec<f64>,
}

impl EdgeGraph {
    /// Every triangle side once per direction; non-manifold edges are simply shared.
    pub fn of_mesh(mesh: &Mesh) -> EdgeGraph {
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
        for v in 0..n {
            offsets[v + 1] += offsets[v];
        }
        let lengths = pairs
            .iter()
            .map(|&(a, b)| mesh.positions[a as usize].distance(mesh.positions[b as usize]))
            .collect();
        EdgeGraph {
            offsets,
            neighbours: pairs.into_iter().map(|(_, b)| b).collect(),
            lengths,
        }
    }

    pub fn neighbours_of(&self, v: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let r = self.offsets[v]..self.offsets[v + 1];
        self.neighbours[r.clone()]
            .iter()
            .zip(&self.lengths[r])
            .map(|(&u, &l)| (u as usize, l))
    }

    /// Lowers `distance` (and sets `label`) wherever a path from `source` is shorter than what
    /// is there; returns how many vertices changed. Run once per source with the arrays kept,
    /// this is a multi-source Dijkstra that only revisits the region each new source wins,
    /// which is what makes farthest-point sampling cheap.
    pub fn relax_from(
        &self,
        source: usize,
        source_label: u32,
        distance: &mut [f64],
        label: &mut [u32],
    ) -> usize {
        let mut heap = BinaryHeap::new();
        distance[source] = 0.0;
        label[source] = source_label;
        heap.push(Entry(0.0, source));
        let mut changed = 1;
        while let Some(Entry(d, v)) = heap.pop() {
            if d > distance[v] {
                continue;
            }
            for (u, l) in self.neighbours_of(v) {
                let nd = d + l;
                if nd < distance[u] {
                    distance[u] = nd;
                    label[u] = source_label;
                    changed += 1;
                    heap.push(Entry(nd, u));
                }
            }
        }
        changed
    }
}

/// Min-heap entry ordered by distance, then vertex index, so ties resolve the same way on
/// every run.
struct Entry(f64, usize);

impl PartialEq for Entry {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other
            .0
            .total_cmp(&self.0)
            .then_with(|| other.1.cmp(&self.1))
    }
}

/// Shortest-path distances on a small dense graph given as a symmetric edge list over `n`
/// nodes: one Dijkstra per node (used on patch graphs of a few hundred nodes).
pub fn all_pairs_shortest_paths(n: usize, edges: &[(usize, usize, f64)]) -> Vec<Vec<f64>> {
    let mut adjacency: Vec<Vec<(usize, f64)>> = vec![Vec::new(); n];
    for &(a, b, w) in edges {
        adjacency[a].push((b, w));
        adjacency[b].push((a, w));
    }
    (0..n)
        .map(|s| {
            let mut dist = vec![f64::INFINITY; n];
            dist[s] = 0.0;
            let mut heap = BinaryHeap::new();
            heap.push(Entry(0.0, s));
            while let Some(Entry(d, v)) = heap.pop() {
                if d > dist[v] {
                    continue;
                }
                for &(u, w) in &adjacency[v] {
                    if d + w < dist[u] {
                        dist[u] = d + w;
                        heap.push(Entry(d + w, u));
                    }
                }
            }
            dist
        })
        .collect()
}

/// Straight-line distance, used where two points have no path between them (different
/// components): the methods then compare them as if across empty space.
pub fn distance_or_euclidean(path: f64, a: DVec3, b: DVec3) -> f64 {
    let e = a.distance(b);
    if path.is_finite() {
        path.max(e)
    } else {
        e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strip() -> Mesh {
        // Two triangles forming a unit square, plus one isolated vertex.
        Mesh {
            positions: vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(1.0, 1.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(5.0, 5.0, 5.0),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn shortest_paths_follow_edges_and_leave_unreachable_at_infinity() {
        let g = EdgeGraph::of_mesh(&strip());
        let mut d = vec![f64::INFINITY; 5];
        let mut l = vec![u32::MAX; 5];
        g.relax_from(1, 7, &mut d, &mut l);
        assert_eq!(d[1], 0.0);
        assert!((d[3] - 2.0).abs() < 1e-12, "1→0→3 or 1→2→3: {}", d[3]);
        assert!((d[0] - 1.0).abs() < 1e-12);
        assert!(d[4].is_infinite() && l[4] == u32::MAX);
        assert_eq!(l[3], 7);
        // A second source only takes what it is nearer to.
        let changed = g.relax_from(3, 8, &mut d, &mut l);
        assert_eq!(l[1], 7);
        assert_eq!(l[3], 8);
        assert!((1..4).contains(&changed));
    }

    #[test]
    fn all_pairs_matches_the_triangle_inequality() {
        let d = all_pairs_shortest_paths(3, &[(0, 1, 1.0), (1, 2, 1.0), (0, 2, 5.0)]);
        assert_eq!(d[0][2], 2.0);
        assert_eq!(d[2][0], 2.0);
        let d = all_pairs_shortest_paths(3, &[(0, 1, 1.0)]);
        assert!(d[0][2].is_infinite());
        assert_eq!(
            distance_or_euclidean(d[0][2], DVec3::ZERO, DVec3::X * 3.0),
            3.0
        );
    }
}

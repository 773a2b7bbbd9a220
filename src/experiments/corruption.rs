//! Controlled damage to meshes, to test how saliency holds up (paper §5.4, Fig. 8).
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

use crate::mesh::Mesh;
use crate::random::standard_normal;

/// Moves every vertex along its normal by Gaussian noise with standard deviation
/// `fraction` × the mean edge length (the paper's "20% noise": fraction = 0.2). Seeded.
pub fn add_normal_noise(mesh: &Mesh, fraction: f64, seed: u64) -> Mesh {
    let sd = fraction * mesh.mean_edge_length();
    let normals = mesh.vertex_normals();
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let positions = mesh
        .positions
        .iter()
        .zip(&normals)
        .map(|(&p, &n)| p + n * (sd * standard_normal(&mut rng)))
        .collect();
    Mesh {
        positions,
        triangles: mesh.triangles.clone(),
    }
}

/// Cuts `holes` patches out of the surface: around seeded random vertices, every triangle
/// with a corner within `radius` (Euclidean) goes, and vertices no triangle uses any more are
/// dropped. Returns the damaged mesh and, for each of its vertices, the input vertex it was.
/// Patch centres are drawn at least 3 radii apart, so the patches stay separate holes.
pub fn cut_holes(mesh: &Mesh, holes: usize, radius: f64, seed: u64) -> (Mesh, Vec<usize>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let n = mesh.positions.len();
    let mut centres: Vec<DVec3> = Vec::new();
    let mut tries = 0;
    while centres.len() < holes && tries < 1000 * holes.max(1) && n > 0 {
        tries += 1;
        let c = mesh.positions[rng.random_range(0..n)];
        if centres.iter().all(|o| o.distance(c) >= 3.0 * radius) {
            centres.push(c);
        }
    }
    let inside = |p: DVec3| centres.iter().any(|c| c.distance(p) <= radius);
    let kept: Vec<[u32; 3]> = mesh
        .triangles
        .iter()
        .filter(|t| !t.iter().any(|&i| inside(mesh.positions[i as usize])))
        .copied()
        .collect();
    let mut new_index = vec![u32::MAX; n];
    let mut origin = Vec::new();
    for t in &kept {
        for &i in t {
            if new_index[i as usize] == u32::MAX {
                new_index[i as usize] = origin.len() as u32;
                origin.push(i as usize);
            }
        }
    }
    let positions = origin.iter().map(|&i| mesh.positions[i]).collect();
    let triangles = kept
        .iter()
        .map(|t| t.map(|i| new_index[i as usize]))
        .collect();
    (
        Mesh {
            positions,
            triangles,
        },
        origin,
    )
}

/// Closed loops of boundary edges (edges used by one triangle): 0 for a closed mesh, one per
/// hole otherwise.
pub fn boundary_loops(mesh: &Mesh) -> usize {
    use std::collections::HashMap;
    let mut count: HashMap<(u32, u32), i32> = HashMap::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            *count.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    // Boundary edges as an undirected graph; loops = its connected components.
    let mut adj: HashMap<u32, Vec<u32>> = HashMap::new();
    for (&(a, b), &c) in &count {
        if c == 1 {
            adj.entry(a).or_default().push(b);
            adj.entry(b).or_default().push(a);
        }
    }
    let mut seen: std::collections::HashSet<u32> = Default::default();
    let mut loops = 0;
    let mut keys: Vec<u32> = adj.keys().copied().collect();
    keys.sort_unstable();
    for start in keys {
        if !seen.insert(start) {
            continue;
        }
        loops += 1;
        let mut stack = vec![start];
        while let Some(v) = stack.pop() {
            for &w in &adj[&v] {
                if seen.insert(w) {
                    stack.push(w);
                }
            }
        }
    }
    loops
}

/// Values carried to `targets` from the nearest point on the surface of `source`: the
/// closest point among the triangles around the few nearest source vertices, with the
/// value interpolated barycentrically there.
pub fn transfer_by_nearest_surface_point(
    source: &Mesh,
    values: &[f64],
    targets: &[DVec3],
) -> Vec<f64> {
    let pts: Vec<[f64; 3]> = source.positions.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&pts).expect("fewer than 2^32 vertices");
    let mut incident: Vec<Vec<u32>> = vec![Vec::new(); source.positions.len()];
    for (t, tri) in source.triangles.iter().enumerate() {
        for &i in tri {
            incident[i as usize].push(t as u32);
        }
    }
    targets
        .par_iter()
        .map(|p| {
            let near = tree
                .query(&p.to_array())
                .nearest_n::<SquaredEuclidean<f64>>(std::num::NonZero::new(8).expect("8 > 0"))
                .execute();
            let mut best = (f64::INFINITY, values[near[0].item as usize]);
            for nb in &near {
                for &t in &incident[nb.item as usize] {
                    let idx = source.triangles[t as usize].map(|i| i as usize);
                    let [a, b, c] = idx.map(|i| source.positions[i]);
                    let q = crate::mesh::geometry::closest_point_on_triangle(*p, a, b, c);
                    let d = q.distance_squared(*p);
                    if d < best.0 {
                        let w = barycentric(q, a, b, c);
                        best = (
                            d,
                            w[0] * values[idx[0]] + w[1] * values[idx[1]] + w[2] * values[idx[2]],
                        );
                    }
                }
            }
            best.1
        })
        .collect()
}

fn barycentric(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let (v0, v1, v2) = (b - a, c - a, p - a);
    let (d00, d01, d11) = (v0.dot(v0), v0.dot(v1), v1.dot(v1));
    let (d20, d21) = (v2.dot(v0), v2.dot(v1));
    let den = d00 * d11 - d01 * d01;
    if den.abs() < 1e-300 {
        return [1.0, 0.0, 0.0];
    }
    let v = (d11 * d20 - d01 * d21) / den;
    let w = (d00 * d21 - d01 * d20) / den;
    [1.0 - v - w, v, w]
}

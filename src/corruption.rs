//! Controlled damage to meshes, to test how saliency holds up (paper §5.4, Fig. 8).
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::mesh::Mesh;

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

/// Box–Muller: one standard normal deviate from two uniforms.
fn standard_normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>(); // (0, 1]: ln is finite
    let u2: f64 = rng.random();
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Values on `target` positions taken from the nearest vertex of a source mesh: carries a
/// per-vertex map from a corrupted or simplified copy back to the original vertices.
pub fn transfer_by_nearest_vertex(
    source_positions: &[DVec3],
    source_values: &[f64],
    target_positions: &[DVec3],
) -> Vec<f64> {
    let pts: Vec<[f64; 3]> = source_positions.iter().map(|p| p.to_array()).collect();
    let tree: ImmutableKdTree<f64, 3> =
        ImmutableKdTree::new_from_slice(&pts).expect("fewer than 2^32 vertices");
    target_positions
        .iter()
        .map(|p| {
            let hit = tree
                .query(&p.to_array())
                .nearest_one::<SquaredEuclidean<f64>>()
                .execute();
            source_values[hit.item as usize]
        })
        .collect()
}

//! Carrying a per-vertex map from one vertex set to another by nearest neighbour: from a
//! simplified or corrupted copy back to the original vertices.
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;

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
    // Each target's query is its own: in parallel, the same values in the same order.
    target_positions
        .par_iter()
        .map(|p| {
            let hit = tree
                .query(&p.to_array())
                .nearest_one::<SquaredEuclidean<f64>>()
                .execute();
            source_values[hit.item as usize]
        })
        .collect()
}

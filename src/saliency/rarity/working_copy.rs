//! The mesh the global-rarity methods work on: normalized (half the oriented bounding-box
//! diagonal = 1, so every radius is in the same units as SMS's and the map does not depend
//! on the mesh's scale or pose), simplified by quadric edge collapse when larger than the
//! method's vertex budget (as the originals did, to keep their all-pairs steps affordable),
//! and without vertices no triangle uses. Maps computed on it are carried back to every
//! input vertex by a Gaussian-weighted mean (the interpolation of SMS's step C).
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use serde::Serialize;

use crate::mesh::edge_graph::EdgeGraph;
use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::simplification::simplify_to_vertex_count;
use crate::mesh::vertex_areas::vertex_areas;
use crate::mesh::Mesh;
use crate::saliency::sms::gaussian_interpolation::{
    gaussian_interpolation, min_max_normalize, InterpolationKind,
};

pub struct WorkingCopy {
    /// Every input vertex in the normalized frame (input order and count).
    pub input_positions: Vec<DVec3>,
    pub mesh: Mesh,
    pub normals: Vec<DVec3>,
    pub areas: Vec<f64>,
    pub graph: EdgeGraph,
    pub simplified: bool,
    tree: ImmutableKdTree<f64, 3>,
}

#[derive(Debug, Clone, Serialize)]
pub struct WorkingCopyReport {
    pub input_vertices: usize,
    pub working_vertices: usize,
    pub working_triangles: usize,
    pub simplified: bool,
    /// σ of the Gaussian that carries the map back to the input vertices (normalized units).
    pub carry_back_sigma: f64,
}

impl WorkingCopy {
    pub fn new(mesh: &Mesh, vertex_budget: usize) -> Result<WorkingCopy, String> {
        let norm = Normalization::of_mesh(mesh, BoundingBox::Oriented);
        let normalized = norm.normalized_mesh(mesh);
        let used = used_vertex_count(&normalized);
        let (small, simplified) = if used > vertex_budget {
            (simplify_to_vertex_count(&normalized, vertex_budget).0, true)
        } else {
            (without_unused_vertices(&normalized), false)
        };
        if small.triangles.is_empty() || small.positions.len() < 4 {
            return Err(format!(
                "the mesh keeps {} vertices and {} triangles after simplification to {} vertices: too few to compare regions",
                small.positions.len(),
                small.triangles.len(),
                vertex_budget
            ));
        }
        let points: Vec<[f64; 3]> = small.positions.iter().map(|p| p.to_array()).collect();
        let tree = ImmutableKdTree::new_from_slice(&points).expect("fewer than 2^32 vertices");
        Ok(WorkingCopy {
            input_positions: normalized.positions,
            normals: small.vertex_normals(),
            areas: vertex_areas(&small),
            graph: EdgeGraph::of_mesh(&small),
            mesh: small,
            simplified,
            tree,
        })
    }

    pub fn len(&self) -> usize {
        self.mesh.positions.len()
    }

    /// Working vertices within `radius` of `p`, in index order (so sums over them do not
    /// depend on the tree's traversal).
    pub fn within(&self, p: DVec3, radius: f64) -> Vec<usize> {
        let hits = self
            .tree
            .query(&p.to_array())
            .within::<SquaredEuclidean<f64>>(radius * radius)
            .unsorted()
            .execute();
        let words = self.len().div_ceil(64);
        if hits.len() * 16 < words {
            let mut found: Vec<usize> = hits.into_iter().map(|h| h.item as usize).collect();
            found.sort_unstable();
            return found;
        }
        // Many hits: mark them in a bit set and read it in index order, cheaper than a sort
        // (the same ascending list; tree items are distinct).
        let mut marks = vec![0u64; words];
        for h in &hits {
            let i = h.item as usize;
            marks[i / 64] |= 1 << (i % 64);
        }
        let mut found = Vec::with_capacity(hits.len());
        for (w, &bits) in marks.iter().enumerate() {
            let mut rest = bits;
            while rest != 0 {
                found.push(w * 64 + rest.trailing_zeros() as usize);
                rest &= rest - 1;
            }
        }
        found
    }

    /// The carry-back σ: the working copy's mean edge length, so a value spreads over about
    /// one ring of working vertices and no further.
    pub fn carry_back_sigma(&self) -> f64 {
        self.mesh.mean_edge_length()
    }

    /// `values` (one per working vertex) at every input vertex, rescaled to [0, 1].
    pub fn carry_back(&self, values: &[f64]) -> Vec<f64> {
        let (mut out, _) = gaussian_interpolation(
            &self.mesh.positions,
            values,
            &self.input_positions,
            self.carry_back_sigma(),
            InterpolationKind::Normalized,
        );
        min_max_normalize(&mut out);
        out
    }

    pub fn report(&self) -> WorkingCopyReport {
        WorkingCopyReport {
            input_vertices: self.input_positions.len(),
            working_vertices: self.len(),
            working_triangles: self.mesh.triangles.len(),
            simplified: self.simplified,
            carry_back_sigma: self.carry_back_sigma(),
        }
    }
}

fn used_vertex_count(mesh: &Mesh) -> usize {
    let mut used = vec![false; mesh.positions.len()];
    for t in &mesh.triangles {
        for &i in t {
            used[i as usize] = true;
        }
    }
    used.iter().filter(|&&u| u).count()
}

fn without_unused_vertices(mesh: &Mesh) -> Mesh {
    let mut new_index = vec![u32::MAX; mesh.positions.len()];
    let mut positions = Vec::new();
    let triangles = mesh
        .triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                let i = i as usize;
                if new_index[i] == u32::MAX {
                    new_index[i] = positions.len() as u32;
                    positions.push(mesh.positions[i]);
                }
                new_index[i]
            })
        })
        .collect();
    Mesh {
        positions,
        triangles,
    }
}

/// How much a map varies before it is rescaled to [0, 1]: rescaling stretches any variation,
/// even a featureless shape's numerical noise, to the full range, so this is what says
/// whether a map is flat.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RawSpread {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    /// Area-weighted standard deviation.
    pub std: f64,
    /// Standard deviation over mean (area-weighted), 0 for a constant map.
    pub coefficient_of_variation: f64,
}

impl RawSpread {
    pub fn of(values: &[f64], areas: &[f64]) -> RawSpread {
        let total: f64 = areas.iter().sum::<f64>().max(f64::MIN_POSITIVE);
        let mean = values.iter().zip(areas).map(|(v, a)| v * a).sum::<f64>() / total;
        let var = values
            .iter()
            .zip(areas)
            .map(|(v, a)| a * (v - mean) * (v - mean))
            .sum::<f64>()
            / total;
        RawSpread {
            min: values.iter().cloned().fold(f64::INFINITY, f64::min),
            max: values.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
            mean,
            std: var.sqrt(),
            coefficient_of_variation: if mean.abs() > 0.0 {
                var.sqrt() / mean.abs()
            } else {
                0.0
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::load_mesh;

    /// Whether the hits are few (sorted) or many (read from a bit set), the list is the
    /// tree's hits in ascending order.
    #[test]
    fn within_lists_the_trees_hits_in_index_order_for_small_and_large_radii() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("stimuli/meshes/bun_zipper_res2.ply");
        let (mesh, _) = load_mesh(&path).unwrap();
        let work = WorkingCopy::new(&mesh, 4000).unwrap();
        let mut both_paths = [false, false];
        for (k, &v) in [0usize, 17, 1000, 2500].iter().enumerate() {
            let p = work.mesh.positions[v.min(work.len() - 1)];
            for radius in [0.0, 0.01, 0.03, 0.1, 0.4, 3.0] {
                let mut expected: Vec<usize> = work
                    .tree
                    .query(&p.to_array())
                    .within::<SquaredEuclidean<f64>>(radius * radius)
                    .unsorted()
                    .execute()
                    .into_iter()
                    .map(|h| h.item as usize)
                    .collect();
                expected.sort_unstable();
                both_paths[usize::from(expected.len() * 16 >= work.len().div_ceil(64))] = true;
                assert_eq!(
                    work.within(p, radius),
                    expected,
                    "vertex {k}, radius {radius}"
                );
            }
        }
        assert_eq!(both_paths, [true, true]);
        assert_eq!(work.within(work.mesh.positions[0], 3.0).len(), work.len());
    }
}

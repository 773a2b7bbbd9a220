//! A training object recognised by its points, not its name: a model scored on a copy of one
//! of its own training meshes (renamed, re-saved as PLY, decompressed) would report a
//! training-set figure as if it were held out. The model file keeps a few of each object's
//! points; a mesh whose surface passes through nearly all of them holds that object.
//!
//! The surface, not only the vertices: a gaze-point file may hold points inside the mesh's
//! triangles (fixations-vr's meca and sofa have 20,000 points on 15,000-vertex meshes, a
//! quarter of them on faces), so a vertex test alone would miss a copy of such a mesh.
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

use crate::mesh::geometry::closest_point_on_triangle;
use crate::mesh::mean_curvature::VertexTriangles;
use crate::mesh::Mesh;

/// Points kept per training object.
pub const FINGERPRINT_POINTS: usize = 8;

/// Of the kept points, how many must lie on the surface: all but two, so a copy that lost a
/// few points still matches, while no two objects share six positions to 10⁻⁵ of their size.
pub const FINGERPRINT_MATCHES: usize = FINGERPRINT_POINTS - 2;

/// A point lies on the surface within this fraction of the mesh's bounding-box diagonal: far
/// above the rounding of a text or float32 copy (about 10⁻⁷), far below the spacing of any
/// mesh's vertices.
pub const FINGERPRINT_TOLERANCE: f64 = 1e-5;

/// Vertices around a point whose triangles are tested: a point inside a triangle has its
/// corners among its nearest vertices.
const NEAREST_VERTICES: usize = 16;

/// [`FINGERPRINT_POINTS`] of `positions`, evenly strided by index (the same points for the
/// same file, whatever the machine); all of them when there are fewer.
pub fn fingerprint_of(positions: &[DVec3]) -> Vec<[f64; 3]> {
    let n = positions.len();
    let take = n.min(FINGERPRINT_POINTS);
    (0..take)
        .map(|k| positions[k * n / take].to_array())
        .collect()
}

/// One mesh's surface, ready to be compared with fingerprints.
pub struct SurfaceLookup<'a> {
    mesh: &'a Mesh,
    tree: Option<ImmutableKdTree<f64, 3>>,
    /// Tree item → vertex index (non-finite vertices are left out of the tree).
    vertex_of_item: Vec<usize>,
    incidence: VertexTriangles,
    tolerance: f64,
}

impl<'a> SurfaceLookup<'a> {
    /// `mesh`'s vertices and triangles, with the tolerance scaled to its bounding box.
    pub fn new(mesh: &'a Mesh) -> SurfaceLookup<'a> {
        let vertex_of_item: Vec<usize> = (0..mesh.positions.len())
            .filter(|&v| mesh.positions[v].is_finite())
            .collect();
        let points: Vec<[f64; 3]> = vertex_of_item
            .iter()
            .map(|&v| mesh.positions[v].to_array())
            .collect();
        let (lo, hi) = vertex_of_item.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &v| (lo.min(mesh.positions[v]), hi.max(mesh.positions[v])),
        );
        let diagonal = if points.is_empty() {
            0.0
        } else {
            (hi - lo).length()
        };
        SurfaceLookup {
            mesh,
            tree: if points.is_empty() {
                None
            } else {
                ImmutableKdTree::new_from_slice(&points).ok()
            },
            vertex_of_item,
            incidence: VertexTriangles::of_mesh(mesh),
            tolerance: FINGERPRINT_TOLERANCE * diagonal,
        }
    }

    /// Whether the surface (a vertex, or a triangle around one of the nearest vertices)
    /// passes within the tolerance of `p`.
    fn on_surface(&self, p: DVec3) -> bool {
        let Some(tree) = &self.tree else { return false };
        let near = tree
            .query(&p.to_array())
            .nearest_n::<SquaredEuclidean<f64>>(NEAREST_VERTICES.try_into().expect("nonzero"))
            .execute();
        let tolerance_squared = self.tolerance * self.tolerance;
        if near
            .first()
            .is_some_and(|n| n.distance <= tolerance_squared)
        {
            return true;
        }
        let positions = &self.mesh.positions;
        near.iter().any(|n| {
            let v = self.vertex_of_item[n.item as usize];
            self.incidence.of_vertex(v).any(|(t, _)| {
                let [a, b, c] = self.mesh.triangles[t].map(|i| positions[i as usize]);
                closest_point_on_triangle(p, a, b, c).distance_squared(p) <= tolerance_squared
            })
        })
    }

    /// How many of `fingerprint`'s points lie on the surface.
    pub fn matches(&self, fingerprint: &[[f64; 3]]) -> usize {
        fingerprint
            .iter()
            .filter(|p| self.on_surface(DVec3::from_array(**p)))
            .count()
    }

    /// Whether the mesh holds the object `fingerprint` was taken from (an empty fingerprint,
    /// from a model file written before fingerprints were kept, never matches).
    pub fn holds(&self, fingerprint: &[[f64; 3]]) -> bool {
        fingerprint.len() >= FINGERPRINT_MATCHES && self.matches(fingerprint) >= FINGERPRINT_MATCHES
    }
}

/// The first of `model`'s training objects whose fingerprint `mesh`'s surface holds, with how
/// many of its points the surface passes through: a map or score of the model on it is a
/// training-set figure, whatever the file is called.
pub fn training_object_in<'m>(
    model: &'m super::GazeModel,
    mesh: &Mesh,
) -> Option<(&'m super::ObjectRecord, usize)> {
    let surface = SurfaceLookup::new(mesh);
    model
        .training
        .objects
        .iter()
        .find(|o| surface.holds(&o.fingerprint))
        .map(|o| (o, surface.matches(&o.fingerprint)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_meshes::icosphere;

    #[test]
    fn a_copy_matches_and_another_object_does_not() {
        let sphere = icosphere(1.0, 4);
        let fingerprint = fingerprint_of(&sphere.positions);
        assert_eq!(fingerprint.len(), FINGERPRINT_POINTS);
        // The same mesh as a text copy would hold it (6 decimals).
        let mut copy = sphere.clone();
        for p in &mut copy.positions {
            *p = (*p * 1e6).round() / 1e6;
        }
        assert!(SurfaceLookup::new(&copy).holds(&fingerprint));
        // Another sphere, 1% larger: the same shape, not the same surface.
        let larger = icosphere(1.01, 4);
        assert_eq!(SurfaceLookup::new(&larger).matches(&fingerprint), 0);
        assert!(!SurfaceLookup::new(&larger).holds(&fingerprint));
    }

    #[test]
    fn points_inside_triangles_are_on_the_surface() {
        let sphere = icosphere(1.0, 3);
        // A gaze-point file with points on faces: the triangles' centroids.
        let centroids: Vec<DVec3> = sphere
            .triangles
            .iter()
            .map(|t| {
                t.iter()
                    .map(|&i| sphere.positions[i as usize])
                    .sum::<DVec3>()
                    / 3.0
            })
            .collect();
        let fingerprint = fingerprint_of(&centroids);
        let lookup = SurfaceLookup::new(&sphere);
        assert_eq!(lookup.matches(&fingerprint), FINGERPRINT_POINTS);
        // Pushed off the faces by a thousandth of the radius: not on the surface.
        let off: Vec<[f64; 3]> = fingerprint
            .iter()
            .map(|p| (DVec3::from_array(*p) * 1.001).to_array())
            .collect();
        assert_eq!(lookup.matches(&off), 0);
    }

    #[test]
    fn an_empty_fingerprint_or_mesh_never_matches() {
        let sphere = icosphere(1.0, 1);
        assert!(!SurfaceLookup::new(&sphere).holds(&[]));
        let empty = Mesh {
            positions: Vec::new(),
            triangles: Vec::new(),
        };
        assert!(!SurfaceLookup::new(&empty).holds(&fingerprint_of(&sphere.positions)));
        // Fewer points than a fingerprint keeps: too few to tell objects apart.
        let few = fingerprint_of(&sphere.positions[..3]);
        assert!(!SurfaceLookup::new(&sphere).holds(&few));
    }
}

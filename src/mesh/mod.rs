//! Triangle meshes: the in-memory form every stage shares, plus readers and writers.
//!
//! Readers keep the input vertex order and count exactly, because every per-vertex output
//! (saliency, ground truth) is indexed by the input file's vertex numbering.

pub mod clustered_gaussian_average;
pub(crate) mod edge_graph;
mod error;
pub mod geometry;
pub mod mean_curvature;
pub(crate) mod nearest_vertex_transfer;
mod obj;
mod off;
pub(crate) mod over_segmentation;
mod ply;
mod read;
pub mod sampling;
pub mod simplification;
mod subdivide;
pub mod test_meshes;
pub(crate) mod vertex_areas;
mod write_obj;
mod write_ply;

pub use error::MeshError;
pub use nearest_vertex_transfer::transfer_by_nearest_vertex;
pub use read::{load_mesh, parse_mesh_bytes, MeshFormat};
pub use subdivide::subdivide_midpoint;
pub use write_obj::write_obj;
pub use write_ply::{write_ply_with_quality, ColorRamp, ColorScale};

use glam::DVec3;
use serde::Serialize;

/// A triangle mesh with positions in input order. Faces that could not form a proper triangle
/// were removed while loading and are counted in [`LoadReport`].
#[derive(Debug, Clone, PartialEq)]
pub struct Mesh {
    /// Vertex positions, in the file's order (per-vertex maps and truth files follow it).
    pub positions: Vec<DVec3>,
    /// Triangles as three indices into `positions`, with the file's winding.
    pub triangles: Vec<[u32; 3]>,
}

/// What a reader found and what it had to leave out; copied into every output's provenance.
#[derive(Debug, Clone, Default, Serialize, PartialEq, Eq)]
pub struct LoadReport {
    /// The format read (`obj`, `off`, `ply-ascii`, `ply-binary_little_endian`, ...).
    pub format: String,
    /// Vertices in the file (all kept).
    pub vertices: usize,
    /// Faces (polygons or strip triangles) as stored in the file.
    pub faces_in_file: usize,
    /// Triangles kept.
    pub triangles: usize,
    /// Polygons with more than three corners, split into a triangle fan.
    pub polygons_triangulated: usize,
    /// Faces skipped because two corners share a vertex index (includes strip joins).
    pub faces_with_repeated_vertex: usize,
    /// Faces skipped because their corners are collinear (zero area).
    pub zero_area_faces: usize,
    /// Vertices no kept triangle uses. They stay in the output, valued by position alone.
    pub unreferenced_vertices: usize,
}

impl Mesh {
    /// Drops faces with repeated corners or zero area and counts them, counts unreferenced
    /// vertices. Used by every reader after parsing so the rules are the same for all formats.
    pub(crate) fn from_raw_faces(
        positions: Vec<DVec3>,
        faces: Vec<[u32; 3]>,
        report: &mut LoadReport,
    ) -> Mesh {
        let mut triangles = Vec::with_capacity(faces.len());
        for f in faces {
            if f[0] == f[1] || f[1] == f[2] || f[0] == f[2] {
                report.faces_with_repeated_vertex += 1;
                continue;
            }
            let [a, b, c] = f.map(|i| positions[i as usize]);
            if (b - a).cross(c - a).length_squared() == 0.0 {
                report.zero_area_faces += 1;
                continue;
            }
            triangles.push(f);
        }
        let mut used = vec![false; positions.len()];
        for t in &triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        report.vertices = positions.len();
        report.triangles = triangles.len();
        report.unreferenced_vertices = used.iter().filter(|u| !**u).count();
        Mesh {
            positions,
            triangles,
        }
    }

    /// The corner positions of triangle `t`.
    pub fn triangle(&self, t: usize) -> [DVec3; 3] {
        self.triangles[t].map(|i| self.positions[i as usize])
    }

    /// The area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f64 {
        let [a, b, c] = self.triangle(t);
        0.5 * (b - a).cross(c - a).length()
    }

    /// The total area of the surface.
    pub fn surface_area(&self) -> f64 {
        (0..self.triangles.len())
            .map(|t| self.triangle_area(t))
            .sum()
    }

    /// Axis-aligned bounds of the vertices used by triangles (stray vertices are ignored so a
    /// single unreferenced outlier cannot change the normalization).
    pub fn referenced_bounds(&self) -> Option<(DVec3, DVec3)> {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for t in &self.triangles {
            for &i in t {
                let p = self.positions[i as usize];
                lo = lo.min(p);
                hi = hi.max(p);
            }
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }

    /// Mean length of the triangle edges (each interior edge counted once per face).
    pub fn mean_edge_length(&self) -> f64 {
        if self.triangles.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        for t in 0..self.triangles.len() {
            let [a, b, c] = self.triangle(t);
            sum += (b - a).length() + (c - b).length() + (a - c).length();
        }
        sum / (3.0 * self.triangles.len() as f64)
    }

    /// Area-weighted vertex normals (zero for unreferenced vertices).
    pub fn vertex_normals(&self) -> Vec<DVec3> {
        let mut n = vec![DVec3::ZERO; self.positions.len()];
        for t in 0..self.triangles.len() {
            let [a, b, c] = self.triangle(t);
            let fnormal = (b - a).cross(c - a); // length = 2 * area: area weighting for free
            for &i in &self.triangles[t] {
                n[i as usize] += fnormal;
            }
        }
        n.iter().map(|v| v.normalize_or_zero()).collect()
    }
}

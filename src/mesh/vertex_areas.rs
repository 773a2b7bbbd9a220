//! The area each vertex stands for, so a map summed or blurred over a mesh weighs the surface,
//! not the tessellation: dense regions do not count more than sparse ones.
use super::Mesh;

/// Vertex areas: one third of the area of each incident triangle (0 for a vertex no triangle
/// uses).
pub fn vertex_areas(mesh: &Mesh) -> Vec<f64> {
    let mut a = vec![0.0; mesh.positions.len()];
    for t in 0..mesh.triangles.len() {
        let third = mesh.triangle_area(t) / 3.0;
        for &i in &mesh.triangles[t] {
            a[i as usize] += third;
        }
    }
    a
}

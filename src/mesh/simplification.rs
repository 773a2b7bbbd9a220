//! Mesh simplification by quadric edge collapse (meshoptimizer's simplifier, through the
//! `meshopt` crate). Collapses keep surviving vertices at their input positions, so each
//! vertex of the result is one of the input's.
use crate::mesh::Mesh;

/// A copy of `mesh` with about `target_vertices` vertices (never more than the input), and for
/// each of its vertices the index of the input vertex it is.
pub fn simplify_to_vertex_count(mesh: &Mesh, target_vertices: usize) -> (Mesh, Vec<usize>) {
    let positions: Vec<f32> = mesh
        .positions
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .collect();
    let bytes: &[u8] = bytemuck_f32(&positions);
    let adapter = meshopt::VertexDataAdapter::new(bytes, 12, 0).expect("12-byte positions");
    let indices: Vec<u32> = mesh.triangles.iter().flatten().copied().collect();
    // A closed mesh has about twice as many triangles as vertices.
    let target_indices = (target_vertices * 2 * 3).min(indices.len());
    let simplified = meshopt::simplify(
        &indices,
        &adapter,
        target_indices,
        1.0,
        meshopt::SimplifyOptions::None,
        None,
    );
    let mut new_index = vec![u32::MAX; mesh.positions.len()];
    let mut kept = Vec::new();
    let mut triangles = Vec::with_capacity(simplified.len() / 3);
    for tri in simplified.chunks_exact(3) {
        let t = [tri[0], tri[1], tri[2]].map(|i| {
            let i = i as usize;
            if new_index[i] == u32::MAX {
                new_index[i] = kept.len() as u32;
                kept.push(i);
            }
            new_index[i]
        });
        triangles.push(t);
    }
    let out = Mesh {
        positions: kept.iter().map(|&i| mesh.positions[i]).collect(),
        triangles,
    };
    (out, kept)
}

fn bytemuck_f32(v: &[f32]) -> &[u8] {
    // SAFETY: f32 has no padding and any byte pattern of it is valid to read as u8; the slice
    // covers exactly the vector's memory.
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast::<u8>(), std::mem::size_of_val(v)) }
}

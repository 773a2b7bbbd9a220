use std::collections::HashMap;

use super::Mesh;

/// One step of midpoint (1-to-4) subdivision: a new vertex at the middle of every edge, each
/// triangle split in four. The surface is unchanged; vertex count grows about fourfold. Used
/// to make large benchmark meshes from real ones.
pub fn subdivide_midpoint(mesh: &Mesh) -> Mesh {
    let mut positions = mesh.positions.clone();
    let mut midpoint: HashMap<(u32, u32), u32> =
        HashMap::with_capacity(mesh.triangles.len() * 3 / 2);
    let mut triangles = Vec::with_capacity(mesh.triangles.len() * 4);
    let mut mid = |a: u32, b: u32, positions: &mut Vec<glam::DVec3>| -> u32 {
        let key = (a.min(b), a.max(b));
        *midpoint.entry(key).or_insert_with(|| {
            positions.push((positions[a as usize] + positions[b as usize]) * 0.5);
            (positions.len() - 1) as u32
        })
    };
    for &[a, b, c] in &mesh.triangles {
        let ab = mid(a, b, &mut positions);
        let bc = mid(b, c, &mut positions);
        let ca = mid(c, a, &mut positions);
        triangles.extend_from_slice(&[[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
    }
    Mesh {
        positions,
        triangles,
    }
}

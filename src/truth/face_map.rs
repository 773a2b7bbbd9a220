//! Per-face truth maps (one value per triangle, as many published 3D gaze datasets give them)
//! carried to vertices: each vertex takes the area-weighted mean of its incident faces, so a
//! finely tessellated region does not outvote a coarse one around the same vertex.
use std::path::Path;

use super::text_table::read_text;
use super::{load_ground_truth, vertex_truth_from_values, GroundTruth, TruthError};
use crate::mesh::Mesh;

/// Whether a truth map gives one value per vertex or per face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum TruthLayout {
    /// Per face when the map has exactly as many rows as the mesh has triangles (and the
    /// mesh has a different number of vertices), else per vertex.
    #[default]
    Auto,
    /// One value per vertex.
    Vertex,
    /// One value per face, in file order.
    Face,
}

/// The area-weighted mean of the values of each vertex's incident faces; a vertex no face
/// uses gets 0 (it is never drawn and cannot be fixated).
pub fn face_values_to_vertices(mesh: &Mesh, face_values: &[f64]) -> Vec<f64> {
    let n = mesh.positions.len();
    let mut sum = vec![0.0; n];
    let mut weight = vec![0.0; n];
    for (t, &value) in mesh.triangles.iter().zip(face_values) {
        let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
        let area = 0.5 * (b - a).cross(c - a).length();
        for &v in t {
            sum[v as usize] += area * value;
            weight[v as usize] += area;
        }
    }
    sum.iter()
        .zip(&weight)
        .map(|(s, w)| if *w > 0.0 { s / w } else { 0.0 })
        .collect()
}

/// Data rows of a per-vertex or per-face map file (None for a fixation set).
fn map_rows(path: &Path) -> Result<Option<usize>, TruthError> {
    let text = read_text(path)?;
    let mut lines = text.lines().filter(|l| !l.trim().is_empty());
    let Some(first) = lines.next() else {
        return Ok(Some(0));
    };
    let lower = first.to_ascii_lowercase();
    let is_header = first
        .split([',', '\t', ';', ' '])
        .filter(|f| !f.trim().is_empty())
        .any(|f| f.trim().parse::<f64>().is_err());
    if is_header && lower.contains("subject") {
        return Ok(None);
    }
    Ok(Some(lines.count() + usize::from(!is_header)))
}

/// [`load_ground_truth`] for `mesh`, reading a per-face map as such (by `layout`, or by its
/// row count) and carrying it to vertices; the positives of a per-face map are then the top
/// `top_fraction` of vertices by the carried value.
pub fn load_ground_truth_on(
    path: &Path,
    mesh: &Mesh,
    top_fraction: f64,
    layout: TruthLayout,
) -> Result<GroundTruth, TruthError> {
    let (nv, nf) = (mesh.positions.len(), mesh.triangles.len());
    let per_face = match layout {
        TruthLayout::Vertex => false,
        TruthLayout::Face => true,
        TruthLayout::Auto => nv != nf && map_rows(path)? == Some(nf),
    };
    if !per_face {
        return load_ground_truth(path, nv, top_fraction);
    }
    let file_error = |message: String| TruthError::File {
        path: path.to_path_buf(),
        message,
    };
    match load_ground_truth(path, nf, top_fraction)? {
        GroundTruth::Fixations(_) => Err(file_error(
            "a fixation set names vertices; only maps can be per face".into(),
        )),
        GroundTruth::VertexMap(m) if m.positive_rule.starts_with("flag") => Err(file_error(
            "a per-face map with a 0/1 flag column: the flags cannot be carried to vertices; give the values alone".into(),
        )),
        GroundTruth::VertexMap(m) => {
            let values = face_values_to_vertices(mesh, &m.values);
            let mut truth =
                vertex_truth_from_values(values, top_fraction).map_err(|e| file_error(e.0))?;
            truth.positive_rule = format!(
                "per-face map ({nf} faces) carried to vertices by area-weighted mean; {}",
                truth.positive_rule
            );
            Ok(GroundTruth::VertexMap(truth))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// Two triangles sharing an edge, areas 0.5 and 2.
    fn two_triangles() -> Mesh {
        Mesh {
            positions: vec![
                DVec3::new(0.0, 0.0, 0.0),
                DVec3::new(1.0, 0.0, 0.0),
                DVec3::new(0.0, 1.0, 0.0),
                DVec3::new(2.0, 2.0, 0.0),
                DVec3::new(5.0, 5.0, 5.0),
            ],
            triangles: vec![[0, 1, 2], [1, 3, 2]],
        }
    }

    #[test]
    fn vertices_take_the_area_weighted_mean_of_their_faces() {
        let mesh = two_triangles();
        let a1 = 0.5;
        let a2 = 0.5 * (DVec3::new(1.0, 2.0, 0.0).cross(DVec3::new(-1.0, 1.0, 0.0))).length();
        let v = face_values_to_vertices(&mesh, &[1.0, 4.0]);
        assert_eq!(v[0], 1.0);
        assert_eq!(v[3], 4.0);
        let shared = (a1 * 1.0 + a2 * 4.0) / (a1 + a2);
        assert!((v[1] - shared).abs() < 1e-12 && (v[2] - shared).abs() < 1e-12);
        assert_eq!(v[4], 0.0, "an unused vertex");
    }

    #[test]
    fn a_map_with_one_row_per_face_is_read_per_face() {
        let mesh = two_triangles();
        let dir = std::env::temp_dir().join(format!("meshgaze-face-map-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let faces = dir.join("faces.csv");
        std::fs::write(&faces, "face,value\n0,1\n1,4\n").unwrap();
        let GroundTruth::VertexMap(m) =
            load_ground_truth_on(&faces, &mesh, 0.2, TruthLayout::Auto).unwrap()
        else {
            panic!("a map")
        };
        assert_eq!(m.values, face_values_to_vertices(&mesh, &[1.0, 4.0]));
        assert!(m.positive_rule.starts_with("per-face map (2 faces)"));
        assert_eq!(m.positive, vec![false, false, false, true, false]);
        // The same numbers as a per-vertex file of 5 rows stay per vertex.
        let vertices = dir.join("vertices.csv");
        std::fs::write(&vertices, "0\n1\n2\n3\n4\n").unwrap();
        let GroundTruth::VertexMap(m) =
            load_ground_truth_on(&vertices, &mesh, 0.2, TruthLayout::Auto).unwrap()
        else {
            panic!("a map")
        };
        assert_eq!(m.values, vec![0.0, 1.0, 2.0, 3.0, 4.0]);
        // Named per face, a 5-row file is too long; flags cannot be carried.
        let e = load_ground_truth_on(&vertices, &mesh, 0.2, TruthLayout::Face).unwrap_err();
        assert!(e.to_string().contains("more rows"), "{e}");
        let flagged = dir.join("flagged.csv");
        std::fs::write(&flagged, "1,0\n4,1\n").unwrap();
        let e = load_ground_truth_on(&flagged, &mesh, 0.2, TruthLayout::Face).unwrap_err();
        assert!(e.to_string().contains("flag"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}

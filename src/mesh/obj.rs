//! Wavefront OBJ: `v` positions and `f` polygons. Written by hand rather than with tobj so that
//! every error names its line and column and vertices keep the file's numbering: tobj numbers
//! them by first use in each object (20,879 of car.obj's 20,890 vertices in the VR data), which
//! would misalign every per-vertex truth file. tests/mesh_io.rs checks that both readers give
//! the same triangles, face for face, on every real OBJ in ../shared/data.
use std::path::Path;

use glam::DVec3;

use super::read::{parse_f64, push_polygon, Tokens};
use super::{LoadReport, MeshError};

pub(crate) fn parse(
    bytes: &[u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), MeshError> {
    let mut positions: Vec<DVec3> = Vec::new();
    let mut faces = Vec::new();
    let mut corners: Vec<u32> = Vec::with_capacity(8);
    let mut tokens = Tokens::new(bytes, Some(b'#'));
    while !tokens.at_end() {
        let Some(keyword) = tokens.next_on_line() else {
            tokens.next_line();
            continue;
        };
        match keyword.text {
            b"v" => {
                let mut xyz = [0.0; 3];
                for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                    let tok = tokens.next_on_line().ok_or_else(|| {
                        MeshError::text(
                            path,
                            tokens.line(),
                            tokens.column(),
                            format!("vertex {} has no {axis} coordinate", positions.len() + 1),
                        )
                    })?;
                    xyz[k] = parse_f64(
                        &tok,
                        path,
                        &format!("the {axis} coordinate of vertex {}", positions.len() + 1),
                    )?;
                }
                positions.push(DVec3::from_array(xyz));
            }
            b"f" => {
                corners.clear();
                while let Some(tok) = tokens.next_on_line() {
                    // `i`, `i/t`, `i//n` or `i/t/n`: only the position index matters here.
                    let first = tok.text.split(|&b| b == b'/').next().unwrap_or(b"");
                    let idx: i64 = std::str::from_utf8(first)
                        .ok()
                        .and_then(|s| s.parse().ok())
                        .ok_or_else(|| {
                            MeshError::text(
                                path,
                                tok.line,
                                tok.column,
                                format!("expected a vertex index, found `{}`", tok.as_str()),
                            )
                        })?;
                    let n = positions.len() as i64;
                    let resolved = if idx > 0 { idx - 1 } else { n + idx };
                    if idx == 0 || resolved < 0 || resolved >= n {
                        return Err(MeshError::text(
                            path,
                            tok.line,
                            tok.column,
                            format!(
                                "vertex index `{}` is out of range: {n} vertices are defined before this line (OBJ indices start at 1; negative ones count back)",
                                tok.as_str()
                            ),
                        ));
                    }
                    corners.push(resolved as u32);
                }
                if corners.len() < 3 {
                    return Err(MeshError::text(
                        path,
                        keyword.line,
                        keyword.column,
                        format!(
                            "a face needs at least 3 vertices, this one has {}",
                            corners.len()
                        ),
                    ));
                }
                push_polygon(&corners, &mut faces, report);
            }
            // Normals, texture coordinates, groups, materials, lines, points: not geometry
            // that saliency uses.
            _ => {}
        }
        tokens.next_line();
    }
    Ok((positions, faces))
}

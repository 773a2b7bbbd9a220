//! OFF (Object File Format): `OFF`, then `#vertices #faces #edges` (the edge count is read and
//! ignored: SHREC'07 files store the real count there, others 0), vertices, then faces as
//! `n i0 .. i(n-1) [colour]`. `COFF`/`NOFF`-style variants carry extra per-vertex values that
//! are skipped.
use std::path::Path;

use glam::DVec3;

use super::read::{check_index, parse_f64, parse_i64, push_polygon, Tokens};
use super::{LoadReport, MeshError};

pub(crate) fn parse(
    bytes: &[u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), MeshError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut tokens = Tokens::new(bytes, Some(b'#'));
    let magic = tokens
        .next_any()
        .ok_or_else(|| MeshError::text(path, 1, 1, "empty file: expected `OFF`"))?;
    let tag = magic.as_str();
    if !tag.ends_with("OFF") {
        return Err(MeshError::text(
            path,
            magic.line,
            magic.column,
            format!("expected the `OFF` keyword, found `{tag}`"),
        ));
    }
    if tag.contains('4') || tag.starts_with('n') {
        return Err(MeshError::text(
            path,
            magic.line,
            magic.column,
            format!("`{tag}` (4D or n-dimensional OFF) is not supported"),
        ));
    }
    let mut count = |what: &str| -> Result<usize, MeshError> {
        let tok = tokens.next_any().ok_or_else(|| {
            MeshError::text(
                path,
                magic.line,
                magic.column,
                format!("the header has no {what}"),
            )
        })?;
        let v = parse_i64(&tok, path, what)?;
        usize::try_from(v).map_err(|_| {
            MeshError::text(
                path,
                tok.line,
                tok.column,
                format!("{what} is negative ({v})"),
            )
        })
    };
    let nv = count("vertex count")?;
    let nf = count("face count")?;
    let _edges = count("edge count")?;
    let mut positions = Vec::with_capacity(nv.min(1 << 24));
    for i in 0..nv {
        let mut xyz = [0.0; 3];
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            let tok = tokens.next_any().ok_or_else(|| {
                MeshError::text(
                    path,
                    tokens.line(),
                    tokens.column(),
                    format!(
                        "the file ends at vertex {} of {nv} (header promised {nv})",
                        i + 1
                    ),
                )
            })?;
            xyz[k] = parse_f64(
                &tok,
                path,
                &format!("the {axis} coordinate of vertex {}", i + 1),
            )?;
        }
        positions.push(DVec3::from_array(xyz));
        // Variants (COFF, NOFF, STOFF) put colours, normals or texture coordinates after the
        // position on the vertex's own line; they are not geometry.
        tokens.next_line();
    }
    let mut faces = Vec::with_capacity(nf.min(1 << 25));
    let mut corners = Vec::with_capacity(8);
    for i in 0..nf {
        let tok = tokens.next_any().ok_or_else(|| {
            MeshError::text(
                path,
                tokens.line(),
                tokens.column(),
                format!(
                    "the file ends at face {} of {nf} (header promised {nf})",
                    i + 1
                ),
            )
        })?;
        let n = parse_i64(&tok, path, &format!("the corner count of face {}", i + 1))?;
        if !(3..=1_000_000).contains(&n) {
            return Err(MeshError::text(
                path,
                tok.line,
                tok.column,
                format!("face {} has {n} corners; a face needs at least 3", i + 1),
            ));
        }
        corners.clear();
        for _ in 0..n {
            let t = tokens.next_on_line().ok_or_else(|| {
                MeshError::text(
                    path,
                    tokens.line(),
                    tokens.column(),
                    format!("face {} lists fewer than its {n} corners", i + 1),
                )
            })?;
            let idx = parse_i64(&t, path, "a vertex index")?;
            corners.push(check_index(idx, nv, &t, path)?);
        }
        // A face line may end with a colour; it is not geometry.
        tokens.next_line();
        push_polygon(&corners, &mut faces, report);
    }
    Ok((positions, faces))
}

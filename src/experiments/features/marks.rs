//! Human-marked interest points: one file per subject, one vertex index per line (the first
//! field of the line; comma, space, tab or semicolon separated), `#` comments and an optional
//! `vertex` header.

use crate::experiments::ExperimentError;
/// The marked vertices of one subject; errors name the line and column.
pub fn parse_marks(
    text: &str,
    name: &str,
    n_vertices: usize,
) -> Result<Vec<usize>, ExperimentError> {
    let mut out = Vec::new();
    let mut header_allowed = true;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start_matches('\u{feff}').trim();
        if t.is_empty() || t.starts_with('#') {
            continue;
        }
        let field = t.split([',', ' ', '\t', ';']).next().unwrap_or("");
        if header_allowed && field.eq_ignore_ascii_case("vertex") {
            header_allowed = false;
            continue;
        }
        header_allowed = false;
        let col = line
            .find(field)
            .map_or(1, |c| line[..c].chars().count() + 1);
        let at = |message: String| ExperimentError::At {
            name: name.to_string(),
            line: i + 1,
            column: col,
            message,
        };
        let v: usize = field
            .parse()
            .map_err(|_| at(format!("expected a vertex index, found `{field}`")))?;
        if v >= n_vertices {
            return Err(at(format!(
                "vertex {v} is out of range: the mesh has {n_vertices} vertices"
            )));
        }
        out.push(v);
    }
    Ok(out)
}

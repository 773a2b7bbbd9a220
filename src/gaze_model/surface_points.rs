//! Oriented points on a surface: what every gaze-model feature is computed from, so a mesh's
//! vertices and a point cloud (the upstream gaze files of objects with no mesh) give features
//! of the same kind.
use std::path::Path;

use glam::DVec3;

use crate::file_bytes::read_maybe_gzipped;
use crate::mesh::Mesh;

/// Points with unit normals (zero where a normal is unknown).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfacePoints {
    /// Positions.
    pub positions: Vec<DVec3>,
    /// Unit normals, one per position (zero where unknown).
    pub normals: Vec<DVec3>,
}

impl SurfacePoints {
    /// A mesh's vertices with area-weighted normals, in input order.
    pub fn of_mesh(mesh: &Mesh) -> SurfacePoints {
        SurfacePoints {
            positions: mesh.positions.clone(),
            normals: mesh.vertex_normals(),
        }
    }

    /// How many points.
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    /// Whether there is no point.
    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }
}

/// A gaze-point file: one line per point, `x y z nx ny nz` and optionally the aggregated
/// fixation `time` and the top-5% `flag` (the layout of the VR experiment's upstream files).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GazePoints {
    /// The points and their normals.
    pub points: SurfacePoints,
    /// Per point, when the file has a 7th column.
    pub time: Option<Vec<f64>>,
    /// Per point, when the file has an 8th column (1 = among the most looked-at).
    pub flag: Option<Vec<bool>>,
}

/// Why a point file cannot be used, with its place.
#[derive(Debug, Clone, PartialEq)]
pub struct PointsError {
    /// The file.
    pub path: String,
    /// 1-based line.
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// What is wrong there.
    pub message: String,
}

impl std::fmt::Display for PointsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}: {}", self.path, self.message)
        } else {
            write!(
                f,
                "{}:{}:{}: {}",
                self.path, self.line, self.column, self.message
            )
        }
    }
}

impl std::error::Error for PointsError {}

/// Reads a gaze-point file (gzip or not, detected by content).
pub fn read_gaze_points(path: &Path) -> Result<GazePoints, PointsError> {
    let bytes = read_maybe_gzipped(path).map_err(|e| PointsError {
        path: path.display().to_string(),
        line: 0,
        column: 0,
        message: e.to_string(),
    })?;
    parse_gaze_points(&bytes, &path.display().to_string())
}

/// Parses the text of a gaze-point file; `name` is used in errors. Blank lines and `#`
/// comments are skipped; every other line must have the same number of columns (6, 7 or 8),
/// all finite numbers, and the flag column only 0 or 1.
pub fn parse_gaze_points(bytes: &[u8], name: &str) -> Result<GazePoints, PointsError> {
    let fail = |line: usize, column: usize, message: String| PointsError {
        path: name.to_string(),
        line,
        column,
        message,
    };
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count()
            + 1;
        fail(line, 1, "not UTF-8 text".to_string())
    })?;
    let mut columns = None;
    let mut out = GazePoints::default();
    let mut time = Vec::new();
    let mut flag = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let no = i + 1;
        let content = line.trim();
        if content.is_empty() || content.starts_with('#') {
            continue;
        }
        let mut values = [0.0f64; 8];
        let mut count = 0;
        for (start, field) in fields_with_columns(line) {
            if count == 8 {
                return Err(fail(
                    no,
                    start,
                    "more than 8 columns (expected `x y z nx ny nz [time [flag]]`)".into(),
                ));
            }
            let v: f64 = field
                .parse()
                .map_err(|_| fail(no, start, format!("`{field}` is not a number")))?;
            if !v.is_finite() {
                return Err(fail(no, start, format!("`{field}` is not a finite number")));
            }
            if count == 7 && v != 0.0 && v != 1.0 {
                return Err(fail(
                    no,
                    start,
                    format!("the flag column must be 0 or 1, found `{field}`"),
                ));
            }
            values[count] = v;
            count += 1;
        }
        match columns {
            None if count < 6 => {
                return Err(fail(
                    no,
                    1,
                    format!("{count} columns; a point needs at least `x y z nx ny nz`"),
                ))
            }
            None => columns = Some(count),
            Some(c) if c != count => {
                return Err(fail(
                    no,
                    1,
                    format!("{count} columns where the first point line had {c}"),
                ))
            }
            Some(_) => {}
        }
        out.points
            .positions
            .push(DVec3::new(values[0], values[1], values[2]));
        out.points
            .normals
            .push(DVec3::new(values[3], values[4], values[5]).normalize_or_zero());
        if count >= 7 {
            time.push(values[6]);
        }
        if count == 8 {
            flag.push(values[7] == 1.0);
        }
    }
    let Some(columns) = columns else {
        return Err(fail(0, 0, "no points in the file".into()));
    };
    if columns >= 7 {
        out.time = Some(time);
    }
    if columns == 8 {
        out.flag = Some(flag);
    }
    Ok(out)
}

/// Whitespace-separated fields with their 1-based character columns.
fn fields_with_columns(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut rest = line;
    let mut offset = 0;
    std::iter::from_fn(move || {
        let skipped = rest.len() - rest.trim_start().len();
        rest = &rest[skipped..];
        offset += skipped;
        if rest.is_empty() {
            return None;
        }
        let end = rest.find(char::is_whitespace).unwrap_or(rest.len());
        let field = &rest[..end];
        let column = line[..offset].chars().count() + 1;
        rest = &rest[end..];
        offset += end;
        Some((column, field))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_upstream_layout_and_locates_errors() {
        let ok = parse_gaze_points(b"0 0 0 0 0 2 0.5 1\n1 0 0 0 3 0 0 0\n", "p").unwrap();
        assert_eq!(ok.points.len(), 2);
        assert_eq!(ok.points.normals[0], DVec3::Z);
        assert_eq!(ok.flag, Some(vec![true, false]));
        let e = parse_gaze_points(b"0 0 0 0 0 1\n0 0 x 0 0 1\n", "p").unwrap_err();
        assert_eq!((e.line, e.column), (2, 5), "{e}");
        let e = parse_gaze_points(b"0 0 0 0 0 1 0 1\n0 0 0 0 0 1 0 2\n", "p").unwrap_err();
        assert_eq!((e.line, e.column), (2, 15), "{e}");
        let e = parse_gaze_points(b"0 0 0 0 0 1\n0 0 0 0 0 1 3\n", "p").unwrap_err();
        assert_eq!(e.line, 2, "{e}");
        assert!(parse_gaze_points(b"# nothing\n", "p").is_err());
    }
}

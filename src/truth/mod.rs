//! Human ground truth for scoring, in the formats documented in docs/ground-truth-format.md:
//! a per-vertex map (one value per vertex, optionally with a 0/1 "fixated" flag, as in the
//! `time bin` files of the VR dataset), or a fixation set (CSV with `subject` and `vertex`
//! columns, one row per fixation, as `meshgaze truth` writes).
pub mod build;
mod density_file;
mod face_map;

pub use density_file::read_density;
pub use face_map::{face_values_to_vertices, load_ground_truth_on, TruthLayout};

pub use build::{
    build_truth, projected_file, read_projections, write_truth, Projections, TruthBuildError,
    TruthParams, TruthResult,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::file_bytes::{read_maybe_gzipped, ReadError};
pub use crate::scoring::ground_truth::{Fixation, FixationTruth, GroundTruth, VertexTruth};

#[derive(Debug, thiserror::Error)]
pub enum TruthError {
    #[error("{path}: {error}")]
    Io {
        path: PathBuf,
        error: std::io::Error,
    },
    #[error("{path}:{line}:{column}: {message}")]
    At {
        path: PathBuf,
        line: usize,
        column: usize,
        message: String,
    },
    #[error("{path}: {message}")]
    File { path: PathBuf, message: String },
}

fn read_text(path: &Path) -> Result<String, TruthError> {
    let bytes = read_maybe_gzipped(path).map_err(|e| match e {
        ReadError::Io(source) => TruthError::Io {
            path: path.to_path_buf(),
            error: source,
        },
        ReadError::CorruptGzip(e) => TruthError::File {
            path: path.to_path_buf(),
            message: format!("gzip data is corrupt: {e}"),
        },
    })?;
    let text = String::from_utf8(bytes).map_err(|e| TruthError::File {
        path: path.to_path_buf(),
        message: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
    })?;
    Ok(text.strip_prefix('\u{feff}').unwrap_or(&text).to_string())
}

/// The file's field separator, from its first line: a comma, tab or semicolon splits strictly
/// (empty fields stay in place, so an empty `vertex` of a background fixation does not shift
/// the columns); otherwise runs of spaces separate.
fn sniff_separator(first_line: &str) -> Option<char> {
    [',', '\t', ';']
        .into_iter()
        .find(|&c| first_line.contains(c))
}

fn fields(line: &str, sep: Option<char>) -> Vec<(usize, &str)> {
    // Columns are 1-based character offsets.
    let mut out = Vec::new();
    match sep {
        Some(sep) => {
            let mut start = 0;
            for (i, c) in line.char_indices() {
                if c == sep {
                    out.push((start + 1, line[start..i].trim()));
                    start = i + c.len_utf8();
                }
            }
            out.push((start + 1, line[start..].trim()));
        }
        None => {
            let mut start = None;
            for (i, c) in line.char_indices() {
                match (c.is_whitespace(), start) {
                    (true, Some(s)) => {
                        out.push((s + 1, &line[s..i]));
                        start = None;
                    }
                    (false, None) => start = Some(i),
                    _ => {}
                }
            }
            if let Some(s) = start {
                out.push((s + 1, line[s..].trim_end()));
            }
        }
    }
    out
}

/// Reads ground truth for a mesh with `n_vertices` vertices. For a map without a flag column,
/// the top `top_fraction` of vertices by value are the positives.
pub fn load_ground_truth(
    path: &Path,
    n_vertices: usize,
    top_fraction: f64,
) -> Result<GroundTruth, TruthError> {
    let text = read_text(path)?;
    let lines: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .collect();
    let Some(&(first_no, first)) = lines.first() else {
        return Err(TruthError::File {
            path: path.to_path_buf(),
            message: "the file is empty".into(),
        });
    };
    let sep = sniff_separator(first);
    let header: Vec<String> = fields(first, sep)
        .iter()
        .map(|(_, f)| f.trim().to_ascii_lowercase())
        .collect();
    let is_header = header.iter().any(|h| h.parse::<f64>().is_err());
    let table = Table {
        path,
        sep,
        header_line: first_no,
        header: is_header.then_some(header.as_slice()),
    };
    if is_header && header.iter().any(|h| h == "subject") {
        return read_fixation_rows(&table, &lines[1..], n_vertices).map(GroundTruth::Fixations);
    }
    let body = if is_header { &lines[1..] } else { &lines[..] };
    let width = header.len();
    read_vertex_map(&table, body, width, n_vertices, top_fraction).map(GroundTruth::VertexMap)
}

/// A delimited text file being read: its path (for messages), separator and header.
struct Table<'a> {
    path: &'a Path,
    sep: Option<char>,
    /// 0-based line of the first non-empty line.
    header_line: usize,
    /// Lower-cased header names, when the first line is a header.
    header: Option<&'a [String]>,
}

impl Table<'_> {
    fn at(&self, line: usize, column: usize, message: String) -> TruthError {
        TruthError::At {
            path: self.path.to_path_buf(),
            line,
            column,
            message,
        }
    }

    fn col(&self, name: &str) -> Option<usize> {
        self.header?.iter().position(|h| h == name)
    }
}

/// A fixation set: `subject,vertex[,...,fate]`; rows whose fate is not hit or snapped are
/// counted by fate, not read.
fn read_fixation_rows(
    t: &Table,
    lines: &[(usize, &str)],
    n_vertices: usize,
) -> Result<FixationTruth, TruthError> {
    let subject_col = t.col("subject").expect("checked by the caller");
    let vertex_col = t.col("vertex").ok_or_else(|| {
        t.at(
            t.header_line + 1,
            1,
            "a fixation file needs a `vertex` column beside `subject`".into(),
        )
    })?;
    let fate_col = t.col("fate");
    let mut fixations = Vec::new();
    let mut subjects: Vec<String> = Vec::new();
    let mut not_on_mesh = BTreeMap::new();
    let mut rows = 0;
    for &(no, line) in lines {
        rows += 1;
        let f = fields(line, t.sep);
        let get = |c: usize, name: &str| {
            f.get(c).copied().ok_or_else(|| {
                t.at(
                    no + 1,
                    line.len() + 1,
                    format!("the row has no `{name}` value (column {})", c + 1),
                )
            })
        };
        if let Some(fc) = fate_col {
            let fate = get(fc, "fate")?.1.trim();
            if fate != "hit" && fate != "snapped" {
                *not_on_mesh.entry(fate.to_string()).or_insert(0) += 1;
                continue;
            }
        }
        let subject = get(subject_col, "subject")?.1.trim().to_string();
        let (vc, vtext) = get(vertex_col, "vertex")?;
        let vertex: usize = vtext.trim().parse().map_err(|_| {
            t.at(
                no + 1,
                vc,
                format!("expected a vertex index, found `{vtext}`"),
            )
        })?;
        if vertex >= n_vertices {
            return Err(t.at(
                no + 1,
                vc,
                format!("vertex {vertex} is out of range: the mesh has {n_vertices} vertices"),
            ));
        }
        if !subjects.contains(&subject) {
            subjects.push(subject.clone());
        }
        fixations.push(Fixation { subject, vertex });
    }
    Ok(FixationTruth {
        fixations,
        subjects,
        rows,
        rows_not_on_mesh: not_on_mesh,
    })
}

/// A per-vertex map. With a header, `vertex,<value>[,<flag>]` (meshgaze's own CSV) is read by
/// name; without, one row per vertex: `value` or `value flag` (`width` fields in the first).
fn read_vertex_map(
    t: &Table,
    body: &[(usize, &str)],
    width: usize,
    n_vertices: usize,
    top_fraction: f64,
) -> Result<VertexTruth, TruthError> {
    let value_col;
    let mut flag_col = None;
    let mut vertex_col = None;
    if let Some(header) = t.header {
        // `face` for per-face maps (face_map.rs reads them with the face count).
        vertex_col = t.col("vertex").or_else(|| t.col("face"));
        let others: Vec<usize> = (0..header.len())
            .filter(|&i| Some(i) != vertex_col)
            .collect();
        match others.as_slice() {
            [v] => value_col = *v,
            [v, f] => {
                value_col = *v;
                flag_col = Some(*f);
            }
            _ => {
                return Err(t.at(
                    t.header_line + 1,
                    1,
                    "expected a header `vertex,value`, `vertex,value,flag`, or `subject,vertex,...` for fixations".into(),
                ))
            }
        }
    } else {
        value_col = 0;
        if width >= 2 {
            flag_col = Some(1);
        }
    }
    let mut values = vec![f64::NAN; n_vertices];
    let mut flags = flag_col.map(|_| vec![false; n_vertices]);
    for (row, &(no, line)) in body.iter().enumerate() {
        let f = fields(line, t.sep);
        let vertex = match vertex_col {
            Some(c) => {
                let (col, v) = f
                    .get(c)
                    .copied()
                    .ok_or_else(|| t.at(no + 1, 1, "missing vertex index".into()))?;
                v.parse::<usize>().map_err(|_| {
                    t.at(no + 1, col, format!("expected a vertex index, found `{v}`"))
                })?
            }
            None => row,
        };
        if vertex >= n_vertices {
            return Err(t.at(
                no + 1,
                1,
                format!(
                    "more rows than the mesh's {n_vertices} vertices (row for vertex {vertex})"
                ),
            ));
        }
        let (col, v) = f
            .get(value_col)
            .copied()
            .ok_or_else(|| t.at(no + 1, 1, "missing value".into()))?;
        let value: f64 = v
            .parse()
            .map_err(|_| t.at(no + 1, col, format!("expected a number, found `{v}`")))?;
        if !value.is_finite() {
            return Err(t.at(no + 1, col, format!("the value `{v}` is not finite")));
        }
        values[vertex] = value;
        if let (Some(fc), Some(fl)) = (flag_col, flags.as_mut()) {
            let (col, v) = f
                .get(fc)
                .copied()
                .ok_or_else(|| t.at(no + 1, line.len() + 1, "missing flag".into()))?;
            fl[vertex] = match v.parse::<f64>() {
                Ok(0.0) => false,
                Ok(1.0) => true,
                _ => return Err(t.at(no + 1, col, format!("expected a 0/1 flag, found `{v}`"))),
            };
        }
    }
    let missing = values.iter().filter(|v| v.is_nan()).count();
    if missing > 0 {
        return Err(TruthError::File {
            path: t.path.to_path_buf(),
            message: format!(
                "{missing} of the mesh's {n_vertices} vertices have no value (the file has {} rows): is it for this mesh?",
                body.len()
            ),
        });
    }
    let (positive, positive_rule) = positives_of(&values, flags, top_fraction);
    Ok(VertexTruth {
        values,
        positive,
        positive_rule,
    })
}

/// A per-vertex truth map given as values (one per vertex, in mesh order) rather than a
/// file: the top `top_fraction` of vertices by value are the positives, as for a file
/// without a flag column. Refuses values that are not finite.
pub fn vertex_truth_from_values(
    values: Vec<f64>,
    top_fraction: f64,
) -> Result<VertexTruth, String> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "truth value {} (vertex {i}) is not finite",
            values[i]
        ));
    }
    if !(top_fraction > 0.0 && top_fraction <= 1.0) {
        return Err(format!(
            "the top fraction taken as fixated must be in (0, 1], not {top_fraction}"
        ));
    }
    let (positive, positive_rule) = positives_of(&values, None, top_fraction);
    Ok(VertexTruth {
        values,
        positive,
        positive_rule,
    })
}

/// The positives of a vertex map: its flags when it has them, else the top fraction by value
/// (ties to the lower index); with the rule in words.
fn positives_of(
    values: &[f64],
    flags: Option<Vec<bool>>,
    top_fraction: f64,
) -> (Vec<bool>, String) {
    if let Some(f) = flags {
        return (f, "flag column (1 = fixated)".to_string());
    }
    let n = values.len();
    let k = ((top_fraction * n as f64).round() as usize)
        .clamp(1, n.max(1))
        .min(n);
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| values[b].total_cmp(&values[a]).then(a.cmp(&b)));
    let mut p = vec![false; n];
    for &i in &order[..k] {
        p[i] = true;
    }
    (
        p,
        format!(
            "top {:.1}% of vertices by value ({k})",
            100.0 * top_fraction
        ),
    )
}

/// The fixation set of projected rows (hit and snapped fixations; the rest counted by fate).
pub fn fixation_truth_from_rows(rows: &[crate::projection::table::ProjectedRow]) -> FixationTruth {
    let mut subjects: Vec<String> = Vec::new();
    let mut fixations = Vec::new();
    let mut rows_not_on_mesh: BTreeMap<String, usize> = BTreeMap::new();
    for r in rows {
        match (r.fate().is_some_and(|f| f.on_mesh()), r.vertex) {
            (true, Some(v)) => {
                if !subjects.contains(&r.subject) {
                    subjects.push(r.subject.clone());
                }
                fixations.push(Fixation {
                    subject: r.subject.clone(),
                    vertex: v,
                });
            }
            _ => *rows_not_on_mesh.entry(r.fate.clone()).or_insert(0) += 1,
        }
    }
    FixationTruth {
        fixations,
        subjects,
        rows: rows.len(),
        rows_not_on_mesh,
    }
}

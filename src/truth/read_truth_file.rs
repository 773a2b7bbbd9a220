//! Reading a truth file: a fixation set or a per-vertex map, told apart by its columns.
use std::collections::BTreeMap;
use std::path::Path;

use super::text_table::{fields, read_text, sniff_separator, Table};
use super::{Fixation, FixationTruth, GroundTruth, TruthError, VertexTruth};

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

/// Values that cannot be a truth map (one not finite, a top fraction outside (0, 1]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct TruthValueError(pub String);

impl From<String> for TruthValueError {
    fn from(message: String) -> Self {
        TruthValueError(message)
    }
}

/// A per-vertex truth map given as values (one per vertex, in mesh order) rather than a
/// file: the top `top_fraction` of vertices by value are the positives, as for a file
/// without a flag column. Refuses values that are not finite.
pub fn vertex_truth_from_values(
    values: Vec<f64>,
    top_fraction: f64,
) -> Result<VertexTruth, TruthValueError> {
    if let Some(i) = values.iter().position(|v| !v.is_finite()) {
        return Err(TruthValueError::from(format!(
            "truth value {} (vertex {i}) is not finite",
            values[i]
        )));
    }
    if !(top_fraction > 0.0 && top_fraction <= 1.0) {
        return Err(TruthValueError::from(format!(
            "the top fraction taken as fixated must be in (0, 1], not {top_fraction}"
        )));
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

//! `projected.csv`: one row per fixation with its fate, vertex and surface point. It is the
//! fixation-set ground-truth format (docs/ground-truth-format.md, format B) that `meshgaze
//! score` and `meshgaze truth` read.
use std::io::Write;
use std::path::Path;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{ProjectedFixation, ProjectionFate};
use crate::stimulus::camera::Phase;

/// One row of projected.csv: a fixation, where it was on screen, which camera it was
/// projected with, where it landed on the mesh and its fate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProjectedRow {
    /// The subject's id.
    pub subject: String,
    /// The fixation's index among the subject's fixations of this stimulus.
    pub fixation: usize,
    /// Start, ms after the stimulus onset.
    pub start_ms: f64,
    /// Duration, ms.
    pub duration_ms: f64,
    /// Screen position on the tracker's screen, px, horizontal.
    pub screen_x: f64,
    /// Screen position, px, vertical (down from the top).
    pub screen_y: f64,
    /// The stimulus time whose camera was used (the displayed frame's time), s.
    pub camera_time_s: Option<f64>,
    /// `hold`, `move` or `ended`: what the camera was doing then.
    pub phase: Option<String>,
    /// The hold viewpoint (0-based) during a hold.
    pub viewpoint: Option<usize>,
    /// The triangle the ray hit.
    pub triangle: Option<usize>,
    /// The nearest corner of that triangle: the fixated vertex.
    pub vertex: Option<usize>,
    /// Where the ray met the surface, mesh coordinates, x.
    pub x: Option<f64>,
    /// Where the ray met the surface, y.
    pub y: Option<f64>,
    /// Where the ray met the surface, z.
    pub z: Option<f64>,
    /// How far the point was snapped onto the silhouette, screen px.
    pub snap_px: Option<f64>,
    /// The fate's name ([`ProjectionFate::name`]).
    pub fate: String,
}

impl From<&ProjectedFixation> for ProjectedRow {
    fn from(p: &ProjectedFixation) -> ProjectedRow {
        ProjectedRow {
            subject: p.subject.clone(),
            fixation: p.index,
            start_ms: p.start_ms,
            duration_ms: p.duration_ms,
            screen_x: p.screen_x,
            screen_y: p.screen_y,
            camera_time_s: p.camera_time_s,
            phase: p.phase.map(|ph| ph.name().to_string()),
            viewpoint: p.viewpoint,
            triangle: p.triangle,
            vertex: p.vertex,
            x: p.point.map(|q| q.x),
            y: p.point.map(|q| q.y),
            z: p.point.map(|q| q.z),
            snap_px: p.snap_px,
            fate: p.fate.name().to_string(),
        }
    }
}

impl ProjectedRow {
    /// The fate, when its name is one meshgaze writes.
    pub fn fate(&self) -> Option<ProjectionFate> {
        ProjectionFate::parse(&self.fate)
    }

    /// The surface point, when the fixation landed on the mesh.
    pub fn point(&self) -> Option<DVec3> {
        Some(DVec3::new(self.x?, self.y?, self.z?))
    }

    /// The camera's phase, when written.
    pub fn phase(&self) -> Option<Phase> {
        match self.phase.as_deref() {
            Some("hold") => Some(Phase::Hold),
            Some("move") => Some(Phase::Move),
            Some("ended") => Some(Phase::Ended),
            _ => None,
        }
    }
}

/// Why a projected.csv or targets.csv could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The file could not be read.
    #[error("{name}: {error}")]
    Read {
        /// The file.
        name: String,
        /// The I/O or gzip error.
        error: crate::file_bytes::ReadError,
    },
    /// A row (line 1: the header) is not a row of the table.
    #[error("{name}:{line}: {message}")]
    Row {
        /// The file.
        name: String,
        /// 1-based line.
        line: u64,
        /// What is wrong with it (the column where known).
        message: String,
    },
    /// Writing the table failed.
    #[error("{0}")]
    Write(#[from] csv::Error),
}

/// Writes projected.csv (the header alone when there are no rows).
pub fn write_projected_csv<W: Write>(out: W, rows: &[ProjectedRow]) -> Result<(), TableError> {
    let mut w = csv::Writer::from_writer(out);
    for r in rows {
        w.serialize(r)?;
    }
    if rows.is_empty() {
        w.write_record([
            "subject",
            "fixation",
            "start_ms",
            "duration_ms",
            "screen_x",
            "screen_y",
            "camera_time_s",
            "phase",
            "viewpoint",
            "triangle",
            "vertex",
            "x",
            "y",
            "z",
            "snap_px",
            "fate",
        ])?;
    }
    w.flush().map_err(|e| TableError::Write(e.into()))
}

/// Reads a `projected.csv`, checking every fate name and that on-mesh rows have a vertex.
pub fn read_projected_csv(path: &Path) -> Result<Vec<ProjectedRow>, TableError> {
    let name = path.display().to_string();
    let bytes = crate::file_bytes::read_maybe_gzipped(path).map_err(|error| TableError::Read {
        name: name.clone(),
        error,
    })?;
    parse_projected_csv(&bytes, &name)
}

/// [`read_projected_csv`] on bytes already in memory; `name` labels the errors.
pub fn parse_projected_csv(bytes: &[u8], name: &str) -> Result<Vec<ProjectedRow>, TableError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut r = csv::Reader::from_reader(bytes);
    let at = |line: u64, message: String| TableError::Row {
        name: name.to_string(),
        line,
        message,
    };
    let headers = r.headers().map_err(|e| at(1, e.to_string()))?.clone();
    let mut rows = Vec::new();
    for rec in r.deserialize::<ProjectedRow>() {
        let row = rec.map_err(|e| {
            let line = e.position().map_or(0, |p| p.line());
            match e.kind() {
                csv::ErrorKind::Deserialize { err, .. } => {
                    let col = err
                        .field()
                        .and_then(|i| headers.get(i as usize))
                        .unwrap_or("?");
                    at(line, format!("column `{col}`: {}", err.kind()))
                }
                other => at(line, format!("{other:?}")),
            }
        })?;
        let line = rows.len() as u64 + 2;
        match row.fate() {
            None => {
                return Err(at(
                    line,
                    format!(
                        "unknown fate `{}` (expected one of {})",
                        row.fate,
                        ProjectionFate::ALL.map(|f| f.name()).join(", ")
                    ),
                ))
            }
            Some(f) if f.on_mesh() && row.vertex.is_none() => {
                return Err(at(line, format!("a `{}` row needs a vertex", row.fate)))
            }
            _ => {}
        }
        rows.push(row);
    }
    Ok(rows)
}

//! `fixations.csv`, the table `meshgaze ingest` writes and `meshgaze project` reads: one row
//! per fixation with its subject, stimulus, times, screen position and fate.
use std::io::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::fixations::Fixation;

/// The columns written: [`HEADER`] and the reason for an `invalid` fate.
pub const WRITTEN: [&str; 14] = [
    "subject",
    "stimulus",
    "eye",
    "trial",
    "start_us",
    "end_us",
    "duration_ms",
    "x_px",
    "y_px",
    "dispersion_px",
    "pupil",
    "onset_offset_us",
    "fate",
    "invalid_reason",
];

/// Columns every fixations.csv has; `invalid_reason` follows (absent in older files).
pub const HEADER: &[&str] = WRITTEN.split_at(13).0;

/// One row of `fixations.csv`, as read back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FixationRow {
    /// The subject's id.
    pub subject: String,
    /// The stimulus it was made on (empty: outside every stimulus).
    pub stimulus: String,
    /// `left`, `right`, `average` or `binocular`.
    pub eye: String,
    /// The trial it belongs to.
    pub trial: u32,
    /// Start, tracker clock in µs.
    pub start_us: i64,
    /// End, tracker clock in µs.
    pub end_us: i64,
    /// Duration, ms.
    pub duration_ms: f64,
    /// Position on the screen, px, horizontal.
    pub x_px: f64,
    /// Position on the screen, px, vertical.
    pub y_px: f64,
    /// Dispersion of its samples (or the export's), px.
    pub dispersion_px: Option<f64>,
    /// Pupil size (its samples' mean, or the export's), in the file's unit.
    pub pupil: Option<f64>,
    /// Start of the fixation after its stimulus onset message, µs.
    pub onset_offset_us: Option<i64>,
    /// The filter's fate (`kept`, `dropped-first`, ...).
    pub fate: String,
    /// Why the fate is `invalid` (empty otherwise).
    #[serde(default)]
    pub invalid_reason: String,
}

impl From<&Fixation> for FixationRow {
    fn from(f: &Fixation) -> FixationRow {
        FixationRow {
            subject: f.subject.clone(),
            stimulus: f.stimulus.clone(),
            eye: f.eye.to_string(),
            trial: f.trial,
            start_us: f.start_us,
            end_us: f.end_us,
            duration_ms: f.duration_ms,
            x_px: f.x_px,
            y_px: f.y_px,
            dispersion_px: f.dispersion_px,
            pupil: f.pupil,
            onset_offset_us: f.onset_offset_us,
            fate: f.fate.name().to_string(),
            invalid_reason: f.invalid_reason.unwrap_or("").to_string(),
        }
    }
}

/// Writes the table (RFC 4180 quoting, so subjects and stimuli may hold commas).
pub fn write_fixations_csv<W: Write>(out: W, rows: &[FixationRow]) -> Result<(), super::GazeError> {
    let mut w = csv::WriterBuilder::new()
        .has_headers(false)
        .from_writer(out);
    w.write_record(WRITTEN).map_err(super::GazeError::table)?;
    for r in rows {
        w.serialize(r).map_err(super::GazeError::table)?;
    }
    w.flush().map_err(super::GazeError::table)
}

/// Reads a `fixations.csv`; errors name the file, line and field.
pub fn read_fixations_csv(path: &Path) -> Result<Vec<FixationRow>, super::GazeError> {
    let bytes = crate::file_bytes::read_maybe_gzipped(path)
        .map_err(|e| super::GazeError::file(path, e.to_string()))?;
    parse_fixations_csv(&bytes, &path.display().to_string())
}

/// fixations.csv from bytes; `name` labels the errors (name:line:column).
pub fn parse_fixations_csv(bytes: &[u8], name: &str) -> Result<Vec<FixationRow>, super::GazeError> {
    let row_error = |line: usize, message: String| super::GazeError::Row {
        path: name.to_string(),
        line,
        message,
    };
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut r = csv::ReaderBuilder::new().from_reader(bytes);
    let headers = r
        .headers()
        .map_err(|e| row_error(1, e.to_string()))?
        .clone();
    for needed in HEADER {
        if !headers.iter().any(|h| h == *needed) {
            return Err(row_error(1, format!(
                "no `{needed}` column; is this a fixations.csv written by `meshgaze ingest`? (columns: {})",
                headers.iter().collect::<Vec<_>>().join(",")
            )));
        }
    }
    let mut rows = Vec::new();
    for rec in r.deserialize::<FixationRow>() {
        match rec {
            Ok(row) => rows.push(row),
            Err(e) => {
                let line = e.position().map_or(0, |p| p.line());
                let field = match e.kind() {
                    csv::ErrorKind::Deserialize { err, .. } => err
                        .field()
                        .and_then(|i| headers.get(i as usize))
                        .map(|h| format!("column `{h}`: "))
                        .unwrap_or_default(),
                    _ => String::new(),
                };
                let message = match e.kind() {
                    csv::ErrorKind::Deserialize { err, .. } => err.kind().to_string(),
                    other => format!("{other:?}"),
                };
                return Err(row_error(line as usize, format!("{field}{message}")));
            }
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(subject: &str) -> FixationRow {
        FixationRow {
            subject: subject.into(),
            stimulus: "bunny, take \"2\"".into(),
            eye: "left".into(),
            trial: 3,
            start_us: -5,
            end_us: 250_000,
            duration_ms: 250.005,
            x_px: 811.25,
            y_px: -3.5,
            dispersion_px: None,
            pupil: Some(4.25),
            onset_offset_us: Some(1_000_000),
            fate: "kept".into(),
            invalid_reason: String::new(),
        }
    }

    #[test]
    fn round_trips_with_quoting() {
        let rows = vec![row("s01"), row("a,b")];
        let mut buf = Vec::new();
        write_fixations_csv(&mut buf, &rows).unwrap();
        assert_eq!(parse_fixations_csv(&buf, "f").unwrap(), rows);
    }

    #[test]
    fn errors_name_line_and_column() {
        let mut buf = Vec::new();
        write_fixations_csv(&mut buf, &[row("s01"), row("s02")]).unwrap();
        let text = String::from_utf8(buf).unwrap().replace("811.25", "8x1");
        let e = parse_fixations_csv(text.as_bytes(), "fix.csv")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("fix.csv:2: column `x_px`:"), "{e}");
        let e = parse_fixations_csv(b"a,b\n1,2\n", "fix.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("no `subject` column"), "{e}");
    }
}

//! SMI RED / iView X / BeGaze text exports: detection and readers (formats A, A', A2, B,
//! B-fix, C1, C2). Nothing is dropped
//! silently: every line of a file is a header line, a blank line, a sample, a message, an
//! event, or counted as unusable with its reason and the position of the first such line.
pub mod begaze_fixations;
pub mod begaze_raw;
pub mod event_statistics;
pub mod event_tables;
pub mod fixation_table;
pub mod fixations;
pub mod idf_samples;
pub mod ingest;
pub mod iview_legacy;
pub mod quality;
pub mod recording;
pub mod stimulus_messages;
pub mod text;
pub mod validity;
pub mod writers;

use std::path::Path;

pub use recording::{
    Event, EventKind, Eye, EyeSample, GazeError, Message, Recording, Sample, SmiFormat,
};

use crate::file_bytes::{read_maybe_gzipped, ReadError};

/// Which SMI format the bytes are, from their first lines; None when none fits.
pub fn detect_format(bytes: &[u8]) -> Result<SmiFormat, String> {
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(65536)]);
    let head = head.trim_start_matches('\u{feff}');
    let first = head.lines().next().unwrap_or("").trim();
    if iview_legacy::looks_like(head) {
        return Ok(SmiFormat::IviewLegacy);
    }
    if head.contains("Table Header for") {
        return Ok(SmiFormat::EventTables);
    }
    if first.starts_with("##") || head.lines().any(|l| l.starts_with("Time\tType\t")) {
        return Ok(
            if first.contains("[BeGaze]") || head.contains("Event Info") {
                SmiFormat::BeGazeSamples
            } else {
                SmiFormat::IdfSamples
            },
        );
    }
    if first.contains("RecordingTime [ms]") {
        return Ok(SmiFormat::BeGazeRaw);
    }
    if first.contains("Event Start Trial Time [ms]") {
        return Ok(SmiFormat::EventStatistics);
    }
    if begaze_fixations::SIGNATURE
        .iter()
        .all(|c| first.contains(c))
    {
        return Ok(SmiFormat::BeGazeFixations);
    }
    Err("not a recognized SMI export: expected a `## [iView]`/`## [BeGaze]` sample file (A, A'), an iView X 2.x `#FileVersion: 2` sample file (A2), a `Table Header for …` event file (C1), a BeGaze Raw Data table (`RecordingTime [ms]`, C2), an Event Statistics table (`Event Start Trial Time [ms]`, B) or a BeGaze fixation table (`Fixation Start [ms]`, B-fix)".into())
}

/// Reads bytes as `format` (detected when None); `path` is for messages.
pub fn parse_smi(
    bytes: &[u8],
    path: &str,
    format: Option<SmiFormat>,
) -> Result<Recording, GazeError> {
    let format = match format {
        Some(f) => f,
        None => detect_format(bytes).map_err(|message| GazeError::File {
            path: path.to_string(),
            message,
        })?,
    };
    let mut r = match format {
        SmiFormat::IdfSamples | SmiFormat::BeGazeSamples => idf_samples::read(bytes, path)?,
        SmiFormat::EventTables => event_tables::read(bytes, path)?,
        SmiFormat::BeGazeRaw => begaze_raw::read(bytes, path)?,
        SmiFormat::EventStatistics => event_statistics::read(bytes, path)?,
        SmiFormat::BeGazeFixations => begaze_fixations::read(bytes, path)?,
        SmiFormat::IviewLegacy => iview_legacy::read(bytes, path)?,
    };
    if format == SmiFormat::BeGazeSamples {
        r.format = SmiFormat::BeGazeSamples;
    }
    Ok(r)
}

/// Reads an SMI export file (gzip allowed).
pub fn read_smi(path: &Path, format: Option<SmiFormat>) -> Result<Recording, GazeError> {
    let p = path.display().to_string();
    let bytes = read_maybe_gzipped(path).map_err(|e| match e {
        ReadError::Io(source) => GazeError::Io {
            path: p.clone(),
            error: source,
        },
        ReadError::CorruptGzip(e) => GazeError::File {
            path: p.clone(),
            message: format!("gzip data is corrupt: {e}"),
        },
    })?;
    parse_smi(&bytes, &p, format)
}

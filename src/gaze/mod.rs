//! Gaze recordings: detection and readers for SMI RED / iView X / BeGaze text exports
//! (formats A, A', A2, B, B-fix, C1, C2), SR Research EyeLink ASC files, Tobii Pro Lab /
//! Studio data exports, Gazepoint Analysis exports and Pupil Labs surface exports, all into one
//! record model ([`Recording`]). Nothing is dropped silently: every line of a file is a
//! header line, a blank line, a sample, a message, an event, or counted as unusable with its
//! reason and the position of the first such line.
pub(crate) mod begaze_fixations;
pub(crate) mod begaze_raw;
pub(crate) mod event_statistics;
pub(crate) mod event_tables;
pub mod eyelink;
pub mod fixation_table;
pub mod fixations;
pub(crate) mod gazepoint;
pub(crate) mod idf_samples;
pub mod ingest;
pub(crate) mod iview_legacy;
pub(crate) mod pupil_labs;
pub mod quality;
pub mod recording;
pub mod stimulus_messages;
pub(crate) mod table_scan;
pub mod text;
pub(crate) mod tobii;
pub(crate) mod tobii_lists;
pub(crate) mod tobii_sdk;
pub mod validity;
pub mod writers;

use std::path::Path;

pub use recording::{
    Event, EventKind, Eye, EyeSample, GazeError, GazeFormat, Message, Recording, Sample,
};

use crate::file_bytes::{read_maybe_gzipped, ReadError};

/// The bytes are not a recording meshgaze reads.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum FormatError {
    /// An EyeLink EDF binary: its ASC text (from SR Research's edf2asc) is what is read.
    #[error("{}", eyelink::edf_refusal())]
    EyelinkEdf,
    /// No format fits; the message lists what each expects.
    #[error("{}", UNRECOGNIZED)]
    Unrecognized,
}

/// What [`FormatError::Unrecognized`] says: every format's telltale lines.
const UNRECOGNIZED: &str = "not a recognized gaze recording: expected an EyeLink ASC file (`** CONVERTED FROM … edf`, `MSG`/`START`/`SAMPLES` lines), a Tobii Pro Lab or Studio data export (`Recording timestamp` … `Gaze point X`, or `RecordingTimestamp` … `GazePointX (ADCSpx)`), a Tobii Studio 1.x/2.x fixation list (`FixationIndex\tTimestamp\tFixationDuration` after a `Data properties:` block), a Tobii Pro SDK gaze dump (`system_time_stamp`, `left_gaze_point_on_display_area_x`), a Gazepoint Analysis export (`TIME(…)`, `FPOGX`), a Pupil Labs surface export (`gaze_positions_on_surface_<name>.csv`, Marker Mapper `gaze.csv`), or an SMI export: a `## [iView]`/`## [BeGaze]` sample file (A, A'), an iView X 2.x `#FileVersion: 2` sample file (A2), a `Table Header for …` event file (C1), a BeGaze Raw Data table (`RecordingTime [ms]`, C2), an Event Statistics table (`Event Start Trial Time [ms]`, B) or a BeGaze fixation table (`Fixation Start [ms]`, B-fix)";

/// Which format the bytes are, from their content (never the file name); an error saying
/// what was expected when none fits.
pub fn detect_format(bytes: &[u8]) -> Result<GazeFormat, FormatError> {
    if eyelink::looks_like_edf(bytes) {
        return Err(FormatError::EyelinkEdf);
    }
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(65536)]);
    let head = head.trim_start_matches('\u{feff}');
    let first = head.lines().next().unwrap_or("").trim();
    if eyelink::looks_like(head) {
        return Ok(GazeFormat::EyelinkAsc);
    }
    if tobii_lists::looks_like(head) {
        return Ok(GazeFormat::TobiiStudioList);
    }
    if pupil_labs::looks_like(first) {
        return Ok(if pupil_labs::is_cloud(first) {
            GazeFormat::PupilCloud
        } else {
            GazeFormat::PupilCore
        });
    }
    if tobii_sdk::looks_like(first) {
        return Ok(GazeFormat::TobiiSdk);
    }
    if gazepoint::looks_like(first) {
        return Ok(GazeFormat::Gazepoint);
    }
    if tobii::looks_like(first) {
        return Ok(if first.contains("RecordingTimestamp") {
            GazeFormat::TobiiStudio
        } else {
            GazeFormat::TobiiProLab
        });
    }
    if iview_legacy::looks_like(head) {
        return Ok(GazeFormat::IviewLegacy);
    }
    if head.contains("Table Header for") {
        return Ok(GazeFormat::EventTables);
    }
    if first.starts_with("##") || head.lines().any(|l| l.starts_with("Time\tType\t")) {
        return Ok(
            if first.contains("[BeGaze]") || head.contains("Event Info") {
                GazeFormat::BeGazeSamples
            } else {
                GazeFormat::IdfSamples
            },
        );
    }
    if first.contains("RecordingTime [ms]") {
        return Ok(GazeFormat::BeGazeRaw);
    }
    if first.contains("Event Start Trial Time [ms]") {
        return Ok(GazeFormat::EventStatistics);
    }
    if begaze_fixations::SIGNATURE
        .iter()
        .all(|c| first.contains(c))
    {
        return Ok(GazeFormat::BeGazeFixations);
    }
    Err(FormatError::Unrecognized)
}

/// Reads bytes as `format` (detected when None); `path` is for messages.
pub fn parse_recording(
    bytes: &[u8],
    path: &str,
    format: Option<GazeFormat>,
) -> Result<Recording, GazeError> {
    let format = match format {
        Some(f) => f,
        None => detect_format(bytes).map_err(|e| GazeError::File {
            path: path.to_string(),
            message: e.to_string(),
        })?,
    };
    let mut r = match format {
        GazeFormat::IdfSamples | GazeFormat::BeGazeSamples => idf_samples::read(bytes, path)?,
        GazeFormat::EventTables => event_tables::read(bytes, path)?,
        GazeFormat::BeGazeRaw => begaze_raw::read(bytes, path)?,
        GazeFormat::EventStatistics => event_statistics::read(bytes, path)?,
        GazeFormat::BeGazeFixations => begaze_fixations::read(bytes, path)?,
        GazeFormat::IviewLegacy => iview_legacy::read(bytes, path)?,
        GazeFormat::EyelinkAsc => eyelink::read(bytes, path)?,
        GazeFormat::TobiiProLab | GazeFormat::TobiiStudio => tobii::read(bytes, path)?,
        GazeFormat::Gazepoint => gazepoint::read(bytes, path)?,
        GazeFormat::TobiiStudioList => tobii_lists::read(bytes, path)?,
        GazeFormat::TobiiSdk => tobii_sdk::read(bytes, path)?,
        GazeFormat::PupilCore | GazeFormat::PupilCloud => pupil_labs::read(bytes, path)?,
    };
    if format == GazeFormat::BeGazeSamples {
        r.format = GazeFormat::BeGazeSamples;
    }
    Ok(r)
}

/// Reads a gaze recording of any supported format (gzip allowed).
pub fn read_recording(path: &Path, format: Option<GazeFormat>) -> Result<Recording, GazeError> {
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
    let mut rec = parse_recording(&bytes, &p, format)?;
    if rec.format == GazeFormat::TobiiStudioList {
        // Studio wrote the stimulus events to the event list beside the fixation list.
        if let Some((messages, file, skipped)) = tobii_lists::sibling_event_messages(path) {
            rec.notes.push(format!(
                "{} messages from {file}{}",
                messages.len(),
                if skipped > 0 {
                    format!(" ({skipped} of its rows were not messages)")
                } else {
                    String::new()
                }
            ));
            rec.messages.extend(messages);
        }
    }
    if matches!(rec.format, GazeFormat::PupilCore | GazeFormat::PupilCloud) {
        // Pupil Labs writes messages to files of their own beside the gaze.
        let (messages, files) =
            pupil_labs::sibling_messages(path, rec.format == GazeFormat::PupilCloud);
        for (file, n, skipped) in files {
            rec.notes.push(format!(
                "{n} messages from {file}{}",
                if skipped > 0 {
                    format!(" ({skipped} of its lines were not messages)")
                } else {
                    String::new()
                }
            ));
        }
        rec.messages.extend(messages);
    }
    Ok(rec)
}

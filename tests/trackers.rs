//! Real exports of current trackers (../shared/data/trackers, see its SOURCES.md), read with
//! default settings: each gives fixations, or is refused with the reason where it holds no
//! screen position. Counts are checked against the files' own lines, counted here
//! independently of the readers.
mod common;

use std::path::PathBuf;

use meshgaze::gaze::fixations::{Detector, Fate};
use meshgaze::gaze::ingest::{ingest_file, IngestParams};
use meshgaze::gaze::{EventKind, GazeFormat};
use meshgaze::protocol::Protocol;

fn params() -> IngestParams {
    IngestParams::from_protocol(&Protocol::builtin().0, None).unwrap()
}

fn tracker_files(vendor: &str, ext: &str) -> Vec<PathBuf> {
    let dir = common::shared_data().join("trackers").join(vendor);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(ext))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no {ext} files in {}", dir.display());
    files
}

/// Lines whose first field is `key`, counted without the reader.
fn lines_starting(text: &str, key: &str) -> usize {
    text.lines()
        .filter(|l| l.split(['\t', ' ']).next() == Some(key))
        .count()
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn every_eyelink_asc_gives_fixations_with_default_settings() {
    for path in tracker_files("eyelink", ".asc") {
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).to_string();
        let f = ingest_file(&path, &params()).unwrap_or_else(|e| panic!("{e}"));
        let r = &f.recording;
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        assert_eq!(r.format, GazeFormat::EyelinkAsc, "{name}");
        assert_eq!(
            r.rows.accounted(),
            r.rows.lines,
            "{name}: every line accounted"
        );
        assert!(
            r.rows.unusable.is_empty(),
            "{name}: unusable lines {:?}",
            r.rows.unusable
        );
        let sample_lines = text
            .lines()
            .filter(|l| l.as_bytes().first().is_some_and(u8::is_ascii_digit))
            .count();
        assert_eq!(r.samples.len(), sample_lines, "{name}: samples");
        let fixation_events = r
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Fixation)
            .count();
        assert_eq!(
            fixation_events,
            lines_starting(&text, "EFIX"),
            "{name}: EFIX"
        );
        assert_eq!(
            r.messages.len(),
            lines_starting(&text, "MSG")
                + lines_starting(&text, "INPUT")
                + lines_starting(&text, "BUTTON"),
            "{name}: messages"
        );
        assert_eq!(
            f.detector,
            Detector::Events,
            "{name}: the tracker's own fixations"
        );
        // Usable: on screen, inside a stimulus. The protocol's filter (drop 2 + 2 per stimulus)
        // may then keep none of a short trial's few: that is the protocol, not the reader.
        let usable = f
            .fixations
            .iter()
            .filter(|x| x.fate != Fate::Invalid)
            .count();
        let kept = f.fixations.iter().filter(|x| x.fate == Fate::Kept).count();
        assert!(usable > 0, "{name}: no usable fixation: {:?}", f.warnings);
        assert!(
            r.header.calibration_area_px.is_some(),
            "{name}: the screen comes from GAZE_COORDS / DISPLAY_COORDS"
        );
        eprintln!(
            "{name}: {} samples, {fixation_events} fixation events, {usable} usable, {kept} kept, screen {:?}, {} Hz",
            r.samples.len(),
            r.header.calibration_area_px.unwrap(),
            r.header.sample_rate_hz.unwrap_or(f64::NAN)
        );
    }
}

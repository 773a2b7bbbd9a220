//! What a gaze recording holds (SMI exports and the other trackers' files alike), in one normalized form whatever the format: samples (both eyes),
//! messages, events, the header, and an account of every row.
use std::collections::BTreeMap;

use serde::Serialize;

/// The export formats (names as in shared/docs/smi-formats.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
pub enum GazeFormat {
    /// IDF Converter sample text: `## [iView]` header, TSV, `Time` in µs, `MSG` rows.
    #[cfg_attr(feature = "cli", value(name = "a"))]
    #[serde(rename = "A")]
    IdfSamples,
    /// BeGaze sample export: `## [BeGaze]` (or a blanked `##` header), per-eye `Event Info`.
    #[cfg_attr(feature = "cli", value(name = "a-begaze"))]
    #[serde(rename = "A'")]
    BeGazeSamples,
    /// IDF Event Detector / BeGaze event text: `Table Header for …` sections.
    #[cfg_attr(feature = "cli", value(name = "c1"))]
    #[serde(rename = "C1")]
    EventTables,
    /// BeGaze "Raw Data" export: `RecordingTime [ms]`, one row per sample, `-` for missing.
    #[cfg_attr(feature = "cli", value(name = "c2"))]
    #[serde(rename = "C2")]
    BeGazeRaw,
    /// BeGaze Metrics Export "Event Statistics": one row per event, times in ms from trial start.
    #[cfg_attr(feature = "cli", value(name = "b"))]
    #[serde(rename = "B")]
    EventStatistics,
    /// Older BeGaze fixation export: one row per fixation (`Fixation Start [ms]`, `Position
    /// X`, `Eye`), no `##` header, several subjects and trials per file.
    #[cfg_attr(feature = "cli", value(name = "b-fix"))]
    #[serde(rename = "B-fix")]
    BeGazeFixations,
    /// iView X 2.x sample file (`#FileVersion: 2`): `#` header, `#Time Set … ScreenH ScreenV`
    /// columns, integer ms times, one eye.
    #[cfg_attr(feature = "cli", value(name = "a2"))]
    #[serde(rename = "A2")]
    IviewLegacy,
    /// SR Research EyeLink ASC text (edf2asc): `START`/`END` blocks, `SAMPLES`/`EVENTS`
    /// layout lines, `EFIX`/`ESACC`/`EBLINK` events, `MSG` lines.
    #[cfg_attr(feature = "cli", value(name = "eyelink"))]
    #[serde(rename = "EyeLink ASC")]
    EyelinkAsc,
    /// Tobii Pro Lab data export (TSV or CSV): `Recording timestamp`, `Sensor`, `Gaze point
    /// X/Y`, `Eye movement type` and its index, `Presented Media name`.
    #[cfg_attr(feature = "cli", value(name = "tobii-pro-lab"))]
    #[serde(rename = "Tobii Pro Lab")]
    TobiiProLab,
    /// Tobii Studio data export (TSV): `RecordingTimestamp` (ms), `GazePointX (ADCSpx)`,
    /// `FixationIndex`, `MediaName`, `StudioEvent`.
    #[cfg_attr(feature = "cli", value(name = "tobii-studio"))]
    #[serde(rename = "Tobii Studio")]
    TobiiStudio,
    /// Tobii Studio 1.x/2.x fixation list (`…-Fixation-Data.tsv`: a `key: value` block, then
    /// `FixationIndex`, `Timestamp`, `FixationDuration`, `MappedFixationPointX/Y`).
    #[cfg_attr(feature = "cli", value(name = "tobii-studio-list"))]
    #[serde(rename = "Tobii Studio list")]
    TobiiStudioList,
    /// Tobii Pro SDK gaze dump (`system_time_stamp`, `left_gaze_point_on_display_area_x/_y`
    /// fractions of the display, validity flags), as experiment programs write it.
    #[cfg_attr(feature = "cli", value(name = "tobii-sdk"))]
    #[serde(rename = "Tobii Pro SDK")]
    TobiiSdk,
    /// Gazepoint Analysis export (`*_all_gaze.csv`, `*_fixations.csv`): `TIME(…)` s,
    /// `FPOGX/FPOGY` fractions of the screen, `FPOGID` fixations, `MEDIA_NAME`, `USER`.
    #[cfg_attr(feature = "cli", value(name = "gazepoint"))]
    #[serde(rename = "Gazepoint")]
    Gazepoint,
    /// Pupil Core surface export of Pupil Player (`gaze_positions_on_surface_<name>.csv`,
    /// `fixations_on_surface_<name>.csv`): fractions of the surface.
    #[cfg_attr(feature = "cli", value(name = "pupil-core"))]
    #[serde(rename = "Pupil Core surface")]
    PupilCore,
    /// Pupil Cloud Marker Mapper export of Neon / Invisible (`gaze.csv`, `fixations.csv`).
    #[cfg_attr(feature = "cli", value(name = "pupil-cloud"))]
    #[serde(rename = "Pupil Cloud surface")]
    PupilCloud,
}

impl GazeFormat {
    /// Every format, in the order `ingest --help` lists them.
    pub const ALL: [GazeFormat; 15] = [
        GazeFormat::IdfSamples,
        GazeFormat::BeGazeSamples,
        GazeFormat::EventTables,
        GazeFormat::BeGazeRaw,
        GazeFormat::EventStatistics,
        GazeFormat::BeGazeFixations,
        GazeFormat::IviewLegacy,
        GazeFormat::EyelinkAsc,
        GazeFormat::TobiiProLab,
        GazeFormat::TobiiStudio,
        GazeFormat::TobiiStudioList,
        GazeFormat::TobiiSdk,
        GazeFormat::Gazepoint,
        GazeFormat::PupilCore,
        GazeFormat::PupilCloud,
    ];

    /// The name `ingest --format` takes (a test keeps it equal to the command line's).
    pub fn short_name(self) -> &'static str {
        match self {
            GazeFormat::IdfSamples => "a",
            GazeFormat::BeGazeSamples => "a-begaze",
            GazeFormat::EventTables => "c1",
            GazeFormat::BeGazeRaw => "c2",
            GazeFormat::EventStatistics => "b",
            GazeFormat::BeGazeFixations => "b-fix",
            GazeFormat::IviewLegacy => "a2",
            GazeFormat::EyelinkAsc => "eyelink",
            GazeFormat::TobiiProLab => "tobii-pro-lab",
            GazeFormat::TobiiStudio => "tobii-studio",
            GazeFormat::TobiiStudioList => "tobii-studio-list",
            GazeFormat::TobiiSdk => "tobii-sdk",
            GazeFormat::Gazepoint => "gazepoint",
            GazeFormat::PupilCore => "pupil-core",
            GazeFormat::PupilCloud => "pupil-cloud",
        }
    }

    /// The format of a `--format` name, or an error listing the names.
    pub fn from_short_name(name: &str) -> Result<GazeFormat, GazeError> {
        GazeFormat::ALL
            .into_iter()
            .find(|f| f.short_name() == name)
            .ok_or_else(|| {
                let names: Vec<&str> = GazeFormat::ALL.iter().map(|f| f.short_name()).collect();
                GazeError::Invalid(format!(
                    "unknown gaze format `{name}`; one of {}",
                    names.join(", ")
                ))
            })
    }
}

/// Which eye a sample stream or an event is from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
pub enum Eye {
    /// The left eye.
    Left,
    /// The right eye.
    Right,
    /// BeGaze's binocular event stream (`Category Binocular`).
    Binocular,
}

/// One eye in one sample. Kept even when invalid, so nothing is lost; `valid` says whether
/// it can be used.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EyeSample {
    /// Point of regard in calibration-area pixels (origin top-left), horizontal.
    pub x: f64,
    /// Point of regard, vertical (pixels down from the top).
    pub y: f64,
    /// Pupil: mapped diameter in mm when exported, else the camera diameter in px.
    pub pupil: Option<f64>,
    /// False when the validity flag is 0 or the point of regard is exactly (0, 0), SMI's
    /// tracking-loss value (see [`crate::gaze::validity`] for when the flag is set aside).
    pub valid: bool,
    /// The exporter's own validity flag for this eye said "lost" (0). Kept apart from
    /// `valid` so that a flag that contradicts the gaze in every row can be set aside.
    #[serde(skip)]
    pub flag_lost: bool,
}

/// One row of gaze samples: both eyes as the file gives them, kept even when invalid.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Sample {
    /// Tracker clock in microseconds (an arbitrary epoch; not uniform, pauses jump).
    pub time_us: i64,
    /// The trial (SMI's `Trial` column; 1 for formats without trials).
    pub trial: u32,
    /// The left eye, when the file has it.
    pub left: Option<EyeSample>,
    /// The right eye, when the file has it.
    pub right: Option<EyeSample>,
    /// The binocular (combined) point of regard, when the file gives one: BeGaze C2's, Tobii's
    /// `Gaze point X/Y`, Gazepoint's `BPOG`.
    pub binocular: Option<EyeSample>,
    /// The exporter's binocular event label: BeGaze C2's category (`Visual Intake`, `Saccade`,
    /// `Blink`, `-`), Tobii's `Eye movement type`.
    pub binocular_event: Option<std::sync::Arc<str>>,
    /// The left eye's event label from the exporter (BeGaze's `Fixation`, `Saccade`, `Blink`, `-`), when exported.
    pub left_event: Option<std::sync::Arc<str>>,
    /// The right eye's event label, as `left_event`.
    pub right_event: Option<std::sync::Arc<str>>,
    /// The stimulus the row names (BeGaze's `Stimulus` column, Tobii's `Presented Media
    /// name`, Gazepoint's `MEDIA_NAME`), when the file has one; consecutive rows share one copy.
    pub stimulus: Option<std::sync::Arc<str>>,
}

/// Consecutive rows naming one stimulus share one copy of its name: a reader asks for the
/// name of each row and gets the previous row's copy when the text is the same (an export
/// repeats the stimulus on each of its ~1,000 rows a second).
#[derive(Debug, Default)]
pub(crate) struct SharedNames {
    last: Option<std::sync::Arc<str>>,
}

impl SharedNames {
    /// The shared copy of `text`.
    pub(crate) fn of(&mut self, text: &str) -> std::sync::Arc<str> {
        match &self.last {
            Some(last) if **last == *text => last.clone(),
            _ => {
                let name: std::sync::Arc<str> = std::sync::Arc::from(text);
                self.last = Some(name.clone());
                name
            }
        }
    }
}

/// Event labels (`Fixation`, `Saccade`, `Blink`, `-`...) shared across rows: a handful of
/// distinct texts on a million rows, each kept once instead of allocated per row.
#[derive(Debug, Default)]
pub(crate) struct SharedLabels {
    seen: Vec<std::sync::Arc<str>>,
}

impl SharedLabels {
    /// Beyond this many distinct labels a column is not a label column: copies are not kept.
    const MAX_KEPT: usize = 32;

    /// The shared copy of `text`.
    pub(crate) fn of(&mut self, text: &str) -> std::sync::Arc<str> {
        if let Some(label) = self.seen.iter().find(|l| ***l == *text) {
            return label.clone();
        }
        let label: std::sync::Arc<str> = std::sync::Arc::from(text);
        if self.seen.len() < Self::MAX_KEPT {
            self.seen.push(label.clone());
        }
        label
    }
}

/// The sampling rate from the median positive interval between consecutive samples, rounded
/// to whole Hz; None with fewer than `min_intervals` intervals (too few to tell a rate).
pub(crate) fn median_rate_hz(samples: &[Sample], min_intervals: usize) -> Option<f64> {
    let mut d: Vec<i64> = samples
        .windows(2)
        .map(|w| w[1].time_us - w[0].time_us)
        .filter(|d| *d > 0)
        .collect();
    if d.is_empty() || d.len() < min_intervals {
        return None;
    }
    // The element a full sort would put in the middle, found in linear time.
    let middle = d.len() / 2;
    let (_, median, _) = d.select_nth_unstable(middle);
    Some((1e6 / *median as f64).round())
}

/// A message the experiment program logged (or an event column turned into one): stimulus
/// onsets, status text, anything; never assumed to be a clean stimulus name.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Message {
    /// Tracker clock in microseconds.
    pub time_us: i64,
    /// The trial it belongs to (1 for formats without trials).
    pub trial: u32,
    /// The text after `# Message: ` (or the whole description when that prefix is absent).
    pub text: String,
}

/// What an event is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum EventKind {
    /// A fixation.
    Fixation,
    /// A saccade.
    Saccade,
    /// A blink.
    Blink,
}

/// A fixation, saccade or blink as an event export records it, one per eye.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Event {
    /// Fixation, saccade or blink.
    pub kind: EventKind,
    /// The eye (or the binocular stream) it was detected in.
    pub eye: Eye,
    /// The trial it belongs to (1 for formats without trials).
    pub trial: u32,
    /// Its number in the file's own count (per eye and kind).
    pub number: u64,
    /// Start, tracker clock in microseconds.
    pub start_us: i64,
    /// End, tracker clock in microseconds.
    pub end_us: i64,
    /// Duration as the file gives it (µs); may differ from `end_us - start_us` by a sample.
    pub duration_us: i64,
    /// Fixation location, or saccade start location (px), horizontal.
    pub x: Option<f64>,
    /// Fixation location, or saccade start location (px), vertical.
    pub y: Option<f64>,
    /// Saccade end location (px), horizontal.
    pub end_x: Option<f64>,
    /// Saccade end location (px), vertical.
    pub end_y: Option<f64>,
    /// A fixation's horizontal dispersion (px), when exported.
    pub dispersion_x: Option<f64>,
    /// A fixation's vertical dispersion (px), when exported.
    pub dispersion_y: Option<f64>,
    /// Average pupil size X (camera px) of a fixation.
    pub pupil_x: Option<f64>,
    /// Average pupil size Y (camera px) of a fixation.
    pub pupil_y: Option<f64>,
    /// The stimulus the export names for this event (format B), when it does.
    pub stimulus: Option<String>,
    /// The stimulus's onset on the same clock as `start_us`, when the export gives it (format
    /// B with raw times); None with `stimulus`: times count from the stimulus onset.
    pub stimulus_onset_us: Option<i64>,
    /// The participant the export names for this event (format B files may hold several).
    pub participant: Option<String>,
}

impl Event {
    /// An event of `kind` over [`start_us`, `end_us`] lasting `duration_us` (as the file gives
    /// it), with no position, pupil, stimulus or participant yet: readers fill what they have
    /// with struct update syntax.
    pub fn span(
        kind: EventKind,
        eye: Eye,
        number: u64,
        start_us: i64,
        end_us: i64,
        duration_us: i64,
    ) -> Event {
        Event {
            kind,
            eye,
            trial: 1,
            number,
            start_us,
            end_us,
            duration_us,
            x: None,
            y: None,
            end_x: None,
            end_y: None,
            dispersion_x: None,
            dispersion_y: None,
            pupil_x: None,
            pupil_y: None,
            stimulus: None,
            stimulus_onset_us: None,
            participant: None,
        }
    }
}

/// Header facts meshgaze uses; every raw `key: value` line is kept too.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct Header {
    /// The file's first line or the exporter's name (`Tobii Pro Lab data export`).
    pub banner: Option<String>,
    /// Every `key: value` line of the header, as written.
    pub entries: Vec<(String, String)>,
    /// Samples per second, from the header or the median interval between samples.
    pub sample_rate_hz: Option<f64>,
    /// The screen (calibration area) in pixels: width, height.
    pub calibration_area_px: Option<[f64; 2]>,
    /// The stimulus's physical size in mm: width, height.
    pub stimulus_dimension_mm: Option<[f64; 2]>,
    /// The subject's distance from the screen in mm.
    pub head_distance_mm: Option<f64>,
    /// The subject (participant) the file names.
    pub subject: Option<String>,
    /// `dd.mm.yyyy HH:MM:SS` as written (the tracker PC's local time).
    pub date: Option<chrono::NaiveDateTime>,
    /// The exporting software's version, when written.
    pub version: Option<String>,
    /// `## Format:` items (LEFT, RIGHT, POR, …).
    pub format_items: Vec<String>,
    /// Positions are fractions of the screen (0–1, origin top-left), as Gazepoint and Pupil
    /// Labs surfaces give them: ingest scales them to pixels with the screen size it is given.
    pub normalized: bool,
}

/// Where the first row with a problem was, so a user can look at it.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FirstSeen {
    /// How many lines had this problem.
    pub count: usize,
    /// 1-based line of the first.
    pub line: usize,
    /// 1-based column of the first.
    pub column: usize,
    /// The first such line (up to 120 characters).
    pub example: String,
}

/// Every line of the file, accounted for.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct RowAccount {
    /// Lines in the file.
    pub lines: usize,
    /// Header lines (column names, `##` blocks, `key: value` lines).
    pub header_lines: usize,
    /// Empty lines.
    pub blank_lines: usize,
    /// Lines read as samples.
    pub samples: usize,
    /// Lines read as messages.
    pub messages: usize,
    /// Lines read as events.
    pub events: usize,
    /// Lines that could not be used, by reason (with the first one's position).
    pub unusable: BTreeMap<String, FirstSeen>,
}

impl RowAccount {
    /// Counts one unusable line under `reason`, remembering the first one's place.
    pub fn reject(&mut self, reason: &str, line: usize, column: usize, example: &str) {
        // A reason seen before only counts: no copy of its text or example (files where every
        // tenth row is another sensor's would copy both on each).
        if let Some(e) = self.unusable.get_mut(reason) {
            e.count += 1;
            return;
        }
        self.unusable.insert(
            reason.to_string(),
            FirstSeen {
                count: 1,
                line,
                column,
                example: example.chars().take(120).collect(),
            },
        );
    }

    /// Unusable lines, every reason together.
    pub fn unusable_total(&self) -> usize {
        self.unusable.values().map(|f| f.count).sum()
    }

    /// Lines accounted for: must equal `lines`.
    pub fn accounted(&self) -> usize {
        self.header_lines
            + self.blank_lines
            + self.samples
            + self.messages
            + self.events
            + self.unusable_total()
    }
}

/// One recording file, read: its format, header, samples, messages and events, and an account
/// of every line.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recording {
    /// The file, as named to the reader.
    pub file: String,
    /// The format it was read as (detected from content, or forced).
    pub format: GazeFormat,
    /// Its header facts.
    pub header: Header,
    /// Column names of the sample table, or of each event table.
    pub columns: Vec<String>,
    /// Every sample row, in file order.
    pub samples: Vec<Sample>,
    /// Every message, in file order.
    pub messages: Vec<Message>,
    /// The exporter's events (fixations, saccades, blinks), in file order.
    pub events: Vec<Event>,
    /// Every line of the file, accounted for.
    pub rows: RowAccount,
    /// Format quirks met (e.g. "fields separated by runs of spaces").
    pub notes: Vec<String>,
}

/// Why recordings could not be read or ingested: the gaze stage's one error. A reader's error
/// names the file and, where one line is at fault, its line and column.
#[derive(Debug, thiserror::Error)]
pub enum GazeError {
    /// The file could not be read.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        error: std::io::Error,
    },
    /// One place in the file is at fault.
    #[error("{path}:{line}:{column}: {message}")]
    At {
        /// The file.
        path: String,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong there.
        message: String,
    },
    /// The file as a whole cannot be used (not a known export, no gaze positions, no screen
    /// size for screen fractions, an eye it does not have); the message says what to do.
    #[error("{path}: {message}")]
    File {
        /// The file.
        path: String,
        /// Why, and what to do.
        message: String,
    },
    /// A row of a table meshgaze wrote (fixations.csv) cannot be read back.
    #[error("{path}:{line}: {message}")]
    Row {
        /// The table.
        path: String,
        /// 1-based line, the header being line 1.
        line: usize,
        /// Which column, and what is wrong.
        message: String,
    },
    /// An option cannot be used (a stimulus pattern that is not a regular expression, an
    /// unknown format name).
    #[error("{0}")]
    Invalid(String),
    /// No fixation could be found or detected in the file; the message names the file and the
    /// first unusable line, usually the reason.
    #[error("{0}")]
    NoFixations(String),
    /// Files that cannot be ingested together: they would count a subject's fixations twice.
    #[error("{0}")]
    Conflict(String),
    /// An output table or sidecar could not be written.
    #[error("cannot write {}: {error}", path.display())]
    Write {
        /// The file.
        path: std::path::PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// An output table could not be formatted (the CSV writer's error).
    #[error("{0}")]
    Table(String),
}

impl GazeError {
    /// A whole-file error on `path`.
    pub(crate) fn file(path: &std::path::Path, message: impl Into<String>) -> GazeError {
        GazeError::File {
            path: path.display().to_string(),
            message: message.into(),
        }
    }

    /// A formatting error of an output table.
    pub(crate) fn table(error: impl std::fmt::Display) -> GazeError {
        GazeError::Table(error.to_string())
    }
}

#[cfg(test)]
mod format_name_tests {
    use super::GazeFormat;

    #[test]
    fn every_format_has_one_short_name_that_parses_back() {
        let mut names: Vec<&str> = GazeFormat::ALL.iter().map(|f| f.short_name()).collect();
        for f in GazeFormat::ALL {
            assert_eq!(GazeFormat::from_short_name(f.short_name()).ok(), Some(f));
        }
        names.sort();
        names.dedup();
        assert_eq!(names.len(), GazeFormat::ALL.len());
        assert!(GazeFormat::from_short_name("smi")
            .unwrap_err()
            .to_string()
            .contains("eyelink"));
    }

    #[cfg(feature = "cli")]
    #[test]
    fn the_short_names_are_the_command_lines_and_all_lists_every_variant() {
        use clap::ValueEnum;
        assert_eq!(GazeFormat::value_variants().len(), GazeFormat::ALL.len());
        for f in GazeFormat::value_variants() {
            let clap_name = f.to_possible_value().unwrap().get_name().to_string();
            assert_eq!(clap_name, f.short_name());
        }
    }
}

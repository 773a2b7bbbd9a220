//! Ingest: from SMI export files to filtered fixations, classified messages and data quality,
//! one file at a time, with the checks that need several files (one source per subject and
//! stimulus). The writers put each table on disk as `meshgaze ingest` does.
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::fixation_table::{write_fixations_csv, FixationRow};
use super::fixations::{
    apply_protocol_filter, fixations, Detector, DetectorParams, EyePolicy, Fate, Fixation,
};
use super::quality::{quality, QualityRow};
use super::read_recording;
use super::recording::{EyeSample, GazeError, GazeFormat, Header, Recording, RowAccount};
use super::stimulus_messages::{
    classify_messages, ClassifiedMessage, Segmentation, StimulusPattern,
};
use super::validity::{apply_validity_rule, flag_counts, ValidityRule};
use crate::protocol::Protocol;
use crate::provenance::{InputFile, Provenance};

/// The protocol's fixation filter (paper §4: drop the first and last two, keep the 15 longest).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FilterRules {
    /// Fixations dropped at the start of each viewing.
    pub drop_first: usize,
    /// Fixations dropped at its end.
    pub drop_last: usize,
    /// Of the rest, the longest kept.
    pub keep_longest: usize,
}

/// Everything that decides how a file becomes fixations.
#[derive(Debug, Clone)]
pub struct IngestParams {
    /// Force a format instead of detecting it.
    pub format: Option<GazeFormat>,
    /// None: the exporter's events when the file has events and no samples, else I-DT.
    pub detector: Option<Detector>,
    /// Which eye's gaze fixations are computed from.
    pub eye: EyePolicy,
    /// Which samples count as tracked (the validity flag, the point of regard).
    pub validity: ValidityRule,
    /// Overrides the subject the file names.
    pub subject: Option<String>,
    /// The sample detectors' thresholds.
    pub detector_params: DetectorParams,
    /// The protocol's fixation filter.
    pub filter: FilterRules,
    /// Which messages start and end a stimulus, and its longest duration.
    pub segmentation: Segmentation,
    /// The screen in pixels for files whose positions are fractions of it (Gazepoint, Pupil
    /// Labs surfaces) and that do not say its size; None: such a file is refused.
    pub screen_px: Option<[f64; 2]>,
}

impl IngestParams {
    /// The protocol's detector settings, filter and stimulus rules; `pattern` (start, end)
    /// overrides the protocol's stimulus patterns.
    pub fn from_protocol(
        protocol: &crate::protocol::Protocol,
        pattern: Option<(&str, Option<&str>)>,
    ) -> Result<IngestParams, GazeError> {
        let rules = &protocol.fixations;
        let (start, end) = match pattern {
            Some((s, e)) => (Some(s), e),
            None => (
                rules.stimulus_pattern.as_deref(),
                rules.stimulus_end_pattern.as_deref(),
            ),
        };
        let pattern = start.map(|p| StimulusPattern::new(p, end)).transpose()?;
        Ok(IngestParams {
            format: None,
            detector: None,
            eye: EyePolicy::Best,
            validity: ValidityRule::Auto,
            subject: None,
            detector_params: DetectorParams {
                max_dispersion_px: rules.idt_max_dispersion_px,
                min_duration_ms: rules.min_duration_ms,
                max_velocity_px_s: rules.ivt_max_velocity_deg_s
                    * protocol.display.pixels_per_degree(),
                ..DetectorParams::default()
            },
            filter: FilterRules {
                drop_first: rules.drop_first,
                drop_last: rules.drop_last,
                keep_longest: rules.keep_longest,
            },
            segmentation: Segmentation {
                pattern,
                max_duration_us: Some((protocol.duration_s() * 1e6).round() as i64),
            },
            screen_px: Some([
                protocol.display.width_px as f64,
                protocol.display.height_px as f64,
            ]),
        })
    }
}

/// One file, ingested.
pub struct IngestedFile {
    /// The file.
    pub path: PathBuf,
    /// What it holds, as read.
    pub recording: Recording,
    /// The file's subject (format B files naming several participants give each fixation
    /// its own).
    pub subject: String,
    /// Where its fixations came from.
    pub detector: Detector,
    /// Its fixations with their fates.
    pub fixations: Vec<Fixation>,
    /// Data quality per stimulus.
    pub quality: Vec<QualityRow>,
    /// Its messages, each with its kind.
    pub messages: Vec<ClassifiedMessage>,
    /// Things a user should know that do not stop the file (printed by the CLI).
    pub warnings: Vec<String>,
}

/// Turns a file's screen fractions into pixels of `screen` (the file's own size when it gives
/// one), and says so in its notes; a file of fractions without any screen size is refused.
fn scale_normalized_positions(
    rec: &mut Recording,
    screen: Option<[f64; 2]>,
    path: &Path,
) -> Result<(), GazeError> {
    if !rec.header.normalized {
        return Ok(());
    }
    let (size, from) = match (rec.header.calibration_area_px, screen) {
        (Some(s), _) => (s, "the file's screen size"),
        (None, Some(s)) => (s, "--screen, else the protocol's display"),
        (None, None) => {
            return Err(GazeError::file(
                path,
                "positions are fractions of the screen and the file does not say its size: give --screen WIDTHxHEIGHT",
            ))
        }
    };
    let [w, h] = size;
    let scale = |e: &mut Option<EyeSample>| {
        if let Some(e) = e.as_mut().filter(|e| e.valid || e.x != 0.0 || e.y != 0.0) {
            e.x *= w;
            e.y *= h;
        }
    };
    for s in &mut rec.samples {
        scale(&mut s.left);
        scale(&mut s.right);
        scale(&mut s.binocular);
    }
    for e in &mut rec.events {
        for (v, k) in [
            (&mut e.x, w),
            (&mut e.y, h),
            (&mut e.end_x, w),
            (&mut e.end_y, h),
        ] {
            if let Some(v) = v.as_mut() {
                *v *= k;
            }
        }
        for (v, k) in [(&mut e.dispersion_x, w), (&mut e.dispersion_y, h)] {
            if let Some(v) = v.as_mut() {
                *v *= k;
            }
        }
    }
    rec.header.calibration_area_px = Some(size);
    rec.header.normalized = false;
    rec.notes.push(format!(
        "positions are fractions of the screen: scaled to {w}x{h} px ({from})"
    ));
    Ok(())
}

/// The detector a file gets when none is asked for: the exporter's events when the file has
/// events and no samples, or is an event file (C1), or is an EyeLink or Tobii file with
/// fixation events (the tracker's own parser / I-VT filter, which is what its users report);
/// else I-DT on the samples.
pub fn default_detector(rec: &Recording) -> Detector {
    let tracker_parsed = matches!(
        rec.format,
        GazeFormat::EyelinkAsc
            | GazeFormat::TobiiProLab
            | GazeFormat::TobiiStudio
            | GazeFormat::TobiiStudioList
            | GazeFormat::Gazepoint
            | GazeFormat::PupilCore
            | GazeFormat::PupilCloud
    );
    let eyelink_fixations = tracker_parsed
        && rec
            .events
            .iter()
            .any(|e| e.kind == super::recording::EventKind::Fixation);
    if eyelink_fixations {
        return Detector::Events;
    }
    if !rec.events.is_empty() && (rec.samples.is_empty() || rec.format == GazeFormat::EventTables) {
        Detector::Events
    } else {
        Detector::IDt
    }
}

/// Fails when a sample detector would see no gaze position at all: every sample's point of
/// regard is 0.00 (exports of pupil and corneal reflex only).
fn check_gaze_present(rec: &Recording, path: &Path) -> Result<(), GazeError> {
    let has_position = |e: &Option<EyeSample>| e.is_some_and(|e| e.x != 0.0 || e.y != 0.0);
    let with_position = rec
        .samples
        .iter()
        .filter(|s| has_position(&s.left) || has_position(&s.right) || has_position(&s.binocular))
        .count();
    if !rec.samples.is_empty() && with_position == 0 {
        return Err(GazeError::file(path, format!(
            "the point of regard (POR X/Y) is 0.00 in all {} samples, so this export carries no gaze position (only pupil and corneal reflex data); no fixation can be found in it. Re-export the recording from BeGaze or IDF Converter with the POR columns selected (Format: POR), or give the exporter's fixation events instead",
            rec.samples.len()
        )));
    }
    Ok(())
}

/// Valid samples of the left eye, the right eye and a binocular stream.
fn valid_sample_counts(rec: &Recording) -> [usize; 3] {
    let valid = |e: &Option<EyeSample>| e.is_some_and(|e| e.valid);
    let mut n = [0; 3];
    for s in &rec.samples {
        n[0] += valid(&s.left) as usize;
        n[1] += valid(&s.right) as usize;
        n[2] += valid(&s.binocular) as usize;
    }
    n
}

/// Fails when `--eye left|right` names an eye with no valid sample, naming the eyes that have.
fn check_chosen_eye_has_samples(
    rec: &Recording,
    eye: EyePolicy,
    path: &Path,
) -> Result<(), GazeError> {
    let [l, r, b] = valid_sample_counts(rec);
    let (chosen, n) = match eye {
        EyePolicy::Left => ("left", l),
        EyePolicy::Right => ("right", r),
        _ => return Ok(()),
    };
    if n > 0 {
        return Ok(());
    }
    let present: Vec<String> = [("left", l), ("right", r), ("binocular", b)]
        .iter()
        .filter(|(_, n)| *n > 0)
        .map(|(e, n)| format!("{n} valid {e}-eye samples"))
        .collect();
    let has = if present.is_empty() {
        "no valid sample of any eye".to_string()
    } else {
        present.join(" and ")
    };
    Err(GazeError::file(
        path,
        format!(
            "--eye {chosen}: no valid {chosen}-eye sample; the file has {has} (leave --eye out to use the eye the file has)"
        ),
    ))
}

/// Why a file gave no kept fixation, when it gave none: the first cause in pipeline order
/// (no gaze, every sample lost and by which rule, no fixation events, none detected, every
/// fixation outside a stimulus or off screen, the protocol's filter). None when some are kept.
pub fn why_no_fixations(
    rec: &Recording,
    detector: Detector,
    params: &IngestParams,
    fixations: &[Fixation],
) -> Option<String> {
    if fixations.iter().any(|f| f.fate == Fate::Kept) {
        return None;
    }
    if detector == Detector::Events {
        let fixation_events = rec
            .events
            .iter()
            .filter(|e| e.kind == super::recording::EventKind::Fixation)
            .count();
        if fixation_events == 0 {
            return Some(format!(
                "the file's {} events hold no fixation (only saccades and blinks)",
                rec.events.len()
            ));
        }
    } else {
        let [l, r, b] = valid_sample_counts(rec);
        if l + r + b == 0 {
            let [fl, fr] = flag_counts(rec);
            let flagged = fl.flagged_lost_with_gaze + fr.flagged_lost_with_gaze;
            let rule = match params.validity {
                ValidityRule::Strict | ValidityRule::Auto if flagged > 0 => format!(
                    "the validity flag is 0 in every row ({flagged} of them with a gaze position; --validity por uses the position instead)"
                ),
                _ => "the point of regard is (0, 0) in every row, SMI's loss value".to_string(),
            };
            return Some(format!(
                "every one of the {} samples is lost: {rule}",
                rec.samples.len()
            ));
        }
        if fixations.is_empty() {
            let p = &params.detector_params;
            return Some(format!(
                "{:?} found no fixation in {} valid samples (dispersion at most {} px for at least {} ms)",
                detector,
                l.max(r).max(b),
                p.max_dispersion_px,
                p.min_duration_ms
            ));
        }
    }
    if fixations.is_empty() {
        return Some("no fixation of the chosen eye".to_string());
    }
    let mut invalid: BTreeMap<&str, usize> = BTreeMap::new();
    for f in fixations {
        if let Some(r) = f.invalid_reason {
            *invalid.entry(r).or_insert(0) += 1;
        }
    }
    let total_invalid: usize = invalid.values().sum();
    if total_invalid == fixations.len() {
        let list: Vec<String> = invalid.iter().map(|(r, n)| format!("{n} {r}")).collect();
        return Some(format!(
            "all {} fixations are unusable: {}",
            fixations.len(),
            list.join(", ")
        ));
    }
    let f = params.filter;
    Some(format!(
        "the protocol's filter kept none of the {} usable fixations (it drops each subject's first {} and last {} per stimulus, then keeps the {} longest)",
        fixations.len() - total_invalid,
        f.drop_first,
        f.drop_last,
        f.keep_longest
    ))
}

/// Reads one export, finds its fixations, applies the protocol's filter and measures quality.
pub fn ingest_file(path: &Path, params: &IngestParams) -> Result<IngestedFile, GazeError> {
    let mut rec = read_recording(path, params.format)?;
    scale_normalized_positions(&mut rec, params.screen_px, path)?;
    let validity_notes = apply_validity_rule(&mut rec, params.validity);
    rec.notes.extend(validity_notes);
    let subject = params
        .subject
        .clone()
        .or_else(|| rec.header.subject.clone())
        .unwrap_or_else(|| {
            path.file_stem()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string()
        });
    let detector = params.detector.unwrap_or_else(|| default_detector(&rec));
    let mut warnings = Vec::new();
    if detector != Detector::Events {
        check_gaze_present(&rec, path)?;
        check_chosen_eye_has_samples(&rec, params.eye, path)?;
        if let (Some(rate), Detector::IVt) = (rec.header.sample_rate_hz, detector) {
            if rate < 200.0 {
                warnings.push(format!(
                    "{}: I-VT at {rate} Hz: velocity detection needs 200 Hz or more",
                    path.display()
                ));
            }
        }
        let interval_ms = super::fixations::sample_interval_us(&rec) as f64 / 1000.0;
        if !rec.samples.is_empty() && params.detector_params.min_duration_ms < interval_ms {
            warnings.push(format!(
                "{}: the minimum fixation duration {} ms is shorter than one sample ({interval_ms:.1} ms)",
                path.display(),
                params.detector_params.min_duration_ms
            ));
        }
    }
    let mut fx = fixations(
        &rec,
        &subject,
        detector,
        params.eye,
        &params.detector_params,
        &params.segmentation,
    )
    .map_err(|e| {
        let e = match e {
            GazeError::NoFixations(message) => message,
            other => other.to_string(),
        };
        // Say why the rows were unusable: that is usually why nothing was found.
        let first = rec.rows.unusable.iter().min_by_key(|(_, f)| f.line);
        match first {
            Some((reason, f)) => GazeError::NoFixations(format!(
                "{e} ({} unusable lines; the first: {reason} at {}:{}:{})",
                rec.rows.unusable_total(),
                path.display(),
                f.line,
                f.column
            )),
            None => GazeError::NoFixations(e),
        }
    })?;
    let rules = params.filter;
    apply_protocol_filter(
        &mut fx,
        rules.drop_first,
        rules.drop_last,
        rules.keep_longest,
    );
    let quality = quality(&rec, &subject, &fx, params.eye);
    let messages = classify_messages(&rec, &params.segmentation);
    if let Some(why) = why_no_fixations(&rec, detector, params, &fx) {
        warnings.push(format!("{}: no fixations: {why}", path.display()));
    }
    Ok(IngestedFile {
        path: path.to_path_buf(),
        recording: rec,
        subject,
        detector,
        fixations: fx,
        quality,
        messages,
        warnings,
    })
}

/// Ingests `paths` in order, each hashed for provenance, then checks them against each other
/// (one source per subject and stimulus). The sequence `meshgaze ingest`, the demo and a
/// study share.
pub fn ingest_files(
    paths: &[PathBuf],
    params: &IngestParams,
) -> Result<(Vec<IngestedFile>, Vec<InputFile>), GazeError> {
    let mut files = Vec::new();
    let mut inputs = Vec::new();
    for path in paths {
        files.push(ingest_file(path, params)?);
        inputs.push(InputFile::hash(path).map_err(|error| GazeError::Io {
            path: path.display().to_string(),
            error,
        })?);
    }
    check_one_source_per_subject(&files)?;
    Ok((files, inputs))
}

/// Writes DIR (created) /fixations.csv, messages.csv, quality.csv and ingest.json; returns the
/// number of fixations written and ingest.json's path.
pub fn write_ingest(
    dir: &Path,
    files: &[IngestedFile],
    inputs: Vec<InputFile>,
    protocol: &Protocol,
    params: &IngestParams,
) -> Result<(usize, PathBuf), GazeError> {
    crate::file_bytes::create_output_dir(dir).map_err(|error| GazeError::Write {
        path: dir.to_path_buf(),
        error,
    })?;
    let fixations = write_ingest_tables(dir, files)?;
    let json = write_ingest_json(dir, files, inputs, protocol, params)?;
    Ok((fixations, json))
}

/// Refuses two files that are one recording (the same stimulus onsets at the same tracker
/// times: a sample export and an event export of it) or that give the same subject fixations
/// on the same stimulus: either would count that subject's fixations twice.
pub fn check_one_source_per_subject(files: &[IngestedFile]) -> Result<(), GazeError> {
    let mut onsets: BTreeMap<Vec<(&str, i64)>, &Path> = BTreeMap::new();
    for f in files {
        let list: Vec<(&str, i64)> = f
            .messages
            .iter()
            .filter_map(|m| m.stimulus.as_deref().map(|s| (s, m.time_us)))
            .collect();
        if list.is_empty() {
            continue;
        }
        let first = list[0];
        if let Some(other) = onsets.insert(list, &f.path) {
            return Err(GazeError::Conflict(format!(
                "{} and {} are one recording (the same stimulus onsets at the same tracker times, e.g. `{}` at {} µs): ingesting both would count its fixations twice (a sample export and an event export?). Give one of them",
                other.display(),
                f.path.display(),
                first.0,
                first.1
            )));
        }
    }
    let mut seen: BTreeMap<(&str, &str), &Path> = BTreeMap::new();
    for f in files {
        let mut pairs: Vec<(&str, &str)> = f
            .fixations
            .iter()
            .filter(|x| x.fate != Fate::Invalid)
            .map(|x| (x.subject.as_str(), x.stimulus.as_str()))
            .collect();
        pairs.sort();
        pairs.dedup();
        for key in pairs {
            if let Some(other) = seen.insert(key, &f.path) {
                if other != f.path {
                    return Err(GazeError::Conflict(format!(
                        "{} and {} both hold subject `{}` watching `{}`: ingesting both would count that subject's fixations twice (a sample export and an event export of one recording?). Give one file per subject and stimulus, or --subject to tell them apart",
                        other.display(),
                        f.path.display(),
                        key.0,
                        if key.1.is_empty() { "(no stimulus)" } else { key.1 }
                    )));
                }
            }
        }
    }
    Ok(())
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |x| format!("{x}"))
}

/// quality.csv: one row per subject and stimulus.
pub fn write_quality_csv(out: &mut impl Write, rows: &[QualityRow]) -> std::io::Result<()> {
    writeln!(out, "subject,stimulus,samples,lost_samples,lost_ms,loss_ratio,declared_rate_hz,measured_rate_hz,precision_rms_px,kept,dropped_first,dropped_last,not_longest,invalid")?;
    for r in rows {
        let n = |k: &str| r.fixations_by_fate.get(k).copied().unwrap_or(0);
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            r.subject,
            r.stimulus.replace(',', ";"),
            r.samples,
            r.lost_samples,
            r.lost_ms,
            r.loss_ratio,
            opt(r.declared_rate_hz),
            opt(r.measured_rate_hz),
            opt(r.precision_rms_px),
            n(Fate::Kept.name()),
            n(Fate::DroppedFirst.name()),
            n(Fate::DroppedLast.name()),
            n(Fate::NotLongest.name()),
            n(Fate::Invalid.name())
        )?;
    }
    Ok(())
}

/// The header of samples.csv.
pub const SAMPLES_CSV_HEADER: &str = "subject,time_us,trial,left_x,left_y,left_pupil,left_valid,right_x,right_y,right_pupil,right_valid";

/// Every sample of a recording, one row each, under [`SAMPLES_CSV_HEADER`].
pub fn write_samples_rows(
    out: &mut impl Write,
    subject: &str,
    rec: &Recording,
) -> std::io::Result<()> {
    let eye = |e: Option<EyeSample>| {
        e.map_or(",,,".to_string(), |e| {
            format!("{},{},{},{}", e.x, e.y, opt(e.pupil), e.valid as u8)
        })
    };
    for s in &rec.samples {
        writeln!(
            out,
            "{subject},{},{},{},{}",
            s.time_us,
            s.trial,
            eye(s.left),
            eye(s.right)
        )?;
    }
    Ok(())
}

/// messages.csv: every message of every file with its kind (RFC 4180 quoting: messages hold
/// commas and quotes).
pub fn write_messages_csv(out: impl Write, files: &[IngestedFile]) -> Result<(), GazeError> {
    let mut w = csv::Writer::from_writer(out);
    w.write_record([
        "file", "subject", "trial", "time_us", "kind", "stimulus", "text",
    ])
    .map_err(GazeError::table)?;
    for f in files {
        let file = f.path.display().to_string();
        for m in &f.messages {
            w.write_record([
                file.as_str(),
                f.subject.as_str(),
                &m.trial.to_string(),
                &m.time_us.to_string(),
                m.kind.name(),
                m.stimulus.as_deref().unwrap_or(""),
                m.text.as_str(),
            ])
            .map_err(GazeError::table)?;
        }
    }
    w.flush().map_err(GazeError::table)
}

/// Messages per kind, for ingest.json.
pub fn message_kind_counts(messages: &[ClassifiedMessage]) -> BTreeMap<&'static str, usize> {
    let mut counts = BTreeMap::new();
    for m in messages {
        *counts.entry(m.kind.name()).or_insert(0) += 1;
    }
    counts
}

#[derive(Serialize)]
struct IngestFileEntry {
    file: String,
    format: GazeFormat,
    subject: String,
    detector: Detector,
    header: Header,
    rows: RowAccount,
    notes: Vec<String>,
    messages: BTreeMap<&'static str, usize>,
    stimuli: Vec<String>,
    fixations: usize,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    warnings: Vec<String>,
}

#[derive(Serialize)]
struct IngestSidecar<'a> {
    provenance: Provenance,
    protocol: &'a str,
    drop_first: usize,
    drop_last: usize,
    keep_longest: usize,
    eye_policy: EyePolicy,
    validity: ValidityRule,
    detector_params: &'a DetectorParams,
    stimulus_pattern: Option<&'a str>,
    stimulus_end_pattern: Option<&'a str>,
    max_stimulus_s: f64,
    files: Vec<IngestFileEntry>,
}

/// The stimuli a file's fixations were made on, sorted.
pub fn stimuli_of(f: &IngestedFile) -> Vec<String> {
    let mut v: Vec<String> = f
        .fixations
        .iter()
        .filter(|x| !x.stimulus.is_empty())
        .map(|x| x.stimulus.clone())
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Writes DIR/ingest.json: provenance (`inputs`), the protocol's filter, the detector and
/// segmentation parameters, and per file its format, subject, header, row account, notes,
/// message kinds and stimuli. Returns its path.
pub fn write_ingest_json(
    dir: &Path,
    files: &[IngestedFile],
    inputs: Vec<InputFile>,
    protocol: &Protocol,
    params: &IngestParams,
) -> Result<PathBuf, GazeError> {
    let rules = &protocol.fixations;
    let sidecar = IngestSidecar {
        provenance: Provenance::new(inputs),
        protocol: &protocol.name,
        drop_first: rules.drop_first,
        drop_last: rules.drop_last,
        keep_longest: rules.keep_longest,
        eye_policy: params.eye,
        validity: params.validity,
        detector_params: &params.detector_params,
        stimulus_pattern: params
            .segmentation
            .pattern
            .as_ref()
            .map(|p| p.start.as_str()),
        stimulus_end_pattern: params
            .segmentation
            .pattern
            .as_ref()
            .and_then(|p| p.end.as_ref())
            .map(|e| e.as_str()),
        max_stimulus_s: protocol.duration_s(),
        files: files
            .iter()
            .map(|f| IngestFileEntry {
                file: f.path.display().to_string(),
                format: f.recording.format,
                subject: f.subject.clone(),
                detector: f.detector,
                header: f.recording.header.clone(),
                rows: f.recording.rows.clone(),
                notes: f.recording.notes.clone(),
                messages: message_kind_counts(&f.messages),
                stimuli: stimuli_of(f),
                fixations: f.fixations.len(),
                warnings: f.warnings.clone(),
            })
            .collect(),
    };
    let j = dir.join("ingest.json");
    let text = serde_json::to_string_pretty(&sidecar).map_err(GazeError::table)? + "\n";
    std::fs::write(&j, text).map_err(|error| GazeError::Write {
        path: j.clone(),
        error,
    })?;
    Ok(j)
}

/// The three tables `meshgaze ingest` writes, as CSV text: what the files hold and what the
/// Python package turns into DataFrames, so both read the same bytes.
pub struct IngestTables {
    /// fixations.csv.
    pub fixations: String,
    /// messages.csv.
    pub messages: String,
    /// quality.csv.
    pub quality: String,
    /// Rows of fixations.csv.
    pub fixation_count: usize,
}

/// fixations.csv, messages.csv and quality.csv of `files`, in memory.
pub fn ingest_tables(files: &[IngestedFile]) -> Result<IngestTables, GazeError> {
    let text = |bytes: Vec<u8>| String::from_utf8(bytes).map_err(GazeError::table);
    let rows: Vec<FixationRow> = files
        .iter()
        .flat_map(|f| f.fixations.iter().map(FixationRow::from))
        .collect();
    let mut fixations = Vec::new();
    write_fixations_csv(&mut fixations, &rows)?;
    let mut messages = Vec::new();
    write_messages_csv(&mut messages, files)?;
    let quality_rows: Vec<QualityRow> = files
        .iter()
        .flat_map(|f| f.quality.iter().cloned())
        .collect();
    let mut quality = Vec::new();
    write_quality_csv(&mut quality, &quality_rows).map_err(GazeError::table)?;
    Ok(IngestTables {
        fixations: text(fixations)?,
        messages: text(messages)?,
        quality: text(quality)?,
        fixation_count: rows.len(),
    })
}

/// samples.csv of `files`: the header, then every sample of every file.
pub fn write_samples_csv(out: &mut impl Write, files: &[IngestedFile]) -> std::io::Result<()> {
    writeln!(out, "{SAMPLES_CSV_HEADER}")?;
    for f in files {
        write_samples_rows(out, &f.subject, &f.recording)?;
    }
    Ok(())
}

/// Writes fixations.csv, messages.csv and quality.csv of `files` into `dir`; returns the
/// number of fixations.
pub fn write_ingest_tables(dir: &Path, files: &[IngestedFile]) -> Result<usize, GazeError> {
    let tables = ingest_tables(files)?;
    for (name, text) in [
        ("fixations.csv", &tables.fixations),
        ("messages.csv", &tables.messages),
        ("quality.csv", &tables.quality),
    ] {
        let p = dir.join(name);
        std::fs::write(&p, text).map_err(|error| GazeError::Write { path: p, error })?;
    }
    Ok(tables.fixation_count)
}

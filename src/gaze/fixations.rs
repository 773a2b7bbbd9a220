//! Fixations from an SMI recording: as the event export recorded them, or detected from
//! samples (I-DT dispersion or I-VT velocity), split by stimulus using the messages, then
//! filtered as the protocol says (drop the first and last N, keep the K longest). Every
//! fixation keeps its fate; none disappears.
use serde::{Deserialize, Serialize};

use super::recording::{EventKind, Eye, EyeSample, GazeError, Recording, Sample};
use super::stimulus_messages::{
    classify_messages, place, stimulus_segments, Placement, Segmentation, StimulusSegment,
};

/// Which eye's gaze a fixation is computed from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum EyePolicy {
    /// The left eye.
    Left,
    /// The right eye.
    Right,
    /// Mean of the valid eyes (one eye when the other is lost).
    Average,
    /// The eye with more valid samples in the recording.
    Best,
}

/// Where fixations come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Detector {
    /// Use the fixation events of an event export.
    Events,
    /// Dispersion threshold (Salvucci & Goldberg 2000), SMI's low-speed detector.
    IDt,
    /// Velocity threshold, for high sample rates (≥ 200 Hz).
    IVt,
}

/// The sample detectors' thresholds.
#[derive(Debug, Clone, Serialize)]
pub struct DetectorParams {
    /// I-DT: largest (max x − min x) + (max y − min y) in pixels (SMI default 100 px).
    pub max_dispersion_px: f64,
    /// Shortest fixation (SMI's low-speed default 80 ms).
    pub min_duration_ms: f64,
    /// I-VT: sample-to-sample speed below which gaze is fixating, in pixels per second.
    pub max_velocity_px_s: f64,
    /// A gap between valid samples longer than this ends a fixation.
    pub max_gap_ms: f64,
}

impl Default for DetectorParams {
    fn default() -> Self {
        DetectorParams {
            max_dispersion_px: 100.0,
            min_duration_ms: 80.0,
            max_velocity_px_s: 1000.0,
            max_gap_ms: 75.0,
        }
    }
}

/// What the protocol's filter did with a fixation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, PartialOrd, Ord)]
#[serde(rename_all = "kebab-case")]
pub enum Fate {
    /// Kept: it counts in the ground truth.
    Kept,
    /// Among the first `drop_first` of the subject's viewing.
    DroppedFirst,
    /// Among the last `drop_last`.
    DroppedLast,
    /// Not among the `keep_longest` longest of the rest.
    NotLongest,
    /// No position, or a position off the calibrated screen.
    Invalid,
}

impl Fate {
    /// The name fixations.csv writes (`kept`, `dropped-first`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Fate::Kept => "kept",
            Fate::DroppedFirst => "dropped-first",
            Fate::DroppedLast => "dropped-last",
            Fate::NotLongest => "not-longest",
            Fate::Invalid => "invalid",
        }
    }
}

/// One fixation of one subject on one stimulus, with its fate.
#[derive(Debug, Clone, Serialize)]
pub struct Fixation {
    /// The subject's id.
    pub subject: String,
    /// The stimulus it was made on (empty: outside every stimulus).
    pub stimulus: String,
    /// Which eye(s): `left`, `right`, `average` or `binocular`.
    pub eye: &'static str,
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
    /// (max x − min x) + (max y − min y) of its samples, or the export's X + Y dispersion.
    pub dispersion_px: Option<f64>,
    /// Pupil size (its samples' mean, or the export's), in the file's unit.
    pub pupil: Option<f64>,
    /// What the protocol's filter did with it.
    pub fate: Fate,
    /// Microsecond offset of the fixation's start from its stimulus onset message.
    pub onset_offset_us: Option<i64>,
    /// Why the fate is `invalid`.
    pub invalid_reason: Option<&'static str>,
}

fn eye_name(e: Eye) -> &'static str {
    match e {
        Eye::Left => "left",
        Eye::Right => "right",
        Eye::Binocular => "binocular",
    }
}

/// The gaze of one sample under the policy, if valid.
fn gaze(s: &Sample, policy: EyePolicy) -> Option<EyeSample> {
    let ok = |e: Option<EyeSample>| e.filter(|e| e.valid);
    match policy {
        EyePolicy::Left => ok(s.left),
        EyePolicy::Right => ok(s.right),
        EyePolicy::Average | EyePolicy::Best => match (ok(s.left), ok(s.right)) {
            (None, None) => ok(s.binocular),
            (Some(l), Some(r)) => Some(EyeSample {
                x: 0.5 * (l.x + r.x),
                y: 0.5 * (l.y + r.y),
                pupil: match (l.pupil, r.pupil) {
                    (Some(a), Some(b)) => Some(0.5 * (a + b)),
                    (a, b) => a.or(b),
                },
                valid: true,
                flag_lost: false,
            }),
            (l, r) => l.or(r),
        },
    }
}

/// Resolves `Best` to the eye with more valid samples.
pub fn resolve_policy(rec: &Recording, policy: EyePolicy) -> EyePolicy {
    if policy != EyePolicy::Best {
        return policy;
    }
    let count = |f: fn(&Sample) -> Option<EyeSample>| {
        rec.samples
            .iter()
            .filter(|s| f(s).is_some_and(|e| e.valid))
            .count()
    };
    let (l, r) = (count(|s| s.left), count(|s| s.right));
    if l == 0 && r == 0 {
        EyePolicy::Average // only a binocular point (C2), or nothing valid
    } else if l >= r {
        EyePolicy::Left
    } else {
        EyePolicy::Right
    }
}

struct Raw {
    /// The stimulus the export itself names (format B), which then wins over messages.
    stimulus: Option<String>,
    /// That stimulus's onset on the event clock (None: times count from the onset).
    stimulus_onset_us: Option<i64>,
    /// The participant the export names (format B), which then wins over the subject.
    participant: Option<String>,
    trial: u32,
    start_us: i64,
    end_us: i64,
    x: f64,
    y: f64,
    dispersion: Option<f64>,
    pupil: Option<f64>,
}

fn summarize(points: &[(i64, EyeSample)], trial: u32, sample_us: i64) -> Raw {
    let n = points.len() as f64;
    let (mut sx, mut sy) = (0.0, 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    let mut pupils = Vec::new();
    for (_, e) in points {
        sx += e.x;
        sy += e.y;
        x0 = x0.min(e.x);
        x1 = x1.max(e.x);
        y0 = y0.min(e.y);
        y1 = y1.max(e.y);
        pupils.extend(e.pupil);
    }
    Raw {
        stimulus: None,
        stimulus_onset_us: None,
        participant: None,
        trial,
        start_us: points[0].0,
        // A sample stands for the interval up to the next one.
        end_us: points[points.len() - 1].0 + sample_us,
        x: sx / n,
        y: sy / n,
        dispersion: Some((x1 - x0) + (y1 - y0)),
        pupil: (!pupils.is_empty()).then(|| pupils.iter().sum::<f64>() / pupils.len() as f64),
    }
}

fn dispersion(points: &[(i64, EyeSample)]) -> f64 {
    let (mut x0, mut x1, mut y0, mut y1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for (_, e) in points {
        x0 = x0.min(e.x);
        x1 = x1.max(e.x);
        y0 = y0.min(e.y);
        y1 = y1.max(e.y);
    }
    (x1 - x0) + (y1 - y0)
}

/// Runs of valid gaze samples without gaps longer than `max_gap_us`, per trial.
fn runs(rec: &Recording, policy: EyePolicy, max_gap_us: i64) -> Vec<(u32, Vec<(i64, EyeSample)>)> {
    let mut out: Vec<(u32, Vec<(i64, EyeSample)>)> = Vec::new();
    let mut current: Vec<(i64, EyeSample)> = Vec::new();
    let mut trial = 0;
    for s in &rec.samples {
        match gaze(s, policy) {
            Some(g) => {
                let breaks = current
                    .last()
                    .is_some_and(|(t, _)| s.time_us - t > max_gap_us)
                    || s.trial != trial;
                if breaks && !current.is_empty() {
                    out.push((trial, std::mem::take(&mut current)));
                }
                trial = s.trial;
                current.push((s.time_us, g));
            }
            None => {
                if !current.is_empty() {
                    out.push((trial, std::mem::take(&mut current)));
                }
            }
        }
    }
    if !current.is_empty() {
        out.push((trial, current));
    }
    out
}

/// Median spacing of samples in µs (the measured rate), or the declared rate's.
pub fn sample_interval_us(rec: &Recording) -> i64 {
    let mut d: Vec<i64> = rec
        .samples
        .windows(2)
        .map(|w| w[1].time_us - w[0].time_us)
        .filter(|d| *d > 0)
        .collect();
    if d.is_empty() {
        return rec
            .header
            .sample_rate_hz
            .map_or(4000, |r| (1e6 / r).round() as i64);
    }
    d.sort_unstable();
    d[d.len() / 2]
}

fn detect_idt(rec: &Recording, policy: EyePolicy, p: &DetectorParams) -> Vec<Raw> {
    let dt = sample_interval_us(rec);
    let min_us = (p.min_duration_ms * 1000.0) as i64;
    let mut out = Vec::new();
    for (trial, run) in runs(rec, policy, (p.max_gap_ms * 1000.0) as i64) {
        let mut i = 0;
        while i < run.len() {
            // Smallest window covering the minimum duration.
            let mut j = i;
            while j < run.len() && run[j].0 + dt - run[i].0 < min_us {
                j += 1;
            }
            if j >= run.len() {
                break;
            }
            if dispersion(&run[i..=j]) <= p.max_dispersion_px {
                while j + 1 < run.len() && dispersion(&run[i..=j + 1]) <= p.max_dispersion_px {
                    j += 1;
                }
                out.push(summarize(&run[i..=j], trial, dt));
                i = j + 1;
            } else {
                i += 1;
            }
        }
    }
    out
}

fn detect_ivt(rec: &Recording, policy: EyePolicy, p: &DetectorParams) -> Vec<Raw> {
    let dt = sample_interval_us(rec);
    let min_us = (p.min_duration_ms * 1000.0) as i64;
    let mut out = Vec::new();
    for (trial, run) in runs(rec, policy, (p.max_gap_ms * 1000.0) as i64) {
        let mut start = 0;
        for k in 1..=run.len() {
            let slow = k < run.len() && {
                let (t0, a) = run[k - 1];
                let (t1, b) = run[k];
                let v = ((b.x - a.x).powi(2) + (b.y - a.y).powi(2)).sqrt()
                    / ((t1 - t0).max(1) as f64 * 1e-6);
                v <= p.max_velocity_px_s
            };
            if !slow {
                let seg = &run[start..k];
                if !seg.is_empty() && seg[seg.len() - 1].0 + dt - seg[0].0 >= min_us {
                    out.push(summarize(seg, trial, dt));
                }
                start = k;
            }
        }
    }
    out
}

/// The name of a stretch of recording that no stimulus message covers: `trialN` when the
/// recording has several trials (each recording restart is a trial), else `recording`.
fn unnamed_stimulus(rec: &Recording, trial: u32) -> String {
    let several_trials = rec
        .samples
        .iter()
        .map(|s| s.trial)
        .chain(rec.events.iter().map(|e| e.trial))
        .any(|tr| tr != trial);
    if several_trials {
        format!("trial{trial}")
    } else {
        "recording".to_string()
    }
}

/// Why a fixation is invalid from where it falls among the stimuli, or None when it falls
/// inside one: (stimulus, onset, reason).
fn stimulus_of(
    rec: &Recording,
    segments: &[StimulusSegment],
    trial: u32,
    t: i64,
) -> (String, Option<i64>, Option<&'static str>) {
    if !segments.iter().any(|s| s.trial == trial) {
        return (unnamed_stimulus(rec, trial), None, None);
    }
    match place(segments, trial, t) {
        Placement::Inside(s) => (s.name.clone(), Some(s.onset_us), None),
        Placement::AfterEnd(s) => (
            s.name.clone(),
            Some(s.onset_us),
            Some(if s.ended_by == "duration" {
                "after the stimulus ended (the protocol's stimulus length)"
            } else {
                "after the stimulus ended (end message)"
            }),
        ),
        Placement::BeforeFirstOnset => (
            String::new(),
            None,
            Some("before the first stimulus onset of its trial"),
        ),
    }
}

/// The eye stream whose fixation events are used. A chosen eye the file has is used; an
/// export with only a binocular stream (BeGaze) uses it whatever the policy; without a choice
/// (`Best`, `Average`) the left eye when present, else the eye the file has (monocular
/// right-eye exports); a chosen eye the file lacks is an error naming the eyes it has.
fn event_eye(rec: &Recording, policy: EyePolicy) -> Result<Eye, String> {
    let count = |eye: Eye| {
        rec.events
            .iter()
            .filter(|e| e.kind == EventKind::Fixation && e.eye == eye)
            .count()
    };
    let preferred = match policy {
        EyePolicy::Right => Eye::Right,
        _ => Eye::Left,
    };
    if count(preferred) > 0 {
        return Ok(preferred);
    }
    if count(Eye::Binocular) > 0 {
        return Ok(Eye::Binocular);
    }
    let present: Vec<(Eye, usize)> = [Eye::Left, Eye::Right]
        .into_iter()
        .map(|e| (e, count(e)))
        .filter(|(_, n)| *n > 0)
        .collect();
    match (policy, present.first()) {
        (EyePolicy::Left | EyePolicy::Right, Some(_)) => Err(format!(
            "{}: no {} fixation events; the file has {} (use --eye {}, or leave --eye out to use the eye the file has)",
            rec.file,
            eye_name(preferred),
            present
                .iter()
                .map(|(e, n)| format!("{n} {} fixation events", eye_name(*e)))
                .collect::<Vec<_>>()
                .join(" and "),
            eye_name(present[0].0)
        )),
        (_, Some(&(eye, _))) => Ok(eye),
        // No fixation event at all: none is found, and ingest says why.
        (_, None) => Ok(preferred),
    }
}

/// All fixations of a recording, before filtering (fate Kept or Invalid).
pub fn fixations(
    rec: &Recording,
    subject: &str,
    detector: Detector,
    policy: EyePolicy,
    params: &DetectorParams,
    segmentation: &Segmentation,
) -> Result<Vec<Fixation>, GazeError> {
    let policy = resolve_policy(rec, policy);
    let segments = stimulus_segments(&classify_messages(rec, segmentation), segmentation);
    let (raw, eye): (Vec<Raw>, &'static str) = match detector {
        Detector::Events => {
            if rec.events.is_empty() {
                return Err(GazeError::NoFixations(format!(
                    "{}: no events: use --detector i-dt or i-vt on a sample file",
                    rec.file
                )));
            }
            let want = event_eye(rec, policy).map_err(GazeError::NoFixations)?;
            let raw = rec
                .events
                .iter()
                .filter(|e| e.kind == EventKind::Fixation && e.eye == want)
                .map(|e| Raw {
                    stimulus: e.stimulus.clone(),
                    stimulus_onset_us: e.stimulus_onset_us,
                    participant: e.participant.clone(),
                    trial: e.trial,
                    start_us: e.start_us,
                    end_us: e.end_us,
                    x: e.x.unwrap_or(f64::NAN),
                    y: e.y.unwrap_or(f64::NAN),
                    dispersion: match (e.dispersion_x, e.dispersion_y) {
                        (Some(a), Some(b)) => Some(a + b),
                        _ => None,
                    },
                    pupil: match (e.pupil_x, e.pupil_y) {
                        (Some(a), Some(b)) => Some(0.5 * (a + b)),
                        (a, b) => a.or(b),
                    },
                })
                .collect();
            (raw, eye_name(want))
        }
        Detector::IDt | Detector::IVt => {
            if rec.samples.is_empty() {
                return Err(GazeError::NoFixations(format!(
                    "{}: no samples to detect fixations in",
                    rec.file
                )));
            }
            let raw = if detector == Detector::IDt {
                detect_idt(rec, policy, params)
            } else {
                detect_ivt(rec, policy, params)
            };
            let eye = match policy {
                EyePolicy::Left => "left",
                EyePolicy::Right => "right",
                _ => "average",
            };
            (raw, eye)
        }
    };
    let area = rec.header.calibration_area_px;
    Ok(raw
        .into_iter()
        .map(|r| {
            // Format B times count from the trial's (stimulus's) start: the offset is the time.
            let (stimulus, onset, outside) = match &r.stimulus {
                Some(s) => {
                    let onset = r.stimulus_onset_us.unwrap_or(0);
                    let late = segmentation
                        .max_duration_us
                        .is_some_and(|d| r.start_us - onset >= d)
                        .then_some("after the stimulus ended (the protocol's stimulus length)");
                    (s.clone(), Some(onset), late)
                }
                None => stimulus_of(rec, &segments, r.trial, r.start_us),
            };
            let on_screen = r.x.is_finite()
                && r.y.is_finite()
                && area.is_none_or(|[w, h]| (0.0..=w).contains(&r.x) && (0.0..=h).contains(&r.y));
            let invalid_reason = outside.or((!on_screen).then_some(
                if r.x.is_finite() && r.y.is_finite() {
                    "off the calibrated screen"
                } else {
                    "no gaze position"
                },
            ));
            Fixation {
                subject: r.participant.clone().unwrap_or_else(|| subject.to_string()),
                stimulus,
                eye,
                trial: r.trial,
                start_us: r.start_us,
                end_us: r.end_us,
                duration_ms: (r.end_us - r.start_us) as f64 / 1000.0,
                x_px: r.x,
                y_px: r.y,
                dispersion_px: r.dispersion,
                pupil: r.pupil,
                fate: if invalid_reason.is_none() {
                    Fate::Kept
                } else {
                    Fate::Invalid
                },
                invalid_reason,
                onset_offset_us: onset.map(|o| r.start_us - o),
            }
        })
        .collect())
}

/// The protocol's filter, per (subject, stimulus): in time order drop the first `drop_first`
/// and last `drop_last` valid fixations, then keep the `keep_longest` longest (ties: earlier
/// start first). Invalid fixations keep their fate and are not counted.
pub fn apply_protocol_filter(
    fixations: &mut [Fixation],
    drop_first: usize,
    drop_last: usize,
    keep_longest: usize,
) {
    let mut groups: std::collections::BTreeMap<(String, String), Vec<usize>> = Default::default();
    for (i, f) in fixations.iter().enumerate() {
        if f.fate != Fate::Invalid {
            groups
                .entry((f.subject.clone(), f.stimulus.clone()))
                .or_default()
                .push(i);
        }
    }
    for idx in groups.values_mut() {
        idx.sort_by_key(|&i| (fixations[i].start_us, i));
        let n = idx.len();
        for (k, &i) in idx.iter().enumerate() {
            fixations[i].fate = if k < drop_first {
                Fate::DroppedFirst
            } else if k >= n.saturating_sub(drop_last) {
                Fate::DroppedLast
            } else {
                Fate::NotLongest
            };
        }
        let mut middle: Vec<usize> = idx
            .iter()
            .copied()
            .filter(|&i| fixations[i].fate == Fate::NotLongest)
            .collect();
        middle.sort_by(|&a, &b| {
            fixations[b]
                .duration_ms
                .total_cmp(&fixations[a].duration_ms)
                .then(fixations[a].start_us.cmp(&fixations[b].start_us))
        });
        for &i in middle.iter().take(keep_longest) {
            fixations[i].fate = Fate::Kept;
        }
    }
}

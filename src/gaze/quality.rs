//! Data quality per subject and stimulus: samples, data loss, measured against declared
//! sample rate, precision (RMS sample-to-sample distance inside kept fixations), fixations
//! by fate.
use std::collections::BTreeMap;

use serde::Serialize;

use super::fixations::{resolve_policy, sample_interval_us, EyePolicy, Fate, Fixation};
use super::recording::Recording;

/// Data quality of one subject's viewing of one stimulus (a row of quality.csv).
#[derive(Debug, Clone, Serialize)]
pub struct QualityRow {
    /// The subject's id.
    pub subject: String,
    /// The stimulus (`recording` for time outside every stimulus).
    pub stimulus: String,
    /// Samples in the viewing.
    pub samples: usize,
    /// Samples without a valid eye the policy uses (the chosen eye; either eye for `average`
    /// and `best`).
    pub lost_samples: usize,
    /// Time lost, ms.
    pub lost_ms: f64,
    /// `lost_samples / samples`.
    pub loss_ratio: f64,
    /// The sample rate the file states.
    pub declared_rate_hz: Option<f64>,
    /// The sample rate measured from the time stamps.
    pub measured_rate_hz: Option<f64>,
    /// RMS distance between successive samples inside kept fixations (px); None without
    /// samples.
    pub precision_rms_px: Option<f64>,
    /// Fixations by the filter's fate.
    pub fixations_by_fate: BTreeMap<&'static str, usize>,
}

/// One row per stimulus the recording shows (from its messages), plus fixation counts.
pub fn quality(
    rec: &Recording,
    subject: &str,
    fixations: &[Fixation],
    policy: EyePolicy,
) -> Vec<QualityRow> {
    let policy = resolve_policy(rec, policy);
    let dt = sample_interval_us(rec);
    let mut rows: BTreeMap<String, QualityRow> = BTreeMap::new();
    let new_row = |stimulus: &str| QualityRow {
        subject: subject.to_string(),
        stimulus: stimulus.to_string(),
        samples: 0,
        lost_samples: 0,
        lost_ms: 0.0,
        loss_ratio: 0.0,
        declared_rate_hz: rec.header.sample_rate_hz,
        measured_rate_hz: (!rec.samples.is_empty()).then(|| 1e6 / dt as f64),
        precision_rms_px: None,
        fixations_by_fate: BTreeMap::new(),
    };
    // Stimulus onsets in time order, per trial.
    let mut onsets: Vec<(u32, i64, &str)> = rec
        .messages
        .iter()
        .filter(|m| !m.text.starts_with("UE-"))
        .map(|m| (m.trial, m.time_us, m.text.as_str()))
        .collect();
    onsets.sort();
    let stimulus_of = |trial: u32, t: i64| -> &str {
        onsets
            .iter()
            .rev()
            .find(|(tr, time, _)| *tr == trial && *time <= t)
            .map_or("recording", |o| o.2)
    };
    for s in &rec.samples {
        let name = stimulus_of(s.trial, s.time_us);
        let r = rows
            .entry(name.to_string())
            .or_insert_with(|| new_row(name));
        r.samples += 1;
        let valid = match policy {
            EyePolicy::Left => s.left.is_some_and(|e| e.valid),
            EyePolicy::Right => s.right.is_some_and(|e| e.valid),
            _ => s.left.is_some_and(|e| e.valid) || s.right.is_some_and(|e| e.valid),
        };
        if !valid {
            r.lost_samples += 1;
            r.lost_ms += dt as f64 / 1000.0;
        }
    }
    for f in fixations {
        let r = rows
            .entry(f.stimulus.clone())
            .or_insert_with(|| new_row(&f.stimulus));
        *r.fixations_by_fate.entry(f.fate.name()).or_insert(0) += 1;
    }
    // Precision inside kept fixations.
    let mut sums: BTreeMap<String, (f64, usize)> = BTreeMap::new();
    if !rec.samples.is_empty() {
        for f in fixations.iter().filter(|f| f.fate == Fate::Kept) {
            let pts: Vec<(f64, f64)> = rec
                .samples
                .iter()
                .filter(|s| s.time_us >= f.start_us && s.time_us < f.end_us)
                .filter_map(|s| {
                    let e = match policy {
                        EyePolicy::Right => s.right,
                        _ => s.left.filter(|e| e.valid).or(s.right),
                    }?;
                    e.valid.then_some((e.x, e.y))
                })
                .collect();
            let e = sums.entry(f.stimulus.clone()).or_insert((0.0, 0));
            for w in pts.windows(2) {
                e.0 += (w[1].0 - w[0].0).powi(2) + (w[1].1 - w[0].1).powi(2);
                e.1 += 1;
            }
        }
    }
    for (name, (sum, n)) in sums {
        if let Some(r) = rows.get_mut(&name) {
            r.precision_rms_px = (n > 0).then(|| (sum / n as f64).sqrt());
        }
    }
    rows.into_values()
        .map(|mut r| {
            r.loss_ratio = if r.samples > 0 {
                r.lost_samples as f64 / r.samples as f64
            } else {
                0.0
            };
            r
        })
        .collect()
}

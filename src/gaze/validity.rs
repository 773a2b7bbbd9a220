//! Which samples count as tracked. SMI marks loss two ways: a per-eye validity flag of 0, and a
//! point of regard of exactly (0, 0). Some exports (seen in iView X files of 500 Hz RED-class
//! trackers) write a flag of 0 in every row while the point of regard moves like gaze: there the
//! flag is not a loss flag, and honouring it would throw away the whole recording.
use serde::{Deserialize, Serialize};

use super::recording::{EyeSample, Recording};

/// How a sample's validity is decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum ValidityRule {
    /// The flag and the point of regard, except for an eye whose flag is 0 in every row while
    /// its point of regard is non-zero in some: that flag is set aside (said in the notes).
    #[default]
    Auto,
    /// The flag and the point of regard, always (lost if either says lost).
    Strict,
    /// The point of regard only: lost where it is (0, 0), whatever the flag says.
    Por,
}

/// What the flags of one eye say over a recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct FlagCounts {
    /// Samples with this eye.
    pub samples: usize,
    /// Of those, flagged lost.
    pub flagged_lost: usize,
    /// Of those flagged lost, with a point of regard other than (0, 0).
    pub flagged_lost_with_gaze: usize,
}

impl FlagCounts {
    /// The flag says lost in every sample while the gaze moves: it is not a loss flag.
    pub fn contradicts_the_gaze(&self) -> bool {
        self.samples > 0 && self.flagged_lost == self.samples && self.flagged_lost_with_gaze > 0
    }
}

fn has_gaze(e: &EyeSample) -> bool {
    !(e.x == 0.0 && e.y == 0.0)
}

/// The flag counts of the left and the right eye.
pub fn flag_counts(rec: &Recording) -> [FlagCounts; 2] {
    let mut counts = [FlagCounts::default(); 2];
    for s in &rec.samples {
        for (k, e) in [s.left, s.right].iter().enumerate() {
            let Some(e) = e else { continue };
            counts[k].samples += 1;
            if e.flag_lost {
                counts[k].flagged_lost += 1;
                if has_gaze(e) {
                    counts[k].flagged_lost_with_gaze += 1;
                }
            }
        }
    }
    counts
}

/// Applies `rule` to the recording's samples and returns what it changed, as notes for the
/// user (empty when nothing changed).
pub fn apply_validity_rule(rec: &mut Recording, rule: ValidityRule) -> Vec<String> {
    let counts = flag_counts(rec);
    let mut notes = Vec::new();
    for (k, (label, c)) in ["L", "R"].iter().zip(counts).enumerate() {
        if c.flagged_lost == 0 {
            continue;
        }
        let set_aside = match rule {
            ValidityRule::Strict => false,
            ValidityRule::Por => true,
            ValidityRule::Auto => c.contradicts_the_gaze(),
        };
        if !set_aside {
            continue;
        }
        for s in &mut rec.samples {
            let e = if k == 0 { &mut s.left } else { &mut s.right };
            if let Some(e) = e {
                e.valid = has_gaze(e);
            }
        }
        notes.push(match rule {
            ValidityRule::Auto => format!(
                "`{label} Validity` is 0 in all {} samples while `{label} POR` is non-zero in {}: the flag is not a loss flag in this export, so a sample is lost only where its POR is (0, 0) (SMI's other loss rule; --validity strict keeps the flag)",
                c.samples, c.flagged_lost_with_gaze
            ),
            _ => format!(
                "--validity por: `{label} Validity` set aside ({} of {} samples flagged lost, {} of them with a gaze position); lost only where POR is (0, 0)",
                c.flagged_lost, c.samples, c.flagged_lost_with_gaze
            ),
        });
    }
    notes
}

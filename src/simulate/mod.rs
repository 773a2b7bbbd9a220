//! Virtual observers: synthetic SMI RED250 recordings of people watching a stimulus, with the
//! true target of every fixation written beside them. They let the whole pipeline (ingest →
//! filter → project) be checked against a known answer, and give the demo its subjects.
//!
//! The model, one subject at a time (all random steps from one seeded ChaCha stream):
//! * a 1 s lead-in on a central fixation cross, the stimulus onset message, the video, a 0.5 s
//!   tail on a blank screen (its own message, so tail fixations belong to no stimulus);
//! * fixations with log-normal durations (median 250 ms, σ_log 0.45, clipped to 100–1200 ms);
//!   each targets a vertex visible at that moment (on screen, first hit from the eye, and
//!   facing the camera), drawn with probability ∝ saliency^sharpness, at least
//!   `min_saccade_deg` away from the current gaze;
//! * the eye lands off the target by a per-fixation accuracy error (2D Gaussian, RMS radius
//!   `accuracy_deg`, 0.4° for the RED250) plus per-sample jitter (`precision_deg` RMS per
//!   axis), converted to pixels at the subject's head distance (uniform in the protocol's
//!   range);
//! * saccades follow the main sequence (21 ms + 2.2 ms per degree) with a minimum-jerk path;
//!   after a fixation, a blink (100–250 ms of lost samples at SMI's (0, 0)) with probability
//!   `blink_probability`.
//!
//! During camera moves the observer keeps looking at the screen point where the target was
//! when the fixation started (no smooth pursuit): such fixations carry `phase = move`.
mod error;
mod extremity_map;
mod observers;
pub mod playlist;
mod write_simulation;

pub use crate::projection::round_trip::{
    parse_targets_csv, read_targets_csv, round_trip, RoundTrip, TrueFixation,
};
pub use error::SimulateError;
pub use extremity_map::extremity_map;
pub use observers::*;
pub use write_simulation::{write_simulation, write_targets_csv, RecordingFormat};

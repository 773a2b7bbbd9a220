//! Playlist recordings: one SMI recording per virtual subject in which every stimulus of a
//! study plays once, in an order shuffled per subject, with each video's onset message, as
//! Experiment Center records a real study.
use rand::seq::SliceRandom;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

use super::{
    extremity_map, simulate_observers, ObserverParams, SimulateError, TargetModel, VirtualSubject,
};
use crate::stimulus::load::LoadedStimulus;

/// Gap between two videos of a playlist, µs.
const GAP_US: i64 = 2_000_000;

/// One subject's playlist: the stimuli in the order shown, and the recording.
pub struct PlaylistSubject {
    /// The stimuli in the order shown.
    pub order: Vec<String>,
    /// The subject's one recording of all of them.
    pub recording: VirtualSubject,
}

/// Simulates `params.subjects` subjects watching every stimulus (named `<mesh stem>.mp4`),
/// each subject in its own seeded order. Subjects look at extremities (a model independent of
/// every saliency method).
pub fn simulate_playlists(
    stimuli: &[LoadedStimulus],
    params: &ObserverParams,
) -> Result<Vec<PlaylistSubject>, SimulateError> {
    // Per stimulus, all subjects (independent streams per subject).
    let mut per_stimulus: Vec<Vec<VirtualSubject>> = Vec::new();
    for (j, s) in stimuli.iter().enumerate() {
        let p = ObserverParams {
            seed: params.seed.wrapping_add(1_000 * j as u64),
            ..params.clone()
        };
        let model = TargetModel::Saliency(extremity_map(&s.mesh));
        per_stimulus.push(simulate_observers(
            &s.mesh,
            &s.plan,
            &s.protocol,
            &model,
            &format!("{}.mp4", s.mesh_stem()),
            &p,
        )?);
    }
    let mut out = Vec::new();
    #[allow(clippy::needless_range_loop)] // k is the subject, indexing each stimulus's subjects
    for k in 0..params.subjects {
        let mut order: Vec<usize> = (0..stimuli.len()).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(params.seed ^ 0x9e37_79b9_7f4a_7c15);
        rng.set_stream(k as u64 + 1);
        order.shuffle(&mut rng);
        let mut rec: Option<VirtualSubject> = None;
        // Each subject's session on its own stretch of the tracker clock.
        let mut cursor: i64 = 1_000_000_000 + 10_000_000_000 * k as i64;
        for &j in &order {
            let mut part = per_stimulus[j][k].clone();
            let first = part.samples.first().map_or(0, |s| s.time_us);
            let shift = cursor - first;
            for s in &mut part.samples {
                s.time_us += shift;
            }
            for e in &mut part.events {
                e.start_us += shift;
                e.end_us += shift;
            }
            for m in &mut part.messages {
                m.time_us += shift;
            }
            for f in &mut part.fixations {
                f.start_us += shift;
                f.end_us += shift;
            }
            cursor = part.samples.last().map_or(cursor, |s| s.time_us) + GAP_US;
            match rec.as_mut() {
                None => rec = Some(part),
                Some(r) => {
                    r.samples.extend(part.samples);
                    r.events.extend(part.events);
                    r.messages.extend(part.messages);
                    r.fixations.extend(part.fixations);
                }
            }
        }
        if let Some(recording) = rec {
            out.push(PlaylistSubject {
                order: order
                    .iter()
                    .map(|&j| format!("{}.mp4", stimuli[j].mesh_stem()))
                    .collect(),
                recording,
            });
        }
    }
    Ok(out)
}

//! The observer model: where each virtual subject looks, sample by sample (see the module
//! documentation of `simulate`).
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::gaze::recording::{Event, EventKind, Eye, EyeSample, Header, Message, Sample};
use crate::mesh::Mesh;
use crate::projection::{displayed_camera, RayCaster};
use crate::protocol::{Display, Protocol};
use crate::stimulus::camera::{CameraPlan, CameraState, Phase};

use super::{SimulateError, TrueFixation};

/// The virtual observers' behaviour (defaults: an SMI RED250 at 250 Hz, 8 subjects).
#[derive(Debug, Clone, Serialize)]
pub struct ObserverParams {
    /// How many subjects.
    pub subjects: usize,
    /// Seed of every random step; each subject draws from its own stream.
    pub seed: u64,
    /// The tracker's sample rate.
    pub sample_rate_hz: f64,
    /// RMS radial accuracy error per fixation, degrees.
    pub accuracy_deg: f64,
    /// RMS per-sample jitter per axis, degrees.
    pub precision_deg: f64,
    /// Median fixation duration (log-normal), ms.
    pub fixation_median_ms: f64,
    /// σ of the log of fixation durations.
    pub fixation_sigma_log: f64,
    /// Shortest fixation, ms.
    pub fixation_min_ms: f64,
    /// Longest fixation, ms.
    pub fixation_max_ms: f64,
    /// A new target is at least this far from the current gaze, degrees.
    pub min_saccade_deg: f64,
    /// Probability of a blink after a fixation.
    pub blink_probability: f64,
    /// Target probability ∝ saliency^sharpness (saliency min–max normalized).
    pub sharpness: f64,
    /// Cosine of the largest angle between a target's normal and the direction to the eye.
    pub min_facing_cos: f64,
    /// Seconds on a central fixation cross before the stimulus.
    pub lead_in_s: f64,
    /// Seconds on a blank screen after it.
    pub tail_s: f64,
}

impl Default for ObserverParams {
    fn default() -> Self {
        ObserverParams {
            subjects: 8,
            seed: 1,
            sample_rate_hz: 250.0,
            accuracy_deg: 0.4,
            precision_deg: 0.03,
            fixation_median_ms: 250.0,
            fixation_sigma_log: 0.45,
            fixation_min_ms: 100.0,
            fixation_max_ms: 1200.0,
            min_saccade_deg: 2.0,
            blink_probability: 0.05,
            sharpness: 2.0,
            min_facing_cos: 0.2,
            lead_in_s: 1.0,
            tail_s: 0.5,
        }
    }
}

/// What the virtual observers look at.
#[derive(Debug, Clone)]
pub enum TargetModel {
    /// One value per vertex; higher draws more fixations.
    Saliency(Vec<f64>),
    /// Only these vertices (uniformly among the visible ones).
    Vertices(Vec<usize>),
}

/// One virtual subject's recording.
#[derive(Debug, Clone)]
pub struct VirtualSubject {
    /// `s01`, `s02`, ...
    pub id: String,
    /// The subject's distance from the screen, mm (uniform in the protocol's range).
    pub head_distance_mm: f64,
    /// The recording's header.
    pub header: Header,
    /// Every sample.
    pub samples: Vec<Sample>,
    /// The stimulus onset and end messages.
    pub messages: Vec<Message>,
    /// The fixations, saccades and blinks, as an event export lists them.
    pub events: Vec<Event>,
    /// Every fixation with its true target.
    pub fixations: Vec<TrueFixation>,
}

struct Normal<'a>(&'a mut ChaCha8Rng);

impl Normal<'_> {
    fn sample(&mut self) -> f64 {
        crate::random::standard_normal(self.0)
    }
}

/// Vertices a viewer could fixate under `cam`: on the picture (with a margin), unoccluded,
/// and facing the camera.
fn visible_vertices(
    caster: &RayCaster,
    normals: &[DVec3],
    cam: &CameraState,
    min_facing_cos: f64,
    margin_px: f64,
) -> Vec<(usize, f64, f64)> {
    let mesh = caster.mesh();
    let tol = 1e-6 * cam.eye.length().max(1.0);
    (0..mesh.positions.len())
        .into_par_iter()
        .filter_map(|v| {
            let p = mesh.positions[v];
            let to_eye = (cam.eye - p).normalize();
            if normals[v].dot(to_eye) < min_facing_cos {
                return None;
            }
            let (x, y, _) = cam.project(p)?;
            if x < margin_px
                || y < margin_px
                || x > cam.width_px as f64 - margin_px
                || y > cam.height_px as f64 - margin_px
            {
                return None;
            }
            // Unoccluded: the first hit along the eye ray is (next to) this vertex.
            caster
                .visible_from(cam.eye, p, tol + 1e-4 * (cam.eye - p).length())
                .then_some((v, x, y))
        })
        .collect()
}

/// Vertices a viewer could look at under one camera: (vertex, screen x, screen y).
type VisibleSet = std::sync::Arc<Vec<(usize, f64, f64)>>;

fn minimum_jerk(s: f64) -> f64 {
    s * s * s * (10.0 - 15.0 * s + 6.0 * s * s)
}

/// Simulates `params.subjects` observers. Deterministic for a seed; subjects are independent
/// streams, so adding subjects does not change the first ones.
pub fn simulate_observers(
    mesh: &Mesh,
    plan: &CameraPlan,
    protocol: &Protocol,
    model: &TargetModel,
    stimulus_name: &str,
    params: &ObserverParams,
) -> Result<Vec<VirtualSubject>, SimulateError> {
    if let TargetModel::Saliency(s) = model {
        if s.len() != mesh.positions.len() {
            return Err(SimulateError::MapLength {
                values: s.len(),
                vertices: mesh.positions.len(),
            });
        }
    }
    if let TargetModel::Vertices(v) = model {
        if let Some(&bad) = v.iter().find(|&&i| i >= mesh.positions.len()) {
            return Err(SimulateError::TargetOutOfRange {
                vertex: bad,
                vertices: mesh.positions.len(),
            });
        }
    }
    let caster = RayCaster::new(mesh);
    let normals = mesh.vertex_normals();
    let weights: Vec<f64> = match model {
        TargetModel::Saliency(s) => {
            let (lo, hi) = s
                .iter()
                .filter(|x| x.is_finite())
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &x| {
                    (a.min(x), b.max(x))
                });
            let span = if hi > lo { hi - lo } else { 1.0 };
            s.iter()
                .map(|&x| {
                    if x.is_finite() {
                        ((x - lo) / span).powf(params.sharpness) + 1e-3
                    } else {
                        0.0
                    }
                })
                .collect()
        }
        TargetModel::Vertices(list) => {
            let mut w = vec![0.0; mesh.positions.len()];
            for &v in list {
                w[v] = 1.0;
            }
            w
        }
    };
    let fps = protocol.video.fps;
    // Visible vertices per displayed frame, shared by all subjects.
    let cache = std::sync::Mutex::new(std::collections::HashMap::<
        i64,
        std::sync::Arc<Vec<(usize, f64, f64)>>,
    >::new());
    let visible_at = |t: f64| {
        let frame = (t * fps as f64).floor() as i64;
        let cam = displayed_camera(plan, fps, t);
        // Frames of one hold share a camera.
        let key = if cam.phase == Phase::Hold {
            -1 - cam.viewpoint as i64
        } else {
            frame
        };
        if let Some(v) = cache.lock().expect("no panics inside").get(&key) {
            return (cam, v.clone());
        }
        let v = std::sync::Arc::new(visible_vertices(
            &caster,
            &normals,
            &cam,
            params.min_facing_cos,
            10.0,
        ));
        cache
            .lock()
            .expect("no panics inside")
            .insert(key, v.clone());
        (cam, v)
    };
    (0..params.subjects)
        .map(|k| {
            simulate_one(
                k,
                plan,
                protocol,
                &weights,
                &visible_at,
                stimulus_name,
                params,
            )
        })
        .collect()
}

/// A recording being written: samples at a fixed rate from `t_us` on, and numbered events.
struct Recording {
    rng: ChaCha8Rng,
    samples: Vec<Sample>,
    events: Vec<Event>,
    number: [u64; 3],
    t_us: i64,
    dt_us: i64,
    pupil: f64,
    /// Per-sample jitter, px (RMS per axis).
    jitter_px: f64,
}

impl Recording {
    /// One binocular sample at `t_us` (then the clock moves on): the eye at `pos` with jitter,
    /// or lost (SMI's (0, 0)) when `pos` is None.
    fn sample(&mut self, pos: Option<(f64, f64)>) {
        let (pupil, jitter) = (self.pupil, self.jitter_px);
        let eye = |rng: &mut ChaCha8Rng| match pos {
            Some((x, y)) => {
                let mut n = Normal(rng);
                let jx = n.sample() * jitter;
                let jy = n.sample() * jitter;
                let p = pupil + 0.02 * n.sample();
                EyeSample {
                    x: ((x + jx) * 100.0).round() / 100.0,
                    y: ((y + jy) * 100.0).round() / 100.0,
                    pupil: Some((p * 1000.0).round() / 1000.0),
                    valid: true,
                    flag_lost: false,
                }
            }
            None => EyeSample {
                x: 0.0,
                y: 0.0,
                pupil: Some(0.0),
                valid: false,
                flag_lost: true,
            },
        };
        let left = eye(&mut self.rng);
        let right = eye(&mut self.rng);
        self.samples.push(Sample {
            time_us: self.t_us,
            trial: 1,
            left: Some(left),
            right: Some(right),
            binocular: None,
            binocular_event: None,
            left_event: None,
            right_event: None,
            stimulus: None,
        });
        self.t_us += self.dt_us;
    }

    /// Appends the next event of `kind` for `eye` over [s, e] µs and returns it to fill in.
    fn event(&mut self, kind: EventKind, eye: Eye, s: i64, e: i64) -> &mut Event {
        let slot = kind as usize;
        self.number[slot] += 1;
        self.events.push(Event {
            kind,
            eye,
            trial: 1,
            number: self.number[slot],
            start_us: s,
            end_us: e,
            duration_us: e - s,
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
        });
        self.events.last_mut().expect("just pushed")
    }

    /// A main-sequence saccade from `from` to `land` along a minimum-jerk path.
    fn saccade(&mut self, from: (f64, f64), land: (f64, f64), ppd: f64, stop_us: i64) {
        let amp_deg = (land.0 - from.0).hypot(land.1 - from.1) / ppd;
        let dur_us = ((21.0 + 2.2 * amp_deg) * 1000.0) as i64;
        let s0 = self.t_us;
        while self.t_us < s0 + dur_us && self.t_us < stop_us {
            let s = minimum_jerk((self.t_us - s0) as f64 / dur_us as f64);
            self.sample(Some((
                from.0 + s * (land.0 - from.0),
                from.1 + s * (land.1 - from.1),
            )));
        }
        let end = self.t_us - self.dt_us;
        for eye in [Eye::Left, Eye::Right] {
            let e = self.event(EventKind::Saccade, eye, s0, end);
            e.x = Some(from.0);
            e.y = Some(from.1);
            e.end_x = Some(land.0);
            e.end_y = Some(land.1);
        }
    }

    /// Samples at `land` until `f_end`, and a fixation event per eye with the samples' mean,
    /// dispersion and pupil.
    fn fixation(&mut self, land: (f64, f64), f_end: i64) {
        let f0 = self.t_us;
        let first_sample = self.samples.len();
        while self.t_us < f_end {
            self.sample(Some(land));
        }
        if self.samples.len() == first_sample {
            return;
        }
        let end = self.t_us - self.dt_us;
        for eye in [Eye::Left, Eye::Right] {
            let pts: Vec<EyeSample> = self.samples[first_sample..]
                .iter()
                .filter_map(|s| if eye == Eye::Left { s.left } else { s.right })
                .collect();
            let n = pts.len() as f64;
            let mx = pts.iter().map(|p| p.x).sum::<f64>() / n;
            let my = pts.iter().map(|p| p.y).sum::<f64>() / n;
            let range = |f: fn(&EyeSample) -> f64| {
                let (a, b) = pts
                    .iter()
                    .map(f)
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                        (a.min(v), b.max(v))
                    });
                b - a
            };
            let (dx, dy) = (range(|p| p.x), range(|p| p.y));
            let pupil = self.pupil;
            let e = self.event(EventKind::Fixation, eye, f0, end);
            e.x = Some((mx * 100.0).round() / 100.0);
            e.y = Some((my * 100.0).round() / 100.0);
            e.dispersion_x = Some((dx * 100.0).round() / 100.0);
            e.dispersion_y = Some((dy * 100.0).round() / 100.0);
            e.pupil_x = Some(pupil);
            e.pupil_y = Some(pupil);
        }
    }

    /// Lost samples until `b_end` and a blink event per eye.
    fn blink(&mut self, b_end: i64) {
        let b0 = self.t_us;
        while self.t_us < b_end {
            self.sample(None);
        }
        let end = self.t_us - self.dt_us;
        for eye in [Eye::Left, Eye::Right] {
            self.event(EventKind::Blink, eye, b0, end);
        }
    }
}

/// Draws a visible vertex with probability ∝ its weight, at least `min_d` px from `gaze`:
/// (vertex, x, y), or None when no candidate has weight.
fn choose_target(
    visible: &[(usize, f64, f64)],
    weights: &[f64],
    gaze: (f64, f64),
    min_d: f64,
    rng: &mut ChaCha8Rng,
) -> Option<(usize, f64, f64)> {
    let candidates: Vec<&(usize, f64, f64)> = visible
        .iter()
        .filter(|c| weights[c.0] > 0.0)
        .filter(|c| (c.1 - gaze.0).hypot(c.2 - gaze.1) >= min_d)
        .collect();
    let total: f64 = candidates.iter().map(|c| weights[c.0]).sum();
    if total <= 0.0 {
        return None;
    }
    let mut r = rng.random::<f64>() * total;
    let mut pick = candidates[candidates.len() - 1];
    for c in &candidates {
        r -= weights[c.0];
        if r <= 0.0 {
            pick = c;
            break;
        }
    }
    Some(*pick)
}

/// The header SMI writes for subject `k`.
fn header_of(
    k: usize,
    id: &str,
    display: &Display,
    params: &ObserverParams,
    head_distance_mm: f64,
) -> Header {
    Header {
        banner: None,
        entries: Vec::new(),
        sample_rate_hz: Some(params.sample_rate_hz),
        calibration_area_px: Some([display.width_px as f64, display.height_px as f64]),
        stimulus_dimension_mm: Some([display.width_mm, display.height_mm]),
        head_distance_mm: Some((head_distance_mm * 10.0).round() / 10.0),
        subject: Some(id.to_string()),
        date: chrono::NaiveDate::from_ymd_opt(2026, 1, 5)
            .and_then(|d| d.and_hms_opt(10, 0, 0))
            .map(|d| d + chrono::Duration::minutes(15 * k as i64)),
        version: None,
        format_items: Vec::new(),
        normalized: false,
    }
}

/// Subject `k`: a fixation cross, the video from `onset`, a blank screen after it; fixations
/// on targets drawn from `weights` among the vertices visible when the eye arrives, saccades
/// between them, blinks after some.
#[allow(clippy::too_many_arguments)]
fn simulate_one(
    k: usize,
    plan: &CameraPlan,
    protocol: &Protocol,
    weights: &[f64],
    visible_at: &dyn Fn(f64) -> (CameraState, VisibleSet),
    stimulus_name: &str,
    params: &ObserverParams,
) -> Result<VirtualSubject, SimulateError> {
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    rng.set_stream(k as u64 + 1);
    let id = format!("s{:02}", k + 1);
    let display = &protocol.display;
    let [d_lo, d_hi] = display.viewing_distance_mm;
    let head_distance_mm = d_lo + (d_hi - d_lo) * rng.random::<f64>();
    let ppd =
        head_distance_mm * 1f64.to_radians().tan() * display.width_px as f64 / display.width_mm;
    let (w, h) = (display.width_px as f64, display.height_px as f64);
    let base_us: i64 = 1_000_000_000 + 60_000_000 * k as i64;
    let onset_us = base_us + (params.lead_in_s * 1e6).round() as i64;
    let duration_s = plan.duration_s();
    let end_us = onset_us + (duration_s * 1e6).round() as i64;
    let stop_us = end_us + (params.tail_s * 1e6).round() as i64;
    let messages = trial_messages(base_us, onset_us, end_us, stimulus_name);
    let pupil = 3.2 + 0.8 * rng.random::<f64>();
    let mut rec = Recording {
        rng,
        samples: Vec::new(),
        events: Vec::new(),
        number: [0; 3],
        t_us: base_us,
        dt_us: (1e6 / params.sample_rate_hz).round() as i64,
        pupil,
        jitter_px: params.precision_deg * ppd,
    };
    let mut fixations: Vec<TrueFixation> = Vec::new();
    let mut gaze = (0.5 * w, 0.5 * h);
    let mut index = 0;
    while rec.t_us < stop_us {
        // Where to look next.
        let t_s = (rec.t_us - onset_us) as f64 / 1e6;
        let screen = Screen { w, h, ppd };
        let mut fix = next_target(
            &mut rec.rng,
            t_s,
            duration_s,
            &screen,
            gaze,
            visible_at,
            weights,
            params,
        );
        fix.subject = id.clone();
        fix.index = index;
        // Accuracy error: per-axis σ so that the RMS radius is accuracy_deg.
        let sigma = params.accuracy_deg / std::f64::consts::SQRT_2 * ppd;
        let (ox, oy) = {
            let mut n = Normal(&mut rec.rng);
            (n.sample() * sigma, n.sample() * sigma)
        };
        let land = (fix.target_x + ox, fix.target_y + oy);
        // Saccade (not before the first fixation).
        if index > 0 {
            rec.saccade(gaze, land, ppd, stop_us);
        }
        let dur_ms = fixation_duration_ms(index, params, &mut rec.rng);
        let f0 = rec.t_us;
        rec.fixation(land, (f0 + (dur_ms * 1000.0) as i64).min(stop_us));
        gaze = land;
        fix.start_us = f0;
        fix.end_us = rec.t_us;
        fix.start_ms = (f0 - onset_us) as f64 / 1000.0;
        fix.duration_ms = (rec.t_us - f0) as f64 / 1000.0;
        fix.gaze_x = land.0;
        fix.gaze_y = land.1;
        fixations.push(fix);
        index += 1;
        // A blink after some fixations.
        if index > 1 && rec.t_us < stop_us && rec.rng.random::<f64>() < params.blink_probability {
            let lasts_us = ((100.0 + 150.0 * rec.rng.random::<f64>()) * 1000.0) as i64;
            rec.blink((rec.t_us + lasts_us).min(stop_us));
        }
    }
    Ok(VirtualSubject {
        header: header_of(k, &id, display, params, head_distance_mm),
        id,
        head_distance_mm,
        samples: rec.samples,
        messages,
        events: rec.events,
        fixations,
    })
}

/// The recording's messages: the fixation cross, the video at its onset, the blank after it.
fn trial_messages(base_us: i64, onset_us: i64, end_us: i64, stimulus_name: &str) -> Vec<Message> {
    vec![
        Message {
            time_us: base_us,
            trial: 1,
            text: "fixation-cross.bmp".into(),
        },
        Message {
            time_us: onset_us,
            trial: 1,
            text: stimulus_name.to_string(),
        },
        Message {
            time_us: end_us,
            trial: 1,
            text: "blank.bmp".into(),
        },
    ]
}

/// The screen in pixels and pixels per degree at the subject's head distance.
struct Screen {
    w: f64,
    h: f64,
    ppd: f64,
}

/// The next fixation's target at `t_s` seconds from onset: the screen centre in the lead-in,
/// a drift around it on the blank after the video, else a vertex chosen by `weights` among
/// those visible when the eye arrives (subject and index are the caller's).
#[allow(clippy::too_many_arguments)]
fn next_target(
    rng: &mut ChaCha8Rng,
    t_s: f64,
    duration_s: f64,
    screen: &Screen,
    gaze: (f64, f64),
    visible_at: &dyn Fn(f64) -> (CameraState, VisibleSet),
    weights: &[f64],
    params: &ObserverParams,
) -> TrueFixation {
    let (w, h, ppd) = (screen.w, screen.h, screen.ppd);
    let mut fix = TrueFixation {
        subject: String::new(),
        index: 0,
        start_us: 0,
        end_us: 0,
        start_ms: 0.0,
        duration_ms: 0.0,
        phase: "lead-in".into(),
        viewpoint: None,
        vertex: None,
        target_x: 0.5 * w,
        target_y: 0.5 * h,
        gaze_x: 0.0,
        gaze_y: 0.0,
    };
    if t_s >= duration_s {
        fix.phase = "tail".into();
        // A blank screen: drift around the centre.
        let mut n = Normal(rng);
        fix.target_x = 0.5 * w + 3.0 * ppd * n.sample();
        fix.target_y = 0.5 * h + 3.0 * ppd * n.sample();
    } else if t_s >= 0.0 {
        // Choose by the camera about when the eye arrives.
        let (cam, visible) = visible_at((t_s + 0.04).min(duration_s - 1e-6));
        fix.phase = cam.phase.name().into();
        fix.viewpoint = Some(cam.viewpoint);
        let min_d = params.min_saccade_deg * ppd;
        if let Some((v, x, y)) = choose_target(&visible, weights, gaze, min_d, rng) {
            fix.vertex = Some(v);
            fix.target_x = x;
            fix.target_y = y;
        }
    }
    fix
}

/// The fixation's duration: in the lead-in until shortly after onset (first saccade latency
/// ~ 200 ms), else log-normal about the median, clamped.
fn fixation_duration_ms(index: usize, params: &ObserverParams, rng: &mut ChaCha8Rng) -> f64 {
    if index == 0 {
        params.lead_in_s * 1000.0 + 150.0 + 100.0 * rng.random::<f64>()
    } else {
        let z = Normal(rng).sample();
        (params.fixation_median_ms * (params.fixation_sigma_log * z).exp())
            .clamp(params.fixation_min_ms, params.fixation_max_ms)
    }
}

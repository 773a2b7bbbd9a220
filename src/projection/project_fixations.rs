//! 2D fixations to mesh vertices: the camera on screen, the ray, the first hit, the snap and the cone.
use glam::DVec3;
use serde::Serialize;

use crate::protocol::DuringMove;
use crate::stimulus::camera::{CameraPlan, CameraState, Phase};

use super::{nearest_corner, Hit, ProjectionFate, RayCaster, ScreenMapping};

/// A fixation to project: times in ms after the stimulus onset.
#[derive(Debug, Clone, PartialEq)]
pub struct ScreenFixation {
    /// The subject's id.
    pub subject: String,
    /// Order of the fixation within the subject's viewing of this stimulus (0-based).
    pub index: usize,
    /// Start, ms after the stimulus onset.
    pub start_ms: f64,
    /// Duration, ms.
    pub duration_ms: f64,
    /// Position on the tracker's screen, px, horizontal.
    pub x_px: f64,
    /// Position on the tracker's screen, px, vertical.
    pub y_px: f64,
    /// The ingest filter's verdict: false when it removed the fixation.
    pub kept: bool,
    /// The ingest stage found no usable position.
    pub invalid: bool,
}

/// How fixations are projected.
#[derive(Debug, Clone, Serialize)]
pub struct ProjectionParams {
    /// Which camera a fixation that overlaps a move is projected with.
    pub during_move: DuringMove,
    /// Background misses look for the nearest visible surface within this many screen pixels
    /// (the tracker's accuracy); None keeps them as background.
    pub snap_radius_px: Option<f64>,
    /// Gaussian cone: half-angle and σ in screen pixels (None = single ray).
    pub cone: Option<Cone>,
    /// The video's frame rate: a fixation is projected with the frame on screen.
    pub fps: u32,
}

/// A Gaussian cone of rays around the gaze ray, for a footprint instead of one vertex.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Cone {
    /// Radius of the sampled disk, screen px.
    pub radius_px: f64,
    /// The Gaussian's σ, screen px.
    pub sigma_px: f64,
    /// Rays per pixel of radius along each axis of the sampling grid.
    pub rays_per_radius: usize,
}

/// One projected fixation.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectedFixation {
    /// The subject's id.
    pub subject: String,
    /// The fixation's index among the subject's fixations of this stimulus.
    pub index: usize,
    /// Start, ms after the stimulus onset.
    pub start_ms: f64,
    /// Duration, ms.
    pub duration_ms: f64,
    /// Screen position on the tracker's screen, px, horizontal.
    pub screen_x: f64,
    /// Screen position, px, vertical.
    pub screen_y: f64,
    /// Stimulus time whose camera was used (the displayed frame's time), s.
    pub camera_time_s: Option<f64>,
    /// What the camera was doing then.
    pub phase: Option<Phase>,
    /// The hold viewpoint (0-based) during a hold.
    pub viewpoint: Option<usize>,
    /// The triangle the ray hit.
    pub triangle: Option<usize>,
    /// Where the (possibly snapped) ray met the surface.
    pub point: Option<DVec3>,
    /// The nearest corner of that triangle: the fixated vertex.
    pub vertex: Option<usize>,
    /// Screen distance of a snap, px.
    pub snap_px: Option<f64>,
    /// What became of the fixation.
    pub fate: ProjectionFate,
    /// Cone mode: vertices and weights (sum 1) of this fixation's Gaussian footprint.
    pub footprint: Vec<(usize, f64)>,
}

/// The camera on screen at stimulus time `t_s`: the frame being shown, not a pose between
/// frames, exactly as the renderer drew it.
pub fn displayed_camera(plan: &CameraPlan, fps: u32, t_s: f64) -> CameraState {
    let frame = (t_s * fps as f64).floor().max(0.0);
    plan.at(frame / fps as f64)
}

/// Whether any frame shown during [start, end] (s) belongs to a move.
pub fn overlaps_move(plan: &CameraPlan, fps: u32, start_s: f64, end_s: f64) -> bool {
    let first = (start_s * fps as f64).floor().max(0.0) as i64;
    let last = (end_s * fps as f64).floor() as i64;
    (first..=last.max(first)).any(|f| plan.at(f as f64 / fps as f64).phase == Phase::Move)
}

/// Projects fixations onto the mesh. Pure: same inputs, same outputs.
pub fn project_fixations(
    plan: &CameraPlan,
    caster: &RayCaster,
    mapping: &ScreenMapping,
    fixations: &[ScreenFixation],
    params: &ProjectionParams,
) -> Vec<ProjectedFixation> {
    use rayon::prelude::*;
    fixations
        .par_iter()
        .map(|f| project_one(plan, caster, mapping, f, params))
        .collect()
}

fn project_one(
    plan: &CameraPlan,
    caster: &RayCaster,
    mapping: &ScreenMapping,
    f: &ScreenFixation,
    params: &ProjectionParams,
) -> ProjectedFixation {
    let mut out = ProjectedFixation {
        subject: f.subject.clone(),
        index: f.index,
        start_ms: f.start_ms,
        duration_ms: f.duration_ms,
        screen_x: f.x_px,
        screen_y: f.y_px,
        camera_time_s: None,
        phase: None,
        viewpoint: None,
        triangle: None,
        point: None,
        vertex: None,
        snap_px: None,
        fate: ProjectionFate::Invalid,
        footprint: Vec::new(),
    };
    if f.invalid || !f.x_px.is_finite() || !f.y_px.is_finite() || !f.start_ms.is_finite() {
        return out;
    }
    if !f.kept {
        out.fate = ProjectionFate::Filtered;
        return out;
    }
    let start_s = f.start_ms / 1000.0;
    let end_s = (f.start_ms + f.duration_ms.max(0.0)) / 1000.0;
    let duration = plan.duration_s();
    let t = match params.during_move {
        DuringMove::Start => start_s,
        DuringMove::Mid | DuringMove::Reject => 0.5 * (start_s + end_s),
    };
    if !(t >= 0.0 && t < duration) {
        return out; // invalid: not while the video was playing
    }
    if params.during_move == DuringMove::Reject && overlaps_move(plan, params.fps, start_s, end_s) {
        out.fate = ProjectionFate::InTransition;
        return out;
    }
    let cam = displayed_camera(plan, params.fps, t);
    out.camera_time_s = Some(cam.time_s);
    out.phase = Some(cam.phase);
    out.viewpoint = Some(cam.viewpoint);
    let Some((vx, vy)) = mapping.to_video(f.x_px, f.y_px) else {
        out.fate = ProjectionFate::OffScreen;
        return out;
    };
    let (origin, dir) = cam.ray(vx, vy);
    let hit = match caster.first_hit(origin, dir) {
        Some(h) => {
            out.fate = ProjectionFate::Hit;
            Some((h, vx, vy))
        }
        None => match params.snap_radius_px {
            Some(r) => {
                let (s, _, _) = mapping.picture();
                snap(caster, &cam, vx, vy, r / s).map(|(h, sx, sy, d)| {
                    out.fate = ProjectionFate::Snapped;
                    out.snap_px = Some(d * s);
                    (h, sx, sy)
                })
            }
            None => None,
        },
    };
    let Some((hit, hx, hy)) = hit else {
        out.fate = ProjectionFate::Background;
        return out;
    };
    out.triangle = Some(hit.triangle);
    out.point = Some(hit.point);
    out.vertex = Some(nearest_corner(caster.mesh(), hit.triangle, hit.point));
    if let Some(cone) = params.cone {
        let (s, _, _) = mapping.picture();
        out.footprint = cone_footprint(caster, &cam, hx, hy, &cone, s);
    }
    out
}

/// Offsets on a 1-pixel grid within `radius`, nearest first (ties in a fixed order).
fn disk_offsets(radius: f64, step: f64) -> Vec<(f64, f64)> {
    let n = (radius / step).floor() as i64;
    let mut v: Vec<(f64, f64)> = Vec::new();
    for j in -n..=n {
        for i in -n..=n {
            let (dx, dy) = (i as f64 * step, j as f64 * step);
            if dx * dx + dy * dy <= radius * radius {
                v.push((dx, dy));
            }
        }
    }
    v.sort_by(|a, b| {
        (a.0 * a.0 + a.1 * a.1)
            .total_cmp(&(b.0 * b.0 + b.1 * b.1))
            .then(a.1.total_cmp(&b.1))
            .then(a.0.total_cmp(&b.0))
    });
    v
}

/// The nearest screen point within `radius` (video px) whose ray hits the mesh.
fn snap(
    caster: &RayCaster,
    cam: &CameraState,
    x: f64,
    y: f64,
    radius: f64,
) -> Option<(Hit, f64, f64, f64)> {
    disk_offsets(radius, 1.0).into_iter().find_map(|(dx, dy)| {
        let (o, d) = cam.ray(x + dx, y + dy);
        caster
            .first_hit(o, d)
            .map(|h| (h, x + dx, y + dy, (dx * dx + dy * dy).sqrt()))
    })
}

/// Vertices seen within a Gaussian cone around the gaze ray, with weights summing to 1.
fn cone_footprint(
    caster: &RayCaster,
    cam: &CameraState,
    x: f64,
    y: f64,
    cone: &Cone,
    screen_scale: f64,
) -> Vec<(usize, f64)> {
    let radius = cone.radius_px / screen_scale;
    let sigma = cone.sigma_px / screen_scale;
    let step = radius / cone.rays_per_radius.max(1) as f64;
    let mut acc: std::collections::BTreeMap<usize, f64> = Default::default();
    let mut total = 0.0;
    for (dx, dy) in disk_offsets(radius, step) {
        let (o, d) = cam.ray(x + dx, y + dy);
        if let Some(h) = caster.first_hit(o, d) {
            let w = (-(dx * dx + dy * dy) / (2.0 * sigma * sigma)).exp();
            *acc.entry(nearest_corner(caster.mesh(), h.triangle, h.point))
                .or_default() += w;
            total += w;
        }
    }
    acc.into_iter().map(|(v, w)| (v, w / total)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disk_offsets_are_sorted_by_distance() {
        let d = disk_offsets(3.0, 1.0);
        assert_eq!(d[0], (0.0, 0.0));
        assert_eq!(d.len(), 29);
        assert!(d
            .windows(2)
            .all(|w| w[0].0.hypot(w[0].1) <= w[1].0.hypot(w[1].1)));
    }
}

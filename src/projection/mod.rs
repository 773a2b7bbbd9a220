//! From 2D screen fixations to mesh vertices (paper §4): the camera that was on screen at the
//! fixation's time (the stimulus's own [`CameraPlan`]), the screen point mapped into the video
//! (letterbox-aware), a ray from the eye through it, the first hit through a BVH with a
//! watertight triangle test, and the hit triangle's nearest corner.
//!
//! Every fixation ends with exactly one [`ProjectionFate`]; nothing is dropped.
pub mod project_file;
pub mod ray_caster;
pub mod round_trip;
pub mod self_check;
pub mod table;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::protocol::DuringMove;
use crate::stimulus::camera::{CameraPlan, CameraState, Phase};
pub use ray_caster::{nearest_corner, Hit, RayCaster};

/// What became of a fixation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ProjectionFate {
    /// The ray hit the mesh.
    Hit,
    /// The ray missed, and the nearest visible surface within the tracker's accuracy was used.
    Snapped,
    /// The ray missed the mesh (the fixation was on the background).
    Background,
    /// Outside the screen, or on a letterbox bar outside the video picture.
    OffScreen,
    /// Overlapped a camera move while the protocol rejects those.
    InTransition,
    /// No usable position, or a time outside the video.
    Invalid,
    /// Removed by the protocol's fixation filter before projection.
    Filtered,
}

impl ProjectionFate {
    pub const ALL: [ProjectionFate; 7] = [
        ProjectionFate::Hit,
        ProjectionFate::Snapped,
        ProjectionFate::Background,
        ProjectionFate::OffScreen,
        ProjectionFate::InTransition,
        ProjectionFate::Invalid,
        ProjectionFate::Filtered,
    ];

    pub fn name(self) -> &'static str {
        match self {
            ProjectionFate::Hit => "hit",
            ProjectionFate::Snapped => "snapped",
            ProjectionFate::Background => "background",
            ProjectionFate::OffScreen => "off-screen",
            ProjectionFate::InTransition => "in-transition",
            ProjectionFate::Invalid => "invalid",
            ProjectionFate::Filtered => "filtered",
        }
    }

    pub fn parse(s: &str) -> Option<ProjectionFate> {
        ProjectionFate::ALL.into_iter().find(|f| f.name() == s)
    }

    /// Whether the fixation has a vertex on the mesh.
    pub fn on_mesh(self) -> bool {
        matches!(self, ProjectionFate::Hit | ProjectionFate::Snapped)
    }
}

/// How gaze coordinates (the tracker's screen) relate to the video's pixels.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ScreenMapping {
    pub screen_width_px: f64,
    pub screen_height_px: f64,
    pub video_width_px: u32,
    pub video_height_px: u32,
}

impl ScreenMapping {
    /// The video scaled to fit the screen with its aspect ratio kept and centred, as players
    /// show it full screen: (scale, left, top) of the picture in screen pixels.
    pub fn picture(&self) -> (f64, f64, f64) {
        let s = (self.screen_width_px / self.video_width_px as f64)
            .min(self.screen_height_px / self.video_height_px as f64);
        let left = 0.5 * (self.screen_width_px - s * self.video_width_px as f64);
        let top = 0.5 * (self.screen_height_px - s * self.video_height_px as f64);
        (s, left, top)
    }

    /// Video pixel coordinates of a gaze point, None when it is not on the picture.
    pub fn to_video(&self, x: f64, y: f64) -> Option<(f64, f64)> {
        if !(x >= 0.0 && y >= 0.0 && x < self.screen_width_px && y < self.screen_height_px) {
            return None;
        }
        let (s, left, top) = self.picture();
        let (vx, vy) = ((x - left) / s, (y - top) / s);
        (vx >= 0.0
            && vy >= 0.0
            && vx < self.video_width_px as f64
            && vy < self.video_height_px as f64)
            .then_some((vx, vy))
    }

    /// Screen coordinates of a video pixel position.
    pub fn to_screen(&self, vx: f64, vy: f64) -> (f64, f64) {
        let (s, left, top) = self.picture();
        (left + s * vx, top + s * vy)
    }
}

/// A fixation to project: times in ms after the stimulus onset.
#[derive(Debug, Clone, PartialEq)]
pub struct ScreenFixation {
    pub subject: String,
    /// Order of the fixation within the subject's viewing of this stimulus (0-based).
    pub index: usize,
    pub start_ms: f64,
    pub duration_ms: f64,
    pub x_px: f64,
    pub y_px: f64,
    /// The ingest filter's verdict: false when it removed the fixation.
    pub kept: bool,
    /// The ingest stage found no usable position.
    pub invalid: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct ProjectionParams {
    pub during_move: DuringMove,
    /// Background misses look for the nearest visible surface within this many screen pixels
    /// (the tracker's accuracy); None keeps them as background.
    pub snap_radius_px: Option<f64>,
    /// Gaussian cone: half-angle and σ in screen pixels (None = single ray).
    pub cone: Option<Cone>,
    pub fps: u32,
}

#[derive(Debug, Clone, Copy, Serialize)]
pub struct Cone {
    pub radius_px: f64,
    pub sigma_px: f64,
    /// Rays per pixel of radius along each axis of the sampling grid.
    pub rays_per_radius: usize,
}

/// One projected fixation.
#[derive(Debug, Clone, PartialEq)]
pub struct ProjectedFixation {
    pub subject: String,
    pub index: usize,
    pub start_ms: f64,
    pub duration_ms: f64,
    pub screen_x: f64,
    pub screen_y: f64,
    /// Stimulus time whose camera was used (the displayed frame's time), s.
    pub camera_time_s: Option<f64>,
    pub phase: Option<Phase>,
    pub viewpoint: Option<usize>,
    pub triangle: Option<usize>,
    /// Where the (possibly snapped) ray met the surface.
    pub point: Option<DVec3>,
    pub vertex: Option<usize>,
    /// Screen distance of a snap, px.
    pub snap_px: Option<f64>,
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

/// Counts by fate, every fate present (zeros included), in [`ProjectionFate::ALL`] order.
pub fn count_fates<'a>(
    fates: impl IntoIterator<Item = &'a ProjectionFate>,
) -> Vec<(ProjectionFate, usize)> {
    let mut counts: Vec<(ProjectionFate, usize)> =
        ProjectionFate::ALL.iter().map(|&f| (f, 0)).collect();
    for f in fates {
        if let Some(c) = counts.iter_mut().find(|c| c.0 == *f) {
            c.1 += 1;
        }
    }
    counts
}

/// Fates of projected rows counted by fate name (every fate present, zero or not); rows without
/// a readable fate are not counted.
pub fn fate_counts_by_name<'a>(
    rows: impl IntoIterator<Item = &'a table::ProjectedRow>,
) -> std::collections::BTreeMap<&'static str, usize> {
    let fates: Vec<ProjectionFate> = rows.into_iter().filter_map(|r| r.fate()).collect();
    count_fates(fates.iter())
        .into_iter()
        .map(|(f, c)| (f.name(), c))
        .collect()
}

/// Fates per subject as a plain-text table (one line per subject, then the totals).
pub fn fate_table_text(
    fates: &std::collections::BTreeMap<String, std::collections::BTreeMap<&'static str, usize>>,
    totals: &std::collections::BTreeMap<&'static str, usize>,
) -> String {
    let names: Vec<&str> = ProjectionFate::ALL.iter().map(|f| f.name()).collect();
    let mut text = format!("{:<10}", "subject");
    for n in &names {
        text += &format!(" {n:>13}");
    }
    text.push('\n');
    let mut row = |label: &str, c: &std::collections::BTreeMap<&'static str, usize>| {
        text += &format!("{label:<10}");
        for n in &names {
            text += &format!(" {:>13}", c.get(n).copied().unwrap_or(0));
        }
        text.push('\n');
    };
    for (s, c) in fates {
        row(s, c);
    }
    row("total", totals);
    text
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn letterbox_maps_the_picture_centre_to_the_video_centre() {
        let m = ScreenMapping {
            screen_width_px: 1920.0,
            screen_height_px: 1080.0,
            video_width_px: 1680,
            video_height_px: 1050,
        };
        let (s, left, top) = m.picture();
        assert!((s - 1080.0 / 1050.0).abs() < 1e-12 && top == 0.0 && left > 0.0);
        let (vx, vy) = m.to_video(960.0, 540.0).unwrap();
        assert!((vx - 840.0).abs() < 1e-9 && (vy - 525.0).abs() < 1e-9);
        assert!(m.to_video(left - 1.0, 500.0).is_none(), "on the bar");
        assert!(m.to_video(-1.0, 500.0).is_none());
        let (sx, sy) = m.to_screen(vx, vy);
        assert!((sx - 960.0).abs() < 1e-9 && (sy - 540.0).abs() < 1e-9);
    }

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

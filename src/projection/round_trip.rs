//! How projected fixations compare with the true targets of virtual observers: the
//! targets.csv rows `simulate` writes, and the round trip `project --targets` reports.
use crate::projection::table::TableError;
use serde::Serialize;

use crate::mesh::Mesh;
use crate::stimulus::camera::{CameraPlan, Phase};

/// A fixation as the virtual observer made it; one row of targets.csv.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct TrueFixation {
    /// The subject's id.
    pub subject: String,
    /// Order within the subject's recording (lead-in and tail included).
    pub index: usize,
    /// Start, tracker clock in µs.
    pub start_us: i64,
    /// End, tracker clock in µs.
    pub end_us: i64,
    /// Start after the stimulus onset, ms (negative in the lead-in).
    pub start_ms: f64,
    /// Duration, ms.
    pub duration_ms: f64,
    /// `lead-in`, `hold`, `move` or `tail`.
    pub phase: String,
    /// The hold viewpoint (0-based) when it started in a hold.
    pub viewpoint: Option<usize>,
    /// The target vertex; None for the cross, the tail, or when nothing was visible.
    pub vertex: Option<usize>,
    /// The target's screen position, px, horizontal.
    pub target_x: f64,
    /// The target's screen position, px, vertical.
    pub target_y: f64,
    /// Where the eye actually pointed (the target plus the accuracy error), px, horizontal.
    pub gaze_x: f64,
    /// Where the eye actually pointed, px, vertical.
    pub gaze_y: f64,
}

/// targets.csv from a file.
pub fn read_targets_csv(path: &std::path::Path) -> Result<Vec<TrueFixation>, TableError> {
    let bytes = std::fs::read(path).map_err(|e| TableError::Read {
        name: path.display().to_string(),
        error: crate::file_bytes::ReadError::Io(e),
    })?;
    parse_targets_csv(&bytes, &path.display().to_string())
}

/// targets.csv from bytes; errors name the line.
pub fn parse_targets_csv(bytes: &[u8], name: &str) -> Result<Vec<TrueFixation>, TableError> {
    let mut r = csv::Reader::from_reader(bytes);
    r.deserialize()
        .map(|x| {
            x.map_err(|e| TableError::Row {
                name: name.to_string(),
                line: e.position().map_or(0, |p| p.line()),
                message: e.to_string(),
            })
        })
        .collect()
}

/// How projected fixations compare with the virtual observers' true targets.
#[derive(Debug, Clone, Serialize, Default)]
pub struct RoundTrip {
    /// Projected fixations that passed the filter and whose camera was a hold.
    pub hold_fixations: usize,
    /// Of those, matched (by time overlap) to a true fixation with a target vertex.
    pub matched: usize,
    /// Matched fixations that landed on the mesh (hit or snapped).
    pub on_mesh: usize,
    /// On-mesh fixations whose vertex is seen within 1° of visual angle of the true target
    /// (the 1° circle around the target, carried onto the surface by the camera).
    pub within_1deg: usize,
    /// within_1deg / matched.
    pub rate: f64,
    /// Median and 95th percentile of the error in degrees of visual angle.
    pub median_error_deg: f64,
    /// 95th percentile of the error, degrees.
    pub p95_error_deg: f64,
    /// (subject, fixation, fate, error in degrees or NaN) of every matched fixation not
    /// within 1°, for inspection.
    pub misses: Vec<(String, usize, String, f64)>,
}

/// Matches each projected hold-phase fixation to the true fixation it overlaps most and
/// measures how far its vertex is from the true target in degrees of visual angle, both seen
/// through the fixation's camera.
pub fn round_trip(
    mesh: &Mesh,
    plan: &CameraPlan,
    pixels_per_degree: f64,
    targets: &[TrueFixation],
    projected: &[crate::projection::table::ProjectedRow],
) -> RoundTrip {
    use crate::projection::ProjectionFate;
    let mut r = RoundTrip::default();
    let mut errors = Vec::new();
    for p in projected {
        let Some(fate) = p.fate() else { continue };
        if p.phase() != Some(Phase::Hold) || fate == ProjectionFate::Filtered {
            continue;
        }
        r.hold_fixations += 1;
        let (a0, a1) = (p.start_ms, p.start_ms + p.duration_ms);
        let best = targets
            .iter()
            .filter(|t| t.subject == p.subject)
            .map(|t| {
                (
                    t,
                    (a1.min(t.start_ms + t.duration_ms) - a0.max(t.start_ms)).max(0.0),
                )
            })
            .filter(|(_, o)| *o > 0.0)
            .max_by(|x, y| x.1.total_cmp(&y.1));
        let Some((t, _)) = best else { continue };
        // The target was chosen with the camera of the hold too.
        let Some(target) = t.vertex.filter(|_| t.phase == "hold") else {
            continue;
        };
        r.matched += 1;
        let (Some(v), true) = (p.vertex, fate.on_mesh()) else {
            r.misses
                .push((p.subject.clone(), p.fixation, p.fate.clone(), f64::NAN));
            continue;
        };
        r.on_mesh += 1;
        // 1° converted to the surface: the surface points seen within 1° of the target,
        // i.e. the landed vertex's screen position against the target's, in degrees.
        let cam = plan.at(p.camera_time_s.unwrap_or(0.0));
        let (Some(a), Some(b)) = (
            cam.project(mesh.positions[target]),
            cam.project(mesh.positions[v]),
        ) else {
            continue;
        };
        let err_deg = (a.0 - b.0).hypot(a.1 - b.1) / pixels_per_degree;
        errors.push(err_deg);
        if err_deg <= 1.0 {
            r.within_1deg += 1;
        } else {
            r.misses
                .push((p.subject.clone(), p.fixation, p.fate.clone(), err_deg));
        }
    }
    r.rate = if r.matched > 0 {
        r.within_1deg as f64 / r.matched as f64
    } else {
        f64::NAN
    };
    errors.sort_by(f64::total_cmp);
    let q = |f: f64| {
        if errors.is_empty() {
            f64::NAN
        } else {
            errors[((errors.len() - 1) as f64 * f).round() as usize]
        }
    };
    r.median_error_deg = q(0.5);
    r.p95_error_deg = q(0.95);
    r
}

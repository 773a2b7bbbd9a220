//! The machine-readable camera timeline: one CSV row per frame.
use std::io::Write;
use std::path::Path;

use super::camera::{CameraPlan, CameraState};
use crate::protocol::Protocol;

/// The timeline CSV's header.
pub fn timeline_header() -> String {
    let mut h = vec![
        "frame",
        "time_ms",
        "phase",
        "viewpoint",
        "next_viewpoint",
        "progress",
        "eye_x",
        "eye_y",
        "eye_z",
    ]
    .into_iter()
    .map(String::from)
    .collect::<Vec<_>>();
    for m in ["view", "proj"] {
        for r in 0..4 {
            for c in 0..4 {
                h.push(format!("{m}_r{r}c{c}"));
            }
        }
    }
    h.extend(["viewport_x", "viewport_y", "viewport_w", "viewport_h"].map(String::from));
    h.join(",")
}

/// One timeline row (shortest exact float formatting, so a recomputed camera compares byte
/// for byte).
pub fn timeline_row(frame: usize, cam: &CameraState) -> String {
    let mut f = vec![
        frame.to_string(),
        format!("{}", cam.time_s * 1000.0),
        cam.phase.name().to_string(),
        cam.viewpoint.to_string(),
        cam.next_viewpoint.to_string(),
        format!("{}", cam.progress),
        format!("{}", cam.eye.x),
        format!("{}", cam.eye.y),
        format!("{}", cam.eye.z),
    ];
    for m in [cam.view, cam.projection] {
        for r in 0..4 {
            for c in 0..4 {
                f.push(format!("{}", m.col(c)[r]));
            }
        }
    }
    f.extend([
        "0".into(),
        "0".into(),
        cam.width_px.to_string(),
        cam.height_px.to_string(),
    ]);
    f.join(",")
}

/// The camera of every frame, one CSV row each.
pub(super) fn write_timeline(
    plan: &CameraPlan,
    protocol: &Protocol,
    path: &Path,
) -> std::io::Result<()> {
    let mut timeline = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(timeline, "{}", timeline_header())?;
    for i in 0..protocol.frame_count() {
        let cam = plan.at(i as f64 / protocol.video.fps as f64);
        writeln!(timeline, "{}", timeline_row(i, &cam))?;
    }
    timeline.flush()
}

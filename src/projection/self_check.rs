//! The projector checked against the renderer: for hold-phase fixations, the triangle the
//! projection stored must be the triangle the rasterizer's id buffer shows at the fixation's
//! pixel (or differ only because the gaze point is off the pixel's centre near an edge).
//! Two independent visibility computations (z-buffer with the top-left fill rule, and a
//! watertight ray cast) agreeing is the evidence that fixations land where the subject saw them.
use std::collections::BTreeMap;

use serde::Serialize;

use super::{ProjectedFixation, ProjectionFate, RayCaster, ScreenMapping};
use crate::stimulus::camera::{CameraPlan, Phase};
use crate::stimulus::raster::{Rasterizer, BACKGROUND_ID};

/// The projector checked against the renderer: the triangle each hold fixation hit against the id image of its frame.
#[derive(Debug, Clone, Serialize, Default)]
pub struct SelfCheck {
    /// Hold-phase fixations that hit the mesh or the background (not snapped, not off the
    /// picture), each checked against the id buffer of its hold.
    pub checked: usize,
    /// The projection's stored triangle (none for background) is the one the id buffer shows
    /// at the fixation's pixel.
    pub agreed: usize,
    /// The stored triangle differs from the id buffer's only because the gaze point is not the
    /// pixel's centre: a ray through the centre hits the id buffer's triangle, and a ray through
    /// the gaze point hits the stored one.
    pub sub_pixel: usize,
    /// (agreed + sub_pixel) / checked.
    pub rate: f64,
    /// (subject, fixation index, stored triangle, id-buffer triangle) of each disagreement.
    pub disagreements: Vec<(String, usize, Option<usize>, Option<usize>)>,
}

/// Compares each hold-phase fixation's stored triangle with the id buffer of that hold
/// (rendered once per viewpoint).
pub fn self_check(
    plan: &CameraPlan,
    caster: &RayCaster,
    mapping: &ScreenMapping,
    projected: &[ProjectedFixation],
) -> SelfCheck {
    let mut by_view: BTreeMap<usize, Vec<&ProjectedFixation>> = BTreeMap::new();
    for p in projected {
        let checkable = matches!(p.fate, ProjectionFate::Hit | ProjectionFate::Background);
        if p.phase == Some(Phase::Hold) && checkable {
            if let Some(v) = p.viewpoint {
                by_view.entry(v).or_default().push(p);
            }
        }
    }
    let raster = Rasterizer::new(caster.mesh());
    let mut report = SelfCheck::default();
    for (_, fixations) in by_view {
        let cam = plan.at(fixations[0].camera_time_s.unwrap_or(0.0));
        let ids = raster.triangle_ids(&cam);
        for p in fixations {
            let Some((vx, vy)) = mapping.to_video(p.screen_x, p.screen_y) else {
                continue;
            };
            let (px, py) = (vx.floor(), vy.floor());
            let id = ids[py as usize * cam.width_px as usize + px as usize];
            let rendered = (id != BACKGROUND_ID).then_some(id as usize);
            report.checked += 1;
            if p.triangle == rendered {
                report.agreed += 1;
                continue;
            }
            let (o, d) = cam.ray(px + 0.5, py + 0.5);
            let at_centre = caster.first_hit(o, d).map(|h| h.triangle);
            let (o, d) = cam.ray(vx, vy);
            let at_gaze = caster.first_hit(o, d).map(|h| h.triangle);
            if at_centre == rendered && at_gaze == p.triangle {
                report.sub_pixel += 1;
            } else {
                report
                    .disagreements
                    .push((p.subject.clone(), p.index, p.triangle, rendered));
            }
        }
    }
    report.rate = if report.checked > 0 {
        (report.agreed + report.sub_pixel) as f64 / report.checked as f64
    } else {
        f64::NAN
    };
    report
}

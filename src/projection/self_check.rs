//! The projector checked against the renderer: for hold-phase fixations, the BVH's triangle
//! under the fixation's pixel must be the triangle the rasterizer's id buffer shows there.
//! Two independent visibility computations (z-buffer with the top-left fill rule, and a
//! watertight ray cast) agreeing is the evidence that fixations land where the subject saw them.
use std::collections::BTreeMap;

use serde::Serialize;

use super::{ProjectedFixation, RayCaster, ScreenMapping};
use crate::stimulus::camera::{CameraPlan, Phase};
use crate::stimulus::raster::{Rasterizer, BACKGROUND_ID};

#[derive(Debug, Clone, Serialize, Default)]
pub struct SelfCheck {
    /// Hold-phase fixations on the picture that were checked.
    pub checked: usize,
    pub agreed: usize,
    pub rate: f64,
    /// (subject, fixation index, BVH triangle, id-buffer triangle) of each disagreement.
    pub disagreements: Vec<(String, usize, Option<usize>, Option<usize>)>,
}

/// Compares each hold-phase fixation's ray through its pixel centre with the id buffer of
/// that hold (rendered once per viewpoint).
pub fn self_check(
    plan: &CameraPlan,
    caster: &RayCaster,
    mapping: &ScreenMapping,
    projected: &[ProjectedFixation],
) -> SelfCheck {
    let mut by_view: BTreeMap<usize, Vec<&ProjectedFixation>> = BTreeMap::new();
    for p in projected {
        if p.phase == Some(Phase::Hold) {
            if let Some(v) = p.viewpoint {
                by_view.entry(v).or_default().push(p);
            }
        }
    }
    let mut raster = Rasterizer::new(caster.mesh());
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
            let (o, d) = cam.ray(px + 0.5, py + 0.5);
            let cast = caster.first_hit(o, d).map(|h| h.triangle);
            report.checked += 1;
            if cast == rendered {
                report.agreed += 1;
            } else {
                report
                    .disagreements
                    .push((p.subject.clone(), p.index, cast, rendered));
            }
        }
    }
    report.rate = if report.checked > 0 {
        report.agreed as f64 / report.checked as f64
    } else {
        f64::NAN
    };
    report
}

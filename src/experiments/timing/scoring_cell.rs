use std::path::Path;
use std::time::Instant;

use rand::{RngExt, SeedableRng};
use serde::{Deserialize, Serialize};

use super::TimingError;
use crate::mesh::load_mesh;
use crate::progress::Silent;
use crate::saliency::{compute_saliency, Method, SmsParams, PAPER_METHODS};
use crate::scoring::{score_mesh, ScoreParams};
use crate::stimulus::hold_views::hold_view_exposure;
use crate::truth::{Fixation, FixationTruth, GroundTruth};
use crate::Protocol;

/// What scoring one mesh the way a study does costs.
#[derive(Debug, Serialize, Deserialize)]
pub struct ScoringCell {
    /// Vertices of the mesh.
    pub vertices: usize,
    /// Maps scored.
    pub maps: usize,
    /// Fixations of the truth.
    pub fixations: usize,
    /// Subjects of the truth.
    pub subjects: usize,
    /// Blur widths of the grid.
    pub blur_scales: usize,
    /// Random maps of the chance band.
    pub chance_draws: usize,
    /// Computing the seven maps (not part of the scoring time).
    pub maps_s: f64,
    /// `score_mesh`: every metric of every map at every blur, the chance band and the
    /// split-half human ceiling.
    pub score_s: f64,
}

/// The 50k armadillo, the paper's seven maps, and a truth of 8 subjects x 15 fixations on
/// vertices drawn with a fixed seed: `score_mesh` with the defaults `meshgaze score` and a
/// study use (21 blur scales, 20 chance draws, human splits), timed on its own.
pub fn scoring_cell(data: &Path) -> Result<ScoringCell, TimingError> {
    let mesh_path = data.join("meshes/classic/decimated_profactor_50k/armadillo.obj");
    let (mesh, _) = load_mesh(&mesh_path).map_err(|e| TimingError::Input {
        path: mesh_path.clone(),
        message: e.to_string(),
    })?;
    let stage = |message: String| TimingError::Input {
        path: mesh_path.clone(),
        message,
    };
    let t = Instant::now();
    let mut maps = Vec::new();
    for method in PAPER_METHODS {
        let out = compute_saliency(method, &mesh, &SmsParams::default(), &Silent)
            .map_err(|e| stage(e.to_string()))?;
        maps.push((Method::name(method).to_string(), out.values));
    }
    let maps_s = t.elapsed().as_secs_f64();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(35);
    let n = mesh.positions.len();
    let subjects: Vec<String> = (1..=8).map(|s| format!("s{s:02}")).collect();
    let fixations: Vec<Fixation> = subjects
        .iter()
        .flat_map(|s| {
            (0..15)
                .map(|_| Fixation {
                    subject: s.clone(),
                    vertex: rng.random_range(0..n),
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let truth = GroundTruth::Fixations(FixationTruth {
        rows: fixations.len(),
        fixations,
        subjects: subjects.clone(),
        rows_not_on_mesh: Default::default(),
    });
    let seen = hold_view_exposure(&mesh, &Protocol::builtin().0)
        .map_err(|e| stage(e.to_string()))?
        .seen();
    let params = ScoreParams::default();
    let t = Instant::now();
    score_mesh(&mesh, &truth, &maps, &params, Some(&seen), &Silent)
        .map_err(|e| stage(e.to_string()))?;
    let score_s = t.elapsed().as_secs_f64();
    Ok(ScoringCell {
        vertices: n,
        maps: maps.len(),
        fixations: 120,
        subjects: subjects.len(),
        blur_scales: params.blur_sigmas.len(),
        chance_draws: params.chance_maps,
        maps_s,
        score_s,
    })
}

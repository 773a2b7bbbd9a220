//! The paper's robustness experiment (§5.4, Fig. 8): each method's map on damaged copies of
//! a mesh (noise along normals, simplification, holes), carried back to the original
//! vertices and compared with the method's own map on the clean mesh.
use crate::experiments::ExperimentError;
use serde::Serialize;

use crate::experiments::corruption::{
    add_normal_noise, cut_holes, transfer_by_nearest_surface_point,
};
use crate::mesh::geometry::{pearson, BoundingBox, Normalization};
use crate::mesh::simplification::simplify_to_vertex_count;
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::saliency::{compute_saliency_viewed, Method, RarityParams, SmsParams, Viewing};
use crate::scoring::auc_judd;

/// The paper's robustness experiment (Fig. 8): how each method's map survives noise,
/// simplification and holes.
#[derive(Debug, Clone, Serialize)]
pub struct RobustnessParams {
    /// Noise σ as a fraction of the mean edge length (paper: 20%).
    pub noise_fraction: f64,
    /// Vertices after simplification (paper: 5k).
    pub simplify_to: usize,
    /// Holes cut into the surface.
    pub holes: usize,
    /// Hole radius in normalized units (half principal-axes box diagonal = 1).
    pub hole_radius: f64,
    /// Positives of the agreement AUC: this top fraction of the clean map.
    pub top_fraction: f64,
    /// Seed of the noise and of the holes' centres.
    pub seed: u64,
    /// Parameters of sri, gr and mr (their defaults unless `--set`).
    pub rarity: RarityParams,
}

impl Default for RobustnessParams {
    fn default() -> Self {
        RobustnessParams {
            noise_fraction: 0.2,
            simplify_to: 5000,
            holes: 5,
            hole_radius: 0.05,
            top_fraction: 0.1,
            seed: 1,
            rarity: RarityParams::default(),
        }
    }
}

/// One damaged copy of the mesh.
pub struct Corrupted {
    /// The damage's short name, as the tables write it.
    pub name: &'static str,
    /// The damaged copy.
    pub mesh: Mesh,
    /// What was done, with its parameters.
    pub description: String,
}

/// How far one method's map on one damaged copy agrees with its map on the clean mesh.
#[derive(Debug, Clone, Serialize)]
pub struct AgreementRow {
    /// The method.
    pub method: String,
    /// The damage's short name.
    pub corruption: &'static str,
    /// Pearson correlation with the clean map over the original vertices.
    pub pearson: f64,
    /// AUC of the carried-back map at finding the clean map's top vertices.
    pub auc_top: f64,
    /// Seconds the method took on the damaged copy.
    pub seconds: f64,
}

/// The experiment's results.
pub struct RobustnessResult {
    /// The damaged copies.
    pub corrupted: Vec<Corrupted>,
    /// Per method: the clean map, then each corrupted copy's own map (on its vertices).
    pub maps: Vec<(Method, Vec<f64>, Vec<Vec<f64>>)>,
    /// One agreement row per method and damage.
    pub rows: Vec<AgreementRow>,
}

/// The three damaged copies of the paper's Fig. 8; an error when a copy would not be damaged
/// (simplifying to as many vertices as the mesh has) or would have no surface left.
pub fn corrupt(mesh: &Mesh, p: &RobustnessParams) -> Result<Vec<Corrupted>, ExperimentError> {
    if mesh.triangles.is_empty() {
        return Err(ExperimentError::Invalid("the mesh has no triangles".into()));
    }
    let n = mesh.positions.len();
    if p.simplify_to >= n {
        return Err(ExperimentError::Invalid(format!(
            "--simplify-to {} is not below the mesh's {n} vertices: the \"simplified\" copy would be the mesh itself; give fewer vertices",
            p.simplify_to
        )));
    }
    let radius = Normalization::of_mesh(mesh, BoundingBox::Oriented).radius;
    let noisy = add_normal_noise(mesh, p.noise_fraction, p.seed);
    let (simplified, _) = simplify_to_vertex_count(mesh, p.simplify_to);
    let (holed, _) = cut_holes(mesh, p.holes, p.hole_radius * radius, p.seed);
    if holed.triangles.is_empty() {
        return Err(ExperimentError::Invalid(format!(
            "{} holes of radius {} (normalized units) remove every triangle of the mesh; give a smaller --hole-radius or fewer --holes",
            p.holes, p.hole_radius
        )));
    }
    Ok(vec![
        Corrupted {
            name: "noise",
            description: format!(
                "Gaussian noise along vertex normals, σ = {}% of the mean edge length",
                100.0 * p.noise_fraction
            ),
            mesh: noisy,
        },
        Corrupted {
            name: "simplified",
            description: format!(
                "quadric edge collapse (meshoptimizer) to {} vertices (asked {})",
                simplified.positions.len(),
                p.simplify_to
            ),
            mesh: simplified,
        },
        Corrupted {
            name: "holes",
            description: format!(
                "{} patches of radius {} (normalized units) removed: {} of {} triangles left",
                p.holes,
                p.hole_radius,
                holed.triangles.len(),
                mesh.triangles.len()
            ),
            mesh: holed,
        },
    ])
}

/// Runs every method on the clean mesh and on each damaged copy.
pub fn robustness(
    mesh: &Mesh,
    methods: &[Method],
    sms: &SmsParams,
    p: &RobustnessParams,
    progress: &dyn Progress,
) -> Result<RobustnessResult, ExperimentError> {
    let corrupted = corrupt(mesh, p)?;
    let viewing = Viewing {
        rarity: p.rarity.clone(),
        ..Viewing::builtin()
    };
    let n = mesh.positions.len();
    let k = ((p.top_fraction * n as f64).round() as usize).clamp(1, n);
    let mut maps = Vec::new();
    let mut rows = Vec::new();
    for &method in methods {
        let clean = compute_saliency_viewed(method, mesh, sms, &viewing, progress)?;
        // The clean map's top k vertices (ties to the lower index).
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&a, &b| clean.values[b].total_cmp(&clean.values[a]).then(a.cmp(&b)));
        let mut positive = vec![false; n];
        for &v in &order[..k] {
            positive[v] = true;
        }
        let mut own = Vec::new();
        for c in &corrupted {
            let out = compute_saliency_viewed(method, &c.mesh, sms, &viewing, progress)?;
            let back = transfer_by_nearest_surface_point(&c.mesh, &out.values, &mesh.positions);
            rows.push(AgreementRow {
                method: method.name().to_string(),
                corruption: c.name,
                pearson: pearson(&clean.values, &back),
                auc_top: auc_judd(&back, &positive, None),
                seconds: out.seconds,
            });
            own.push(out.values);
        }
        maps.push((method, clean.values, own));
    }
    Ok(RobustnessResult {
        corrupted,
        maps,
        rows,
    })
}

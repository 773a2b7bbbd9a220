//! The feature-point experiment's own arithmetic and files: the separation in mesh units, the
//! sweep over the tolerance α, and the CSV tables `meshgaze features` writes.
use crate::experiments::ExperimentError;
use std::io::Write;

use serde::Serialize;

use super::{evaluate, Evaluation, FeaturePoint, GeodesicGraph, TruthPoint};
use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::Mesh;

/// What the feature points' minimum separation is measured in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum SeparationUnit {
    /// Half the principal-axes bounding-box diagonal = 1.
    Normalized,
    /// Fraction of the geodesic diameter.
    Diameter,
}

/// `separation` in the mesh's own units.
pub fn separation_in_mesh_units(
    mesh: &Mesh,
    separation: f64,
    unit: SeparationUnit,
    geodesic_diameter: f64,
) -> f64 {
    match unit {
        SeparationUnit::Normalized => {
            separation * Normalization::of_mesh(mesh, BoundingBox::Oriented).radius
        }
        SeparationUnit::Diameter => separation * geodesic_diameter,
    }
}

/// The benchmark at α = 0, step, 2·step, … ≤ max (each α rounded to 1e-9 so 0.07 prints as
/// 0.07); at most 1000 steps.
pub fn alpha_sweep(
    graph: &GeodesicGraph,
    truth: &[TruthPoint],
    detected: &[usize],
    alpha_max: f64,
    alpha_step: f64,
    geodesic_diameter: f64,
) -> Result<Vec<Evaluation>, ExperimentError> {
    let steps = (alpha_max / alpha_step + 1e-9).floor();
    if !(alpha_step > 0.0 && alpha_max >= 0.0 && steps <= 1000.0) {
        return Err(ExperimentError::Invalid(
            "--alpha-step must be positive with at most 1000 steps".into(),
        ));
    }
    Ok((0..=steps as usize)
        .map(|i| {
            let alpha = (i as f64 * alpha_step * 1e9).round() / 1e9;
            evaluate(graph, truth, detected, alpha, geodesic_diameter)
        })
        .collect())
}

/// `rank,vertex,saliency,x,y,z`, most salient first.
pub fn write_feature_points_csv(
    mut w: impl Write,
    mesh: &Mesh,
    points: &[FeaturePoint],
) -> std::io::Result<()> {
    writeln!(w, "rank,vertex,saliency,x,y,z")?;
    for (k, p) in points.iter().enumerate() {
        let q = mesh.positions[p.vertex];
        writeln!(
            w,
            "{},{},{},{},{},{}",
            k + 1,
            p.vertex,
            p.saliency,
            q.x,
            q.y,
            q.z
        )?;
    }
    w.flush()
}

/// `vertex,subjects` of the voted ground truth.
pub fn write_truth_points_csv(mut w: impl Write, truth: &[TruthPoint]) -> std::io::Result<()> {
    writeln!(w, "vertex,subjects")?;
    for p in truth {
        writeln!(w, "{},{}", p.vertex, p.subjects)?;
    }
    w.flush()
}

/// One row per α of the sweep.
pub fn write_evaluation_csv(mut w: impl Write, rows: &[Evaluation]) -> std::io::Result<()> {
    writeln!(
        w,
        "alpha,truth_points,detected_points,matched,fne,fpe,wme,recall,precision,f_measure"
    )?;
    for x in rows {
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{}",
            x.alpha,
            x.truth_points,
            x.detected_points,
            x.matched,
            x.false_negative_error,
            x.false_positive_error,
            x.weighted_miss_error,
            x.recall,
            x.precision,
            x.f_measure
        )?;
    }
    w.flush()
}

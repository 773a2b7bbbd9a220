//! Sparse metric-based mesh saliency (SMS; Hu, Liang, Shum, Li, Aslam, Neurocomputing 2020).
//!
//! A. normalize, sample the surface, build the Gaussian distance field and the multi-scale
//!    harmonic shape descriptors (the metric is implicit in them);
//! B. principal eigenvalue, then the sparse leading eigenvector by the truncated power method;
//! C. Gaussian interpolation from samples to vertices, rescaled to [0, 1].
use crate::saliency::SaliencyError;
use std::time::Instant;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::descriptor_metric::DescriptorMetric;
use super::gaussian_interpolation::{
    gaussian_interpolation, min_max_normalize, InterpolationKind, InterpolationReport,
};
use super::truncated_power::{
    principal_eigenpair, truncated_power, EigenReport, PowerParams, TruncatedPowerReport,
};
use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::sampling::{sample_surface_with, Sampling};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::saliency::sms::descriptors::{
    compute_descriptors, gaussian_distance_field::grid_geometry, DescriptorParams, Descriptors,
    ExactField, GridField, GridParams,
};
use crate::scoring::gini_index;

/// Where descriptor samples read the Gaussian distance field from.
/// How the distance field behind the descriptors is evaluated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum FieldKind {
    /// A res³ grid read by trilinear interpolation (the paper's 256³).
    Grid,
    /// Exact distance at every shell sample by brute force over triangles: a reference for
    /// small meshes, orders of magnitude slower.
    Exact,
}

/// The parameters of the sparse metric-based saliency; the defaults are the paper's.
#[derive(Debug, Clone, Serialize)]
pub struct SmsParams {
    /// Random surface samples n (paper: 5000).
    pub samples: usize,
    /// Seed of the surface sampling (the only random step).
    pub seed: u64,
    /// The multi-scale harmonic shape descriptors (scales, shells, bands).
    pub descriptor: DescriptorParams,
    /// How the distance field is evaluated.
    pub field: FieldKind,
    /// The distance-field grid (resolution, Gaussian smoothing).
    pub grid: GridParams,
    /// Fraction of samples allowed to be non-zero (paper: 0.2).
    pub mu: f64,
    /// Interpolation Gaussian σ in normalized units (paper: 0.02), radius 3σ.
    pub sigma: f64,
    /// How sample saliency is carried back to vertices.
    pub interpolation: InterpolationKind,
    /// The box the mesh is normalized by (its half diagonal becomes 1).
    pub bounding_box: BoundingBox,
    /// The power iterations' tolerance and limits.
    pub power: PowerParams,
    /// Uniform random points (the paper) or Poisson-disk (its future work, §6).
    pub sampling: Sampling,
}

impl Default for SmsParams {
    fn default() -> Self {
        SmsParams {
            samples: 5000,
            seed: 1,
            descriptor: DescriptorParams::default(),
            field: FieldKind::Grid,
            grid: GridParams::default(),
            mu: 0.2,
            sigma: 0.02,
            interpolation: InterpolationKind::Normalized,
            bounding_box: BoundingBox::Oriented,
            power: PowerParams::default(),
            sampling: Sampling::Uniform,
        }
    }
}

impl SmsParams {
    /// Refuses parameters the method cannot run with, naming the command-line option.
    pub fn validate(&self) -> Result<(), SaliencyError> {
        if self.samples < 2 {
            return Err(SaliencyError::Invalid(format!(
                "--samples must be at least 2 (got {})",
                self.samples
            )));
        }
        if !(self.mu > 0.0 && self.mu <= 1.0) {
            return Err(SaliencyError::Invalid(format!(
                "--mu must be in (0, 1] (got {})",
                self.mu
            )));
        }
        if !(self.sigma > 0.0 && self.sigma.is_finite()) {
            return Err(SaliencyError::Invalid(format!(
                "--sigma must be positive (got {})",
                self.sigma
            )));
        }
        if self.descriptor.scales.is_empty() {
            return Err(SaliencyError::Invalid(
                "--scales needs at least one radius".into(),
            ));
        }
        if let Some(s) = self
            .descriptor
            .scales
            .iter()
            .find(|s| !(**s > 0.0 && s.is_finite()))
        {
            return Err(SaliencyError::Invalid(format!(
                "every scale must be a positive radius (got {s})"
            )));
        }
        if self.descriptor.shells == 0 || self.descriptor.bands == 0 {
            return Err(SaliencyError::Invalid(
                "--shells and --bands must be at least 1".into(),
            ));
        }
        if self.descriptor.quadrature_rings < self.descriptor.bands {
            return Err(SaliencyError::Invalid(format!(
                "--quadrature-rings ({}) must be at least --bands ({}) to resolve the bands",
                self.descriptor.quadrature_rings, self.descriptor.bands
            )));
        }
        Ok(())
    }
}

/// Optional extra maps (paper Figs. 2 and 3).
#[derive(Debug, Clone, Copy, Default)]
pub struct SmsExtras {
    /// One map per scale, from that scale's metric alone.
    pub per_scale: bool,
    /// The map without sparsity (μ = 1: the principal eigenvector).
    pub dense: bool,
}

/// Seconds of the paper's three steps (Table 3's columns).
#[derive(Debug, Clone, Serialize)]
pub struct StepTimings {
    /// A: normalization, sampling, distance field, descriptors.
    pub a_metric_s: f64,
    /// of which building the distance field.
    pub a_field_s: f64,
    /// B: principal eigenvalue and truncated power method.
    pub b_saliency_s: f64,
    /// C: interpolation to vertices.
    pub c_interpolation_s: f64,
    /// The whole run.
    pub total_s: f64,
}

/// What a run did, for the JSON sidecar: the frame, the field, the convergence of both power
/// iterations, the interpolation, the sparsity and the time of each step.
#[derive(Debug, Clone, Serialize)]
pub struct SmsReport {
    /// The normalization applied (centre, scale, box).
    pub normalization: Normalization,
    /// The distance-field grid's voxel size, normalized units (None: exact field).
    pub grid_voxel_size: Option<f64>,
    /// The Gaussian smoothing σ of the distance field, normalized units.
    pub gedt_sigma: Option<f64>,
    /// The metric's principal eigenvalue and its convergence.
    pub principal_eigenvalue: EigenReport,
    /// The truncated power method's convergence and support.
    pub truncated_power: TruncatedPowerReport,
    /// How the samples were carried to vertices.
    pub interpolation: InterpolationReport,
    /// Gini index of the vertex map.
    pub gini_vertices: f64,
    /// Gini index of the sample saliency.
    pub gini_samples: f64,
    /// Seconds per step.
    pub timings: StepTimings,
}

/// One of the optional maps ([`SmsExtras`]).
#[derive(Debug, Clone)]
pub struct ExtraMap {
    /// `scale<r>` (one per descriptor radius) or `dense`: the suffix of its files.
    pub name: String,
    /// One value per input vertex, in [0, 1].
    pub vertex_saliency: Vec<f64>,
    /// Its Gini index.
    pub gini: f64,
}

/// What [`sparse_metric_saliency`] returns.
#[derive(Debug, Clone)]
pub struct SmsResult {
    /// One value per input vertex, in input order, in [0, 1].
    pub vertex_saliency: Vec<f64>,
    /// Sample positions in the input frame.
    pub sample_points: Vec<DVec3>,
    /// The sparse unit eigenvector (≥ 0, at most μn non-zeros).
    pub sample_saliency: Vec<f64>,
    /// The extra maps asked for.
    pub extras: Vec<ExtraMap>,
    /// What the run did.
    pub report: SmsReport,
}

/// Samples, their positions in the normalized frame, and the descriptors.
struct StageA {
    normalization: Normalization,
    normalized: Mesh,
    centers: Vec<DVec3>,
    descriptors: Descriptors,
    field_s: f64,
    grid: Option<(f64, f64)>,
}

fn stage_a(mesh: &Mesh, params: &SmsParams, progress: &dyn Progress) -> Result<StageA, String> {
    let normalization = Normalization::of_mesh(mesh, params.bounding_box);
    let normalized = normalization.normalized_mesh(mesh);
    let samples = sample_surface_with(&normalized, params.samples, params.seed, params.sampling);
    if samples.is_empty() {
        return Err("the mesh has zero surface area: nothing to sample".into());
    }
    let centers: Vec<DVec3> = samples.iter().map(|s| s.point).collect();
    let (descriptors, (field_s, grid)) = describe(&normalized, &centers, params, progress)?;
    Ok(StageA {
        normalization,
        normalized,
        centers,
        descriptors,
        field_s,
        grid,
    })
}

/// Seconds spent building the field, and its (voxel size, Gaussian width).
type FieldFacts = (f64, Option<(f64, f64)>);

/// Descriptors at `centers` of the normalized mesh with the field `params` asks for.
fn describe(
    normalized: &Mesh,
    centers: &[DVec3],
    params: &SmsParams,
    progress: &dyn Progress,
) -> Result<(Descriptors, FieldFacts), String> {
    let tick = |k: usize| progress.advance(k as u64);
    let t_field = Instant::now();
    Ok(match params.field {
        FieldKind::Grid => {
            progress.start("distance field", 0);
            let field = GridField::build(normalized, params.descriptor.max_radius(), params.grid)
                .map_err(|e| e.to_string())?;
            let field_s = t_field.elapsed().as_secs_f64();
            progress.finish();
            progress.start("descriptors", centers.len() as u64);
            let d = compute_descriptors(&field, centers, &params.descriptor, &tick);
            progress.finish();
            (d, (field_s, Some((field.h, field.sigma))))
        }
        FieldKind::Exact => {
            // Same Gaussian width the grid would use at this resolution, for comparability.
            let (lo, hi) = normalized.referenced_bounds().ok_or("no triangle")?;
            let (_, h) = grid_geometry(lo, hi, params.descriptor.max_radius(), params.grid)?;
            let field = ExactField {
                mesh: normalized,
                sigma: params.grid.sigma_voxels * h,
            };
            progress.start("descriptors (exact field)", centers.len() as u64);
            let d = compute_descriptors(&field, centers, &params.descriptor, &tick);
            progress.finish();
            (d, (0.0, Some((h, field.sigma))))
        }
    })
}

/// Sparse saliency of samples from descriptors: principal eigenpair, then truncated power.
pub fn sparse_sample_saliency(
    descriptors: &Descriptors,
    mu: f64,
    power: PowerParams,
) -> (Vec<f64>, EigenReport, TruncatedPowerReport) {
    let metric = DescriptorMetric::new(descriptors);
    let (eigen, v1) = principal_eigenpair(&metric, power);
    let k = ((mu * descriptors.n as f64).round() as usize).clamp(1, descriptors.n);
    let (tp, x) = truncated_power(&metric, eigen.value, &v1, k, power);
    (x, eigen, tp)
}

/// Runs SMS on `mesh` (any frame; it is normalized internally).
pub fn sparse_metric_saliency(
    mesh: &Mesh,
    params: &SmsParams,
    extras: SmsExtras,
    progress: &dyn Progress,
) -> Result<SmsResult, SaliencyError> {
    params.validate()?;
    let t0 = Instant::now();
    let a = stage_a(mesh, params, progress).map_err(SaliencyError::Compute)?;
    let a_s = t0.elapsed().as_secs_f64();

    let t1 = Instant::now();
    progress.start("sparse eigenvector", 0);
    let (x, eigen, tp) = sparse_sample_saliency(&a.descriptors, params.mu, params.power);
    progress.finish();
    let b_s = t1.elapsed().as_secs_f64();

    let t2 = Instant::now();
    let to_vertices = |values: &[f64]| {
        let (mut v, report) = gaussian_interpolation(
            &a.centers,
            values,
            &a.normalized.positions,
            params.sigma,
            params.interpolation,
        );
        min_max_normalize(&mut v);
        (v, report)
    };
    let (vertex_saliency, interpolation) = to_vertices(&x);
    let c_s = t2.elapsed().as_secs_f64();
    let total_s = t0.elapsed().as_secs_f64();

    let mut extra_maps = Vec::new();
    if extras.dense {
        let (xd, _, _) = sparse_sample_saliency(&a.descriptors, 1.0, params.power);
        let (v, _) = to_vertices(&xd);
        extra_maps.push(ExtraMap {
            name: "dense".into(),
            gini: gini_index(&v),
            vertex_saliency: v,
        });
    }
    if extras.per_scale {
        let block = params.descriptor.per_scale_len();
        for (k, s) in params.descriptor.scales.iter().enumerate() {
            let dk = a.descriptors.columns(k * block, block);
            let (xk, _, _) = sparse_sample_saliency(&dk, params.mu, params.power);
            let (v, _) = to_vertices(&xk);
            extra_maps.push(ExtraMap {
                name: format!("scale{s}"),
                gini: gini_index(&v),
                vertex_saliency: v,
            });
        }
    }

    let inv = 1.0 / a.normalization.scale;
    let center = DVec3::from_array(a.normalization.center);
    let report = SmsReport {
        normalization: a.normalization,
        grid_voxel_size: a.grid.map(|g| g.0),
        gedt_sigma: a.grid.map(|g| g.1),
        principal_eigenvalue: eigen,
        truncated_power: tp,
        interpolation,
        gini_vertices: gini_index(&vertex_saliency),
        gini_samples: gini_index(&x),
        timings: StepTimings {
            a_metric_s: a_s,
            a_field_s: a.field_s,
            b_saliency_s: b_s,
            c_interpolation_s: c_s,
            total_s,
        },
    };
    Ok(SmsResult {
        vertex_saliency,
        sample_points: a.centers.iter().map(|p| *p * inv + center).collect(),
        sample_saliency: x,
        extras: extra_maps,
        report,
    })
}

/// Descriptors of the given points (input frame) of `mesh`, computed exactly as SMS does:
/// the same normalization, field and parameters. Exposed for validation and research.
pub fn descriptors_at(
    mesh: &Mesh,
    points: &[DVec3],
    params: &SmsParams,
) -> Result<Descriptors, SaliencyError> {
    let normalization = Normalization::of_mesh(mesh, params.bounding_box);
    let normalized = normalization.normalized_mesh(mesh);
    let centers: Vec<DVec3> = points.iter().map(|&p| normalization.apply(p)).collect();
    Ok(
        describe(&normalized, &centers, params, &crate::progress::Silent)
            .map_err(SaliencyError::Compute)?
            .0,
    )
}

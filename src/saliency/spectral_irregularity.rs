//! "SI": mesh saliency via spectral processing (Song, Liu, Martin, Rosin, ACM TOG 2014),
//! single scale, as in its public MATLAB code (see docs/baselines.md for the choices):
//! 1. simplify large meshes (quadric edge collapse) to `vertices` vertices;
//! 2. Laplacian L = D − W with W_ij = 1/‖v_i − v_j‖² on edges (mesh normalized first);
//! 3. full eigendecomposition L = B Λ Bᵀ (by default in f32 refined in f64:
//!    `laplacian_spectrum.rs` says why and how close);
//! 4. log spectrum ℒ = log λ (the constant modes, λ = 0, are set to 1: log 0);
//! 5. spectral irregularity R = |ℒ − box₉ * ℒ| (centred 9-tap mean, edges replicated);
//! 6. S = (B diag(e^R) Bᵀ) ∘ W, saliency_i = Σ_j S_ij;
//!
//! 7. the map is log |saliency_i| (floored at 1e-12 of the largest |saliency|): raw values span
//!    orders of magnitude, and the public code (GeoNotes `SpecSaliency/saliency_main.m`) shows
//!    log(abs(saliency)) too; a linear rescale leaves all but a few vertices at one value;
//!
//! then carried back to every input vertex from its nearest simplified vertex, smoothed over
//! the surface (area-weighted Gaussian, σ = `smoothing_sigma` normalized units: Song et al.
//! end with a Gaussian smoothing whose width the paper does not give; 0.02 is SMS's σ) and
//! rescaled to [0, 1].
use crate::saliency::SaliencyError;
use serde::Serialize;

use super::laplacian_spectrum::{laplacian_spectrum, Eigensolver, LaplacianSpectrum};
use super::sms::gaussian_interpolation::min_max_normalize;
use crate::mesh::clustered_gaussian_average::{clustered_gaussian_average, GaussianSum};
use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::simplification::simplify_to_vertex_count;
use crate::mesh::transfer_by_nearest_vertex;
use crate::mesh::vertex_areas::vertex_areas;
use crate::mesh::Mesh;
use crate::scoring::surface_blur::SurfaceBlur;

/// Parameters of SI (Song et al. 2014).
#[derive(Debug, Clone, Serialize)]
pub struct SpectralParams {
    /// Vertices of the simplified copy the spectrum is computed on.
    pub vertices: usize,
    /// Width of the box filter on the log spectrum.
    pub box_width: usize,
    /// Final surface smoothing σ in normalized units (0 = none).
    pub smoothing_sigma: f64,
    /// How the smoothing's Gaussian sums (cut at 3σ) are computed.
    pub smoothing_sum: GaussianSum,
    /// How the Laplacian's eigenpairs are computed.
    pub eigensolver: Eigensolver,
}

impl Default for SpectralParams {
    fn default() -> Self {
        SpectralParams {
            vertices: 2500,
            box_width: 9,
            smoothing_sigma: 0.02,
            // At 3 cells per σ the map is within 6e-4 of the exact sum's on the bunny and
            // the armadillo (tests/gaussian_sum.rs): the input is piecewise constant over
            // ~2,500 patches, smooth at the scale of the clusters.
            smoothing_sum: GaussianSum::Clustered {
                cells_per_sigma: 3.0,
            },
            // f32 and a Rayleigh–Ritz step on windows of 128: SI on the 50k armadillo in
            // 2.8–3.1 CPU-s instead of 3.3–4.9, the map within 9e-4 of f64's there and 9e-3 on
            // the bundled bunny, Pearson ≥ 0.999997 (tests/gaussian_sum.rs).
            eigensolver: Eigensolver::SingleRefined { window: 128 },
        }
    }
}

/// What a run of SI met.
#[derive(Debug, Clone, Serialize)]
pub struct SpectralReport {
    /// Vertices of the simplified copy.
    pub simplified_vertices: usize,
    /// Triangles of the simplified copy.
    pub simplified_triangles: usize,
    /// Zero eigenvalues (the constant modes), taken as log λ = 0 in the log spectrum: those at
    /// or below 10⁻¹² of the largest with the f64 solver, one per connected component with
    /// the refined f32 one.
    pub zero_eigenvalues: usize,
}

/// Per-vertex SI saliency in [0, 1] (input order and count).
pub fn spectral_irregularity(
    mesh: &Mesh,
    params: &SpectralParams,
) -> Result<(Vec<f64>, SpectralReport), SaliencyError> {
    let norm = Normalization::of_mesh(mesh, BoundingBox::Oriented);
    let normalized = norm.normalized_mesh(mesh);
    let (small, _) = if normalized.positions.len() > params.vertices {
        simplify_to_vertex_count(&normalized, params.vertices)
    } else {
        let all = (0..normalized.positions.len()).collect();
        (normalized.clone(), all)
    };
    let n = small.positions.len();
    if n < 3 || small.triangles.is_empty() {
        return Err(SaliencyError::Compute(
            "the simplified mesh has no triangle left".into(),
        ));
    }
    let edges = unique_edges(&small);
    let weight = |a: usize, b: usize| {
        let d2 = (small.positions[a] - small.positions[b]).length_squared();
        if d2 > 0.0 {
            1.0 / d2
        } else {
            0.0
        }
    };
    let LaplacianSpectrum {
        values: lambda,
        vectors: basis,
        zero_modes: zero,
    } = laplacian_spectrum(n, &edges, &weight, params.eigensolver)
        .map_err(SaliencyError::Compute)?;
    let e = exp_log_spectrum_irregularity(&lambda, zero, params.box_width);
    // saliency_i = Σ_{j∈N(i)} W_ij Σ_k B_ik e_k B_jk. faer stores B by columns, so a row of it
    // is strided by n: copied into rows first, each edge's sum reads two contiguous rows (the
    // same products in the same order).
    let mut rows = vec![0.0; n * n];
    for (k, column) in basis.col_iter().enumerate() {
        for (i, x) in column.iter().enumerate() {
            rows[i * n + k] = *x;
        }
    }
    let row = |i: usize| &rows[i * n..(i + 1) * n];
    let mut saliency_small = vec![0.0; n];
    for &(a, b) in &edges {
        let s: f64 = row(a)
            .iter()
            .zip(&e)
            .zip(row(b))
            .map(|((x, ek), y)| x * ek * y)
            .sum();
        let v = weight(a, b) * s;
        saliency_small[a] += v;
        saliency_small[b] += v;
    }
    let largest = saliency_small.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let floor = 1e-12 * largest.max(f64::MIN_POSITIVE);
    for v in saliency_small.iter_mut() {
        *v = v.abs().max(floor).ln();
    }
    // Back to every input vertex: the value of the nearest simplified vertex.
    let mut values =
        transfer_by_nearest_vertex(&small.positions, &saliency_small, &normalized.positions);
    if params.smoothing_sigma > 0.0 {
        values = smooth(&normalized, values, params);
    }
    min_max_normalize(&mut values);
    Ok((
        values,
        SpectralReport {
            simplified_vertices: n,
            simplified_triangles: small.triangles.len(),
            zero_eigenvalues: zero,
        },
    ))
}

/// Each undirected edge of the triangles once, (low, high), sorted.
fn unique_edges(mesh: &Mesh) -> Vec<(usize, usize)> {
    let mut edges: Vec<(usize, usize)> = Vec::new();
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k] as usize, t[(k + 1) % 3] as usize);
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges.sort_unstable();
    edges.dedup();
    edges
}

/// exp of each eigenvalue's spectral irregularity: |log λ_i − its box mean over
/// `box_width` neighbours in the spectrum|; the `zero` smallest (the constant modes) count as
/// log λ = 0.
fn exp_log_spectrum_irregularity(lambda: &[f64], zero: usize, box_width: usize) -> Vec<f64> {
    let n = lambda.len();
    let log_spectrum: Vec<f64> = lambda
        .iter()
        .enumerate()
        .map(|(k, &l)| if k < zero { 0.0 } else { l.ln() })
        .collect();
    let half = box_width / 2;
    (0..n)
        .map(|i| {
            let mean = (0..box_width)
                .map(|k| log_spectrum[(i + k).saturating_sub(half).min(n - 1)])
                .sum::<f64>()
                / box_width as f64;
            (log_spectrum[i] - mean).abs().exp()
        })
        .collect()
}

/// The map blurred over the (normalized) surface at `smoothing_sigma`, exactly or clustered.
fn smooth(normalized: &Mesh, values: Vec<f64>, params: &SpectralParams) -> Vec<f64> {
    let sigma = params.smoothing_sigma;
    match params.smoothing_sum {
        GaussianSum::Exact => {
            let blur = SurfaceBlur::new(normalized.positions.clone(), vertex_areas(normalized));
            blur.blur(&[&values], sigma).remove(0)
        }
        GaussianSum::Clustered { cells_per_sigma } => {
            // The same sum as SurfaceBlur's: area-weighted, cut at 3σ, a vertex
            // without area-carrying neighbours keeps its value.
            let areas = vertex_areas(normalized);
            let carrying: Vec<usize> = (0..areas.len()).filter(|&i| areas[i] > 0.0).collect();
            let pick = |x: &[f64]| carrying.iter().map(|&i| x[i]).collect::<Vec<f64>>();
            let points: Vec<_> = carrying.iter().map(|&i| normalized.positions[i]).collect();
            clustered_gaussian_average(
                &points,
                &pick(&areas),
                &pick(&values),
                &normalized.positions,
                sigma,
                3.0 * sigma,
                cells_per_sigma,
            )
            .into_iter()
            .zip(&values)
            .map(|(a, own)| a.unwrap_or(*own))
            .collect()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::load_mesh;

    #[test]
    fn si_runs_on_a_real_mesh_and_is_deterministic() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("stimuli/meshes/bun_zipper_res2.ply");
        let (mesh, _) = load_mesh(&path).unwrap();
        let params = SpectralParams {
            vertices: 800,
            ..Default::default()
        };
        let (a, report) = spectral_irregularity(&mesh, &params).unwrap();
        assert_eq!(a.len(), mesh.positions.len());
        assert!(
            report.simplified_vertices <= 900 && report.simplified_vertices >= 600,
            "{report:?}"
        );
        assert!(a.iter().all(|v| (0.0..=1.0).contains(v)));
        let (b, _) = spectral_irregularity(&mesh, &params).unwrap();
        assert_eq!(a, b);
    }

    /// A known answer: a sphere of 10,242 vertices with one smooth bump (height 0.25 of the
    /// radius, Gaussian in angle with width 0.15 rad). At the defaults SI must put its
    /// maximum and its 50 highest vertices on the bump (2.3% of the vertices). On a 2,562-vertex
    /// icosphere the simplification to 2,500 keeps the icosahedral pattern, and SI answers its
    /// 12 valence-5 vertices instead; 10,242 vertices are simplified into an irregular mesh.
    #[test]
    fn si_finds_the_one_bump_on_a_sphere() {
        let mut mesh = crate::mesh::test_meshes::icosphere(1.0, 5);
        let axis = glam::DVec3::new(0.3, 0.5, 0.81).normalize();
        let mut on_bump = Vec::new();
        for p in mesh.positions.iter_mut() {
            let angle = p.normalize().dot(axis).clamp(-1.0, 1.0).acos();
            *p *= 1.0 + 0.25 * (-(angle / 0.15).powi(2)).exp();
            on_bump.push(angle < 0.3);
        }
        let bump = on_bump.iter().filter(|b| **b).count();
        assert_eq!(mesh.positions.len(), 10_242);
        assert!(bump > 150 && bump < 300, "{bump}");
        let (s, _) = spectral_irregularity(&mesh, &SpectralParams::default()).unwrap();
        let mut order: Vec<usize> = (0..s.len()).collect();
        order.sort_by(|&a, &b| s[b].total_cmp(&s[a]));
        let top_on_bump = order[..50].iter().filter(|&&v| on_bump[v]).count();
        let mean = |on: bool| {
            let v: Vec<f64> = (0..s.len())
                .filter(|&i| on_bump[i] == on)
                .map(|i| s[i])
                .collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        assert!(on_bump[order[0]], "the maximum is off the bump");
        assert_eq!(top_on_bump, 50, "of the 50 highest vertices");
        assert!(
            mean(true) > 2.0 * mean(false),
            "{} vs {}",
            mean(true),
            mean(false)
        );
    }
}

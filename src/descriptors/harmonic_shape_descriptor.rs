//! Local harmonic shape descriptor (Kazhdan et al. 2003, as used by Shilane & Funkhouser 2007
//! and the paper §3.3): the Gaussian distance field inside a ball around a surface point,
//! cut into concentric shells; on each shell, the L2 norm of each spherical-harmonic band.
//! Band norms do not change when the shape rotates, so no local frame is needed.
use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::gaussian_distance_field::GaussianField;
use super::spherical_harmonics::{real_spherical_harmonics, SphereQuadrature};

/// How shell samples are weighted before the transform.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum ShellWeight {
    /// Multiply by r·√(4π), the square root of the shell's area, as ShapeSPH does: larger
    /// shells count more, like the volume they stand for.
    Area,
    /// No weight: every shell counts the same.
    None,
}

/// Whether each scale's descriptor is rescaled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum DescriptorNormalization {
    /// Keep magnitudes: how much surface a ball holds is part of its shape.
    Raw,
    /// Divide each scale's vector by its L2 norm (ShapeSPH's global descriptor does this).
    Unit,
}

#[derive(Debug, Clone, Serialize)]
pub struct DescriptorParams {
    /// Ball radii in normalized units (paper: 0.02, 0.04, 0.06, 0.08, 0.10).
    pub scales: Vec<f64>,
    /// Concentric shells per ball (paper: 8); radii (j + ½)·s/shells.
    pub shells: usize,
    /// Spherical-harmonic bands l = 0..bands-1 (paper: 8).
    pub bands: usize,
    /// Gauss–Legendre rings of the sphere quadrature (2·rings longitudes).
    pub quadrature_rings: usize,
    pub shell_weight: ShellWeight,
    pub normalization: DescriptorNormalization,
}

impl Default for DescriptorParams {
    fn default() -> Self {
        DescriptorParams {
            scales: vec![0.02, 0.04, 0.06, 0.08, 0.10],
            shells: 8,
            bands: 8,
            quadrature_rings: 16,
            shell_weight: ShellWeight::Area,
            normalization: DescriptorNormalization::Raw,
        }
    }
}

impl DescriptorParams {
    pub fn per_scale_len(&self) -> usize {
        self.shells * self.bands
    }
    pub fn len(&self) -> usize {
        self.scales.len() * self.per_scale_len()
    }
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    pub fn max_radius(&self) -> f64 {
        self.scales.iter().cloned().fold(0.0, f64::max)
    }
}

/// Row-major n × dim matrix of descriptors; columns are [scale][shell][band].
#[derive(Debug, Clone, PartialEq)]
pub struct Descriptors {
    pub n: usize,
    pub dim: usize,
    pub data: Vec<f64>,
}

impl Descriptors {
    pub fn row(&self, i: usize) -> &[f64] {
        &self.data[i * self.dim..(i + 1) * self.dim]
    }

    /// The columns of one contiguous block (e.g. one scale), as a new matrix.
    pub fn columns(&self, start: usize, len: usize) -> Descriptors {
        let mut data = Vec::with_capacity(self.n * len);
        for i in 0..self.n {
            data.extend_from_slice(&self.row(i)[start..start + len]);
        }
        Descriptors {
            n: self.n,
            dim: len,
            data,
        }
    }
}

/// Precomputed projection: weight × harmonic for every quadrature direction.
struct Projector {
    directions: Vec<DVec3>,
    /// [direction][lm], quadrature weight folded in.
    basis: Vec<f32>,
    coeffs: usize,
}

impl Projector {
    fn new(params: &DescriptorParams) -> Projector {
        let q = SphereQuadrature::gauss_legendre_product(params.quadrature_rings);
        let coeffs = params.bands * params.bands;
        let mut basis = Vec::with_capacity(q.directions.len() * coeffs);
        let mut y = vec![0.0; coeffs];
        for (d, w) in q.directions.iter().zip(&q.weights) {
            real_spherical_harmonics(*d, params.bands, &mut y);
            basis.extend(y.iter().map(|v| (v * w) as f32));
        }
        Projector {
            directions: q.directions,
            basis,
            coeffs,
        }
    }
}

/// Descriptors of balls centred at `centers` (normalized frame), in parallel. The result is
/// the same for any thread count: rows are computed independently.
pub fn compute_descriptors<F: GaussianField>(
    field: &F,
    centers: &[DVec3],
    params: &DescriptorParams,
    progress: &(dyn Fn(usize) + Sync),
) -> Descriptors {
    let projector = Projector::new(params);
    let dim = params.len();
    let mut data = vec![0.0; centers.len() * dim];
    data.par_chunks_mut(dim)
        .zip(centers.par_iter())
        .for_each_init(
            || {
                (
                    vec![0f32; projector.directions.len()],
                    vec![0f32; projector.coeffs],
                )
            },
            |(samples, coeffs), (row, &center)| {
                describe_one(field, center, params, &projector, samples, coeffs, row);
                progress(1);
            },
        );
    Descriptors {
        n: centers.len(),
        dim,
        data,
    }
}

fn describe_one<F: GaussianField>(
    field: &F,
    center: DVec3,
    params: &DescriptorParams,
    projector: &Projector,
    samples: &mut [f32],
    coeffs: &mut [f32],
    row: &mut [f64],
) {
    let per_scale = params.per_scale_len();
    let coeff_count = projector.coeffs;
    for (k, &scale) in params.scales.iter().enumerate() {
        let block = &mut row[k * per_scale..(k + 1) * per_scale];
        for shell in 0..params.shells {
            let radius = (shell as f64 + 0.5) / params.shells as f64 * scale;
            for (s, d) in samples.iter_mut().zip(&projector.directions) {
                *s = field.value(center + *d * radius);
            }
            coeffs.fill(0.0);
            for (s, basis_row) in samples
                .iter()
                .zip(projector.basis.chunks_exact(coeff_count))
            {
                if *s != 0.0 {
                    for (c, b) in coeffs.iter_mut().zip(basis_row) {
                        *c += s * b;
                    }
                }
            }
            let weight = match params.shell_weight {
                ShellWeight::Area => radius * (4.0 * std::f64::consts::PI).sqrt(),
                ShellWeight::None => 1.0,
            };
            for l in 0..params.bands {
                let band = &coeffs[l * l..(l + 1) * (l + 1)];
                let energy: f64 = band.iter().map(|&c| (c as f64) * (c as f64)).sum();
                block[shell * params.bands + l] = weight * energy.sqrt();
            }
        }
        if params.normalization == DescriptorNormalization::Unit {
            let norm = block.iter().map(|v| v * v).sum::<f64>().sqrt();
            if norm > 0.0 {
                block.iter_mut().for_each(|v| *v /= norm);
            }
        }
    }
}

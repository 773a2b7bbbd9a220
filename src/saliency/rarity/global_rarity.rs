//! "GR": mesh saliency with global rarity (Wu, Shen, Zhu, Liu, Graphical Models 2013), as
//! reconstructed in docs/baselines.md (no public code exists; choices are parameters):
//! 1. per-vertex local shape: Zernike coefficients of the height map over the tangent plane at
//!    several radii;
//! 2. local contrast at each radius r: the Gaussian-weighted (σ = r, cut at 2r) area-weighted
//!    mean descriptor difference between a vertex and its surroundings, averaged over radii;
//! 3. global rarity: over-segment into patches, describe each by its vertices' mean
//!    descriptor, and rate it by its area-weighted mean descriptor distance to every patch of
//!    the mesh (a shape that covers much of the surface is common, hence not rare);
//! 4. S = w·local + (1 − w)·rarity.
//!
//! Both terms stay in the descriptor's own units (Zernike moments of heights in units of the
//! radius) until the final rescale: dividing each by its maximum first would stretch a
//! featureless shape's numerical noise into a full-range map.
use crate::saliency::SaliencyError;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::working_copy::{RawSpread, WorkingCopy, WorkingCopyReport};
use super::zernike_patches::{ZernikePatches, ZernikePatchesParams};
use crate::mesh::over_segmentation::Patches;
use crate::mesh::Mesh;

/// Parameters of GR (Wu et al. 2013); docs/baselines.md gives the choices.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GrParams {
    /// Vertices of the simplified working copy.
    pub vertices: usize,
    /// Height-map radii (normalized units: half the bounding-box diagonal = 1).
    pub radii: Vec<f64>,
    /// Highest Zernike order (8: 25 coefficients per radius).
    pub order: usize,
    /// Patches of the over-segmentation the rarity is measured over.
    pub patches: usize,
    /// w: weight of local contrast against global rarity.
    pub local_weight: f64,
    /// Seed of the over-segmentation's first patch centre.
    pub seed: u64,
}

impl Default for GrParams {
    fn default() -> Self {
        GrParams {
            vertices: 10_000,
            radii: vec![0.05, 0.1, 0.2],
            order: 8,
            patches: 500,
            local_weight: 0.5,
            seed: 1,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct GrReport {
    pub working_copy: WorkingCopyReport,
    /// The map on the working copy before rescaling.
    pub raw: RawSpread,
    pub patches: usize,
    pub descriptor_length: usize,
}

impl GrParams {
    /// What GR's working copy, descriptors and patches depend on.
    pub fn zernike_patches(&self) -> ZernikePatchesParams {
        ZernikePatchesParams {
            vertices: self.vertices,
            radii: self.radii.clone(),
            order: self.order,
            patches: self.patches,
            seed: self.seed,
        }
    }

    pub(crate) fn validate(&self) -> Result<(), SaliencyError> {
        if self.radii.is_empty() || !(0.0..=1.0).contains(&self.local_weight) {
            return Err(SaliencyError::Invalid(
                "gr needs at least one radius and local_weight in [0, 1]".into(),
            ));
        }
        Ok(())
    }
}

/// GR's map of `mesh`, one value per input vertex, with its report.
pub fn global_rarity_saliency(
    mesh: &Mesh,
    params: &GrParams,
) -> Result<(Vec<f64>, GrReport), SaliencyError> {
    params.validate()?;
    let shared = ZernikePatches::new(mesh, &params.zernike_patches())?;
    global_rarity_saliency_from(&shared, params)
}

/// [`global_rarity_saliency`] from inputs already built (shared with MR when their
/// parameters agree).
pub fn global_rarity_saliency_from(
    shared: &ZernikePatches,
    params: &GrParams,
) -> Result<(Vec<f64>, GrReport), SaliencyError> {
    params.validate()?;
    let (work, z, patches) = shared.built_with(&params.zernike_patches(), "gr")?;
    let per_radius = z[0].len() / params.radii.len();
    let n = work.len();

    let mut local = vec![0.0; n];
    for (s, &r) in params.radii.iter().enumerate() {
        let span = s * per_radius..(s + 1) * per_radius;
        let contrast: Vec<f64> = (0..n)
            .into_par_iter()
            .map(|v| {
                let p = work.mesh.positions[v];
                let own = &z[v][span.clone()];
                let (mut num, mut den) = (0.0, 0.0);
                for near in work.within(p, 2.0 * r).chunks(LANES) {
                    let apart = squared_distances(own, near, |u| &z[u][span.clone()]);
                    for (&u, d2) in near.iter().zip(apart) {
                        if u == v {
                            continue;
                        }
                        let w = work.areas[u]
                            * (-(work.mesh.positions[u] - p).length_squared() / (2.0 * r * r))
                                .exp();
                        num += w * d2.sqrt();
                        den += w;
                    }
                }
                if den > 0.0 {
                    num / den
                } else {
                    0.0
                }
            })
            .collect();
        for (acc, c) in local.iter_mut().zip(contrast) {
            *acc += c / params.radii.len() as f64;
        }
    }

    let (patch_desc, patch_area) = patch_descriptors(work, patches, z);
    let total_area: f64 = patch_area.iter().sum();
    let rarity: Vec<f64> = (0..patches.len())
        .into_par_iter()
        .map(|p| {
            (0..patches.len())
                .map(|q| patch_area[q] * distance(&patch_desc[p], &patch_desc[q]))
                .sum::<f64>()
                / total_area.max(f64::MIN_POSITIVE)
        })
        .collect();
    let saliency: Vec<f64> = (0..n)
        .map(|v| {
            let g = rarity[patches.label[v] as usize];
            params.local_weight * local[v] + (1.0 - params.local_weight) * g
        })
        .collect();
    Ok((
        work.carry_back(&saliency),
        GrReport {
            working_copy: work.report(),
            raw: RawSpread::of(&saliency, &work.areas),
            patches: patches.len(),
            descriptor_length: z[0].len(),
        },
    ))
}

/// Each patch's area-weighted mean vertex descriptor and its area.
pub(super) fn patch_descriptors(
    work: &WorkingCopy,
    patches: &Patches,
    z: &[Vec<f64>],
) -> (Vec<Vec<f64>>, Vec<f64>) {
    let dims = z.first().map_or(0, |r| r.len());
    let mut desc = vec![vec![0.0; dims]; patches.len()];
    let mut area = vec![0.0; patches.len()];
    for ((row, &label), &a) in z.iter().zip(&patches.label).zip(&work.areas) {
        let p = label as usize;
        area[p] += a;
        for (d, x) in desc[p].iter_mut().zip(row) {
            *d += a * x;
        }
    }
    for (d, &a) in desc.iter_mut().zip(&area) {
        if a > 0.0 {
            d.iter_mut().for_each(|x| *x /= a);
        }
    }
    (desc, area)
}

/// Neighbours whose descriptor distances are summed side by side.
const LANES: usize = 8;

/// ‖a − row(u)‖² for up to [`LANES`] neighbours u at once, each summed over the coordinates in
/// order as [`distance`] sums them (the same bits): one sum alone waits on each add, several
/// interleaved keep the adder busy.
fn squared_distances<'a>(
    a: &[f64],
    near: &[usize],
    row: impl Fn(usize) -> &'a [f64],
) -> [f64; LANES] {
    let mut rows: [&[f64]; LANES] = [a; LANES];
    for (slot, &u) in rows.iter_mut().zip(near) {
        *slot = row(u);
    }
    let mut sums = [0.0f64; LANES];
    for (c, x) in a.iter().enumerate() {
        for (sum, r) in sums.iter_mut().zip(&rows) {
            let d = x - r[c];
            *sum += d * d;
        }
    }
    sums
}

pub(super) fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Side by side or one at a time, a neighbour's distance is the same bits, for full and
    /// partial groups of neighbours.
    #[test]
    fn interleaved_distances_equal_one_at_a_time() {
        let rows: Vec<Vec<f64>> = (0..11)
            .map(|i| {
                (0..25)
                    .map(|c| ((i * 31 + c * 7) as f64 * 0.37).sin() * 10f64.powi(c % 5 - 2))
                    .collect()
            })
            .collect();
        let own = &rows[3];
        let near: Vec<usize> = (0..11).collect();
        for group in near.chunks(LANES) {
            let apart = squared_distances(own, group, |u| &rows[u]);
            for (&u, d2) in group.iter().zip(apart) {
                assert_eq!(d2.sqrt().to_bits(), distance(own, &rows[u]).to_bits());
            }
        }
    }
}

//! Saliency of sample points carried to mesh vertices by Gaussian filtering (paper Eq. 2):
//! ξ(v) = Σ_{p: ‖v−p‖<3σ} w_p φ(p) / Σ w_p, w_p = exp(−‖v−p‖²/(2σ²)), found with a kd-tree.
use glam::DVec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Whether the Gaussian sum is divided by the sum of weights (the paper's Eq. 2) or not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum InterpolationKind {
    /// Weighted mean (Nadaraya–Watson), as Eq. 2 writes it; independent of sample density.
    Normalized,
    /// Plain weighted sum: denser sampling reads as more salient.
    Sum,
}

/// How sample saliency was carried to vertices.
#[derive(Debug, Clone, Serialize)]
pub struct InterpolationReport {
    /// The Gaussian σ, normalized units.
    pub sigma: f64,
    /// The cutoff radius (3σ).
    pub radius: f64,
    /// Weighted mean or weighted sum.
    pub kind: InterpolationKind,
    /// Vertices with no sample within the radius; they take the nearest sample's value.
    pub vertices_without_sample_in_radius: usize,
}

/// Values at `targets` from values at `sources`, both in the normalized frame.
///
/// Targets are handled by cells of a uniform grid: each cell gathers once, in index order, the
/// sources within 3σ of the box its targets span, and each target then runs through that
/// short list. The sum for a target is over the same sources, in the same (index) order and
/// with the same arithmetic as a kd-tree query within 3σ sorted by index, so the result is
/// that query's to the bit (tested against it), without a tree walk and a sort per target.
pub fn gaussian_interpolation(
    sources: &[DVec3],
    values: &[f64],
    targets: &[DVec3],
    sigma: f64,
    kind: InterpolationKind,
) -> (Vec<f64>, InterpolationReport) {
    assert_eq!(sources.len(), values.len());
    let radius = 3.0 * sigma;
    let report = |fallback| InterpolationReport {
        sigma,
        radius,
        kind,
        vertices_without_sample_in_radius: fallback,
    };
    if sources.is_empty() {
        // Nothing to interpolate from: every target is without a sample, and has no value.
        return (vec![f64::NAN; targets.len()], report(targets.len()));
    }
    let r2 = radius * radius;
    let inv = 1.0 / (2.0 * sigma * sigma);
    // Built only if some target has no source within the radius.
    let tree: std::sync::OnceLock<ImmutableKdTree<f64, 3>> = std::sync::OnceLock::new();
    let nearest_value = |q: DVec3| {
        let tree = tree.get_or_init(|| {
            let points: Vec<[f64; 3]> = sources.iter().map(|p| p.to_array()).collect();
            ImmutableKdTree::new_from_slice(&points).expect("fewer than 2^32 samples")
        });
        let nearest = tree
            .query(&q.to_array())
            .nearest_one::<SquaredEuclidean<f64>>()
            .execute();
        values[nearest.item as usize]
    };
    let grid = CellGrid::new(sources, targets, radius);
    let source_cells = grid.bin(sources);
    let target_cells = grid.bin(targets);
    let reach = grid.reach(radius);
    let per_cell: Vec<Vec<(usize, f64, bool)>> = target_cells
        .occupied()
        .collect::<Vec<_>>()
        .into_par_iter()
        .map_init(Vec::new, |candidates: &mut Vec<u32>, cell| {
            let members = target_cells.members(cell);
            let (lo, hi) = members.iter().fold(
                (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), &t| (lo.min(targets[t as usize]), hi.max(targets[t as usize])),
            );
            // Sources that may lie within the radius of some target of the cell; the slack
            // keeps rounding in the box distance from dropping one the exact test keeps.
            candidates.clear();
            let [cx, cy, cz] = grid.coordinates(cell);
            for z in cz.saturating_sub(reach)..(cz + reach + 1).min(grid.dims[2]) {
                for y in cy.saturating_sub(reach)..(cy + reach + 1).min(grid.dims[1]) {
                    for x in cx.saturating_sub(reach)..(cx + reach + 1).min(grid.dims[0]) {
                        for &s in source_cells.members(grid.index([x, y, z])) {
                            let p = sources[s as usize];
                            let gap = (lo - p).max(p - hi).max(DVec3::ZERO);
                            if gap.length_squared() <= r2 * (1.0 + 1e-9) {
                                candidates.push(s);
                            }
                        }
                    }
                }
            }
            // Fixed summation order: by source index.
            candidates.sort_unstable();
            members
                .iter()
                .map(|&t| {
                    let q = targets[t as usize];
                    let (mut num, mut den, mut hits) = (0.0, 0.0, 0usize);
                    for &s in candidates.iter() {
                        let p = sources[s as usize];
                        // Squared distance summed axis by axis, as kiddo's SquaredEuclidean.
                        let (dx, dy, dz) = (q.x - p.x, q.y - p.y, q.z - p.z);
                        let d = dx * dx + dy * dy + dz * dz;
                        if d <= r2 {
                            let w = (-d * inv).exp();
                            num += w * values[s as usize];
                            den += w;
                            hits += 1;
                        }
                    }
                    if hits == 0 {
                        return (t as usize, nearest_value(q), true);
                    }
                    let value = match kind {
                        InterpolationKind::Normalized => num / den,
                        InterpolationKind::Sum => num,
                    };
                    (t as usize, value, false)
                })
                .collect()
        })
        .collect();
    let mut out = vec![0.0; targets.len()];
    let mut fallback = 0;
    for (t, value, without) in per_cell.into_iter().flatten() {
        out[t] = value;
        fallback += usize::from(without);
    }
    (out, report(fallback))
}

/// A uniform grid over the bounding box of two point sets, of cells about a third of the
/// radius wide (coarser if that would take more than about 4M cells).
struct CellGrid {
    lo: DVec3,
    side: f64,
    dims: [usize; 3],
}

/// Points binned by cell: the members of cell c are `order[starts[c]..starts[c + 1]]`, in
/// index order.
struct Binned {
    starts: Vec<u32>,
    order: Vec<u32>,
}

impl Binned {
    fn members(&self, cell: usize) -> &[u32] {
        &self.order[self.starts[cell] as usize..self.starts[cell + 1] as usize]
    }

    fn occupied(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.starts.len() - 1).filter(|&c| self.starts[c] < self.starts[c + 1])
    }
}

impl CellGrid {
    fn new(a: &[DVec3], b: &[DVec3], radius: f64) -> CellGrid {
        let (lo, hi) = a.iter().chain(b).fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        let extent = (hi - lo).max(DVec3::ZERO);
        const MAX_CELLS: f64 = 4_194_304.0;
        let mut side = radius / 3.0;
        let volume = |side: f64| {
            (extent / side + DVec3::ONE)
                .floor()
                .to_array()
                .iter()
                .product::<f64>()
        };
        if !(side > 0.0 && side.is_finite()) || volume(side) > MAX_CELLS {
            // A cube root of the overshoot, then doubling until it fits.
            side = (extent.max_element() / MAX_CELLS.cbrt()).max(f64::MIN_POSITIVE);
            while volume(side) > MAX_CELLS {
                side *= 2.0;
            }
        }
        let dims = (extent / side + DVec3::ONE)
            .floor()
            .to_array()
            .map(|d| d.max(1.0) as usize);
        CellGrid { lo, side, dims }
    }

    /// Cells on each side of a cell that can hold a point within `radius` of it.
    fn reach(&self, radius: f64) -> usize {
        let cells = (radius / self.side).ceil();
        if cells.is_finite() {
            (cells as usize + 1).min(self.dims.into_iter().max().unwrap_or(1))
        } else {
            self.dims.into_iter().max().unwrap_or(1)
        }
    }

    fn cell_of(&self, p: DVec3) -> usize {
        let c = ((p - self.lo) / self.side).floor().to_array();
        let clamp = |v: f64, d: usize| (v.max(0.0) as usize).min(d - 1);
        self.index([
            clamp(c[0], self.dims[0]),
            clamp(c[1], self.dims[1]),
            clamp(c[2], self.dims[2]),
        ])
    }

    fn index(&self, [x, y, z]: [usize; 3]) -> usize {
        (z * self.dims[1] + y) * self.dims[0] + x
    }

    fn coordinates(&self, cell: usize) -> [usize; 3] {
        let x = cell % self.dims[0];
        let y = (cell / self.dims[0]) % self.dims[1];
        [x, y, cell / (self.dims[0] * self.dims[1])]
    }

    /// A counting sort of `points` by cell, stable in index order.
    fn bin(&self, points: &[DVec3]) -> Binned {
        let cells: Vec<u32> = points.par_iter().map(|&p| self.cell_of(p) as u32).collect();
        let n_cells = self.dims.iter().product::<usize>();
        let mut starts = vec![0u32; n_cells + 1];
        for &c in &cells {
            starts[c as usize + 1] += 1;
        }
        for c in 0..n_cells {
            starts[c + 1] += starts[c];
        }
        let mut next = starts.clone();
        let mut order = vec![0u32; points.len()];
        for (i, &c) in cells.iter().enumerate() {
            order[next[c as usize] as usize] = i as u32;
            next[c as usize] += 1;
        }
        Binned { starts, order }
    }
}

/// Rescales to [0, 1] (all zeros if the values are constant).
pub fn min_max_normalize(values: &mut [f64]) {
    let lo = values.iter().cloned().fold(f64::INFINITY, f64::min);
    let hi = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let span = hi - lo;
    for v in values.iter_mut() {
        *v = if span > 0.0 { (*v - lo) / span } else { 0.0 };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kd-tree query within 3σ, its hits summed in index order: the definition the cell
    /// grid must reproduce to the bit.
    fn by_kd_tree(sources: &[DVec3], values: &[f64], targets: &[DVec3], sigma: f64) -> Vec<f64> {
        let points: Vec<[f64; 3]> = sources.iter().map(|p| p.to_array()).collect();
        let tree: ImmutableKdTree<f64, 3> = ImmutableKdTree::new_from_slice(&points).unwrap();
        let (radius, inv) = (3.0 * sigma, 1.0 / (2.0 * sigma * sigma));
        targets
            .iter()
            .map(|v| {
                let mut hits = tree
                    .query(&v.to_array())
                    .within::<SquaredEuclidean<f64>>(radius * radius)
                    .unsorted()
                    .execute();
                if hits.is_empty() {
                    let nearest = tree
                        .query(&v.to_array())
                        .nearest_one::<SquaredEuclidean<f64>>()
                        .execute();
                    return values[nearest.item as usize];
                }
                hits.sort_unstable_by_key(|h| h.item);
                let (mut num, mut den) = (0.0, 0.0);
                for h in &hits {
                    let w = (-h.distance * inv).exp();
                    num += w * values[h.item as usize];
                    den += w;
                }
                num / den
            })
            .collect()
    }

    fn scattered(n: usize, seed: f64) -> Vec<DVec3> {
        (0..n)
            .map(|i| {
                let t = i as f64 + seed;
                DVec3::new(
                    (t * 0.7310).sin() * (t * 0.0130).cos(),
                    (t * 1.3700).cos() * 0.8,
                    (t * 0.1930).sin() * (t * 0.0710).sin(),
                )
            })
            .collect()
    }

    #[test]
    fn cell_grid_gives_the_kd_tree_sums_to_the_bit() {
        let sources = scattered(3000, 0.25);
        let values: Vec<f64> = (0..sources.len())
            .map(|i| ((i * 37) % 101) as f64)
            .collect();
        let targets = scattered(20000, 7.5);
        // Wide, paper-sized and tiny (most targets fall back to the nearest source) widths.
        for sigma in [0.2, 0.02, 0.0007] {
            let (ours, report) = gaussian_interpolation(
                &sources,
                &values,
                &targets,
                sigma,
                InterpolationKind::Normalized,
            );
            let reference = by_kd_tree(&sources, &values, &targets, sigma);
            for (i, (a, b)) in ours.iter().zip(&reference).enumerate() {
                assert_eq!(
                    a.to_bits(),
                    b.to_bits(),
                    "σ {sigma}, target {i}: {a} vs {b}"
                );
            }
            if sigma < 0.001 {
                assert!(report.vertices_without_sample_in_radius > 1000);
            }
        }
    }

    #[test]
    fn no_sources_gives_no_values_and_says_so() {
        let (out, report) = gaussian_interpolation(
            &[],
            &[],
            &[DVec3::ZERO, DVec3::ONE],
            0.02,
            InterpolationKind::Normalized,
        );
        assert!(out.iter().all(|v| v.is_nan()));
        assert_eq!(report.vertices_without_sample_in_radius, 2);
    }
}

//! Gaussian blur of per-vertex maps over the surface: s_b(v) = Σ_u a_u s(u) K(u,v) / Σ_u a_u K(u,v)
//! with K = exp(−‖u−v‖²/2σ²) cut at 3σ (Euclidean) and a_u the vertex area (a third of its
//! triangles' areas), so dense tessellation does not weigh more. [`SurfaceBlur`] sums it in f64
//! over a grid of 3σ cubes (SI's smoothing); the scoring blur, [`GaussianBlur`], sums the same
//! kernel for every map at once in f32 blocks (`cut_gaussian_sums.rs`, within 10⁻⁵ of a map's
//! largest value, ten times faster), and at large σ (where merging the sources of each cube of
//! side σ/3 cuts the work) from merged sources with their moments to second order (within
//! 8·10⁻⁴ of a map's range, tested); there the chance band's random maps, read only as samples
//! of a distribution, are merged to first order (four channels each instead of ten:
//! [`GaussianBlur::blur_with_references`]). The blur is linear, so
//! a sum of maps blurs to the sum of the blurred maps (used for split-half human maps).
//! σ is in normalized units (half the bounding-box diagonal = 1).
use glam::DVec3;
use rayon::prelude::*;

use crate::mesh::Mesh;
use crate::scoring::cut_gaussian_sums::{
    cut_gaussian_sums, cut_gaussian_sums_then, split_denominator,
};
use crate::scoring::error::ScoreError;
use crate::scoring::exp_of_nonpositive::exp_of_nonpositive;
#[cfg(target_arch = "x86_64")]
use crate::scoring::exp_of_nonpositive::exp_of_nonpositive_avx2;
use crate::scoring::lattice_gauss_transform::{lattice_gauss_transform, lattice_work};

use crate::mesh::geometry::symmetric_outer;
use crate::mesh::vertex_areas::vertex_areas;

/// The Euclidean Gaussian blur's exact neighbourhood sums over a grid of 3σ cubes (the direct
/// part of [`GaussianBlur`], and SI's smoothing).
pub struct SurfaceBlur {
    positions: Vec<DVec3>,
    areas: Vec<f64>,
    /// Sources: vertices with area (unreferenced vertices carry no surface), in index order.
    sources: Vec<usize>,
}

/// Sources bucketed into cubes of side 3σ, so every source within 3σ of a point lies in the
/// 27 cubes around the point's own. Cubes hold sources in index order and are visited in a
/// fixed order, so each sum runs in the same order on any number of threads.
struct SourceGrid {
    cell: f64,
    /// Occupied cells, sorted by key; `starts[i]..starts[i + 1]` indexes `members`.
    keys: Vec<[i64; 3]>,
    starts: Vec<usize>,
    members: Vec<usize>,
}

impl SourceGrid {
    fn key(&self, p: DVec3) -> [i64; 3] {
        let c = (p / self.cell).floor();
        [c.x as i64, c.y as i64, c.z as i64]
    }

    fn new(positions: &[DVec3], sources: &[usize], cell: f64) -> SourceGrid {
        let mut grid = SourceGrid {
            cell,
            keys: Vec::new(),
            starts: Vec::new(),
            members: Vec::new(),
        };
        let mut keyed: Vec<([i64; 3], usize)> = sources
            .iter()
            .map(|&u| (grid.key(positions[u]), u))
            .collect();
        keyed.sort_unstable();
        for (i, (k, u)) in keyed.iter().enumerate() {
            if i == 0 || keyed[i - 1].0 != *k {
                grid.keys.push(*k);
                grid.starts.push(grid.members.len());
            }
            grid.members.push(*u);
        }
        grid.starts.push(grid.members.len());
        grid
    }

    fn cell_members(&self, key: [i64; 3]) -> &[usize] {
        match self.keys.binary_search(&key) {
            Ok(i) => &self.members[self.starts[i]..self.starts[i + 1]],
            Err(_) => &[],
        }
    }
}

impl SurfaceBlur {
    /// `positions` in normalized units, one area per vertex.
    pub fn new(positions: Vec<DVec3>, areas: Vec<f64>) -> SurfaceBlur {
        let sources: Vec<usize> = (0..positions.len()).filter(|&i| areas[i] > 0.0).collect();
        SurfaceBlur {
            positions,
            areas,
            sources,
        }
    }

    /// Blurs every map at σ; σ = 0 returns copies.
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Vec<Vec<f64>> {
        if sigma <= 0.0 || maps.is_empty() {
            return maps.iter().map(|m| m.to_vec()).collect();
        }
        let k = maps.len();
        let rows = row_major(maps);
        let (den, mut out) = self.direct_sums(&rows, k, sigma, 3.0 * sigma);
        for (v, num) in out.chunks_mut(k).enumerate() {
            if den[v] > 0.0 {
                num.iter_mut().for_each(|x| *x /= den[v]);
            } else {
                num.copy_from_slice(&rows[v * k..(v + 1) * k]);
            }
        }
        column_major(&out, k)
    }

    /// For every vertex v: Σ_u a_u K(u, v) and Σ_u a_u K(u, v) x_u (k channels, row-major), over
    /// the sources within `radius`.
    fn direct_sums(&self, rows: &[f64], k: usize, sigma: f64, radius: f64) -> (Vec<f64>, Vec<f64>) {
        let n = self.positions.len();
        let grid = SourceGrid::new(&self.positions, &self.sources, radius);
        let mut out = vec![0.0; n * k];
        let mut den = vec![0.0; n];
        if k == 0 {
            // Every map sparse: only the denominator is summed here.
            den.par_iter_mut().enumerate().for_each(|(v, den)| {
                *den = self.direct_sum_at(&grid, v, rows, &mut [], sigma, radius);
            });
            return (den, out);
        }
        out.par_chunks_mut(k)
            .zip(den.par_iter_mut())
            .enumerate()
            .for_each(|(v, (num, den))| {
                *den = self.direct_sum_at(&grid, v, rows, num, sigma, radius);
            });
        (den, out)
    }

    /// One vertex's sums: adds Σ a_u K x_u into `num`, returns Σ a_u K.
    fn direct_sum_at(
        &self,
        grid: &SourceGrid,
        v: usize,
        rows: &[f64],
        num: &mut [f64],
        sigma: f64,
        radius: f64,
    ) -> f64 {
        let k = num.len();
        let radius2 = radius * radius;
        let inv = 1.0 / (2.0 * sigma * sigma);
        let p = self.positions[v];
        let [cx, cy, cz] = grid.key(p);
        let mut den = 0.0;
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &u in grid.cell_members([cx + dx, cy + dy, cz + dz]) {
                        let d2 = self.positions[u].distance_squared(p);
                        if d2 > radius2 {
                            continue;
                        }
                        let w = self.areas[u] * (-d2 * inv).exp();
                        den += w;
                        for (acc, x) in num.iter_mut().zip(&rows[u * k..(u + 1) * k]) {
                            *acc += w * x;
                        }
                    }
                }
            }
        }
        den
    }

    /// Source pairs within `radius` a direct sum would visit, counted per cell (an upper bound:
    /// every source of the 27 cells around a vertex's own).
    fn direct_pairs(&self, radius: f64) -> f64 {
        let grid = SourceGrid::new(&self.positions, &self.sources, radius);
        let mut pairs = 0.0;
        for (i, key) in grid.keys.iter().enumerate() {
            let here = (grid.starts[i + 1] - grid.starts[i]) as f64;
            let mut around = 0;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        around += grid
                            .cell_members([key[0] + dx, key[1] + dy, key[2] + dz])
                            .len();
                    }
                }
            }
            pairs += here * around as f64;
        }
        pairs
    }
}

/// Maps as rows of k values per vertex: a sum over neighbours then reads one contiguous row
/// per neighbour instead of k scattered values.
fn row_major(maps: &[&[f64]]) -> Vec<f64> {
    let k = maps.len();
    let n = maps.first().map_or(0, |m| m.len());
    let mut rows = vec![0.0; n * k];
    for (m, map) in maps.iter().enumerate() {
        for (v, x) in map.iter().enumerate() {
            rows[v * k + m] = *x;
        }
    }
    rows
}

/// Channels per merged source for a map (and the denominator) at second order, and for a
/// reference at first order ([`GaussianBlur::clustered_sums`]).
const SECOND_ORDER: usize = 10;
const FIRST_ORDER: usize = 4;

/// Channels per merged source for dense maps flagged in `precise` (false: a reference), the
/// denominator's included ([`GaussianBlur::clustered_sums`]).
fn merged_width(precise: &[bool]) -> usize {
    SECOND_ORDER
        + precise
            .iter()
            .map(|&p| if p { SECOND_ORDER } else { FIRST_ORDER })
            .sum::<usize>()
}

/// A merged source's ten channels, (C0, C1, C2 as xx, yy, zz, 2xy, 2xz, 2yz), from its moments
/// M0, M1 and M2 (xx, yy, zz, xy, xz, yz) about its centroid c, with s = 1/σ²: the bracket
/// M0 − s tr M2/2 + s M1·(v − c) + s² (v − c)ᵀ M2 (v − c)/2 as C0 + C1·v + vᵀ C2 v.
fn second_order_terms(m0: f64, m1: DVec3, m2: [f64; 6], c: DVec3, s: f64, out: &mut [f64]) {
    let [xx, yy, zz, xy, xz, yz] = m2;
    let m2c = DVec3::new(
        xx * c.x + xy * c.y + xz * c.z,
        xy * c.x + yy * c.y + yz * c.z,
        xz * c.x + yz * c.y + zz * c.z,
    );
    let h = 0.5 * s * s;
    out[0] = m0 - 0.5 * s * (xx + yy + zz) - s * m1.dot(c) + h * c.dot(m2c);
    out[1..4].copy_from_slice(&(m1 * s - m2c * (s * s)).to_array());
    out[4..10].copy_from_slice(&[
        h * xx,
        h * yy,
        h * zz,
        2.0 * h * xy,
        2.0 * h * xz,
        2.0 * h * yz,
    ]);
}

/// C0 + C1·v + vᵀ C2 v from the ten channels' sums at target v.
fn second_order_at(t: &[f64], v: DVec3) -> f64 {
    t[0] + t[1] * v.x
        + t[2] * v.y
        + t[3] * v.z
        + t[4] * v.x * v.x
        + t[5] * v.y * v.y
        + t[6] * v.z * v.z
        + t[7] * v.x * v.y
        + t[8] * v.x * v.z
        + t[9] * v.y * v.z
}

fn column_major(rows: &[f64], k: usize) -> Vec<Vec<f64>> {
    let n = rows.len() / k.max(1);
    (0..k)
        .map(|m| (0..n).map(|v| rows[v * k + m]).collect())
        .collect()
}

/// The scoring blur: s_b(v) = Σ_u a_u s(u) K(u, v) / Σ_u a_u K(u, v) with K the Gaussian
/// exp(−‖u − v‖²/2σ²) cut at `cutoff` σ: 3 for [`BlurKernel::Euclidean`] (the same sum as
/// [`SurfaceBlur`], to 10⁻⁵ of a map's largest value), 5 for [`BlurKernel::Gaussian`] (the tail past 5σ is under 4·10⁻⁶ of the
/// peak: the full Gaussian for every purpose).
///
/// Sparse maps (fixation counts: a few hundred non-zero vertices) are summed exactly from their
/// non-zero vertices, however large σ is. The dense maps and the common denominator are summed
/// directly over the neighbourhoods, every map in one pass of f32 blocks (one exp per pair
/// serves them all: `scoring/cut_gaussian_sums.rs`); with the full Gaussian, where a direct sum would cost more,
/// by the lattice Gauss transform (`scoring/lattice_gauss_transform.rs`, within 10⁻⁵
/// of the map's range): one pass per σ for every map.
pub struct GaussianBlur {
    direct: SurfaceBlur,
    cutoff_sigmas: f64,
    lattice: bool,
}

/// Where [`BlurKernel::Gaussian`] cuts the Gaussian, in σ.
pub const FULL_GAUSSIAN_CUTOFF_SIGMAS: f64 = 5.0;

/// A map counts as sparse (summed from its non-zero vertices) below one non-zero in 64.
const SPARSE_FRACTION: usize = 64;

/// Which sum [`GaussianBlur`] uses for the dense maps at one σ.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GaussianSum {
    /// Summed over each vertex's neighbourhood, exactly.
    Direct,
    /// Summed over each vertex's neighbourhood from sources merged per cube of side
    /// σ / [`CLUSTERS_PER_SIGMA`], each with its moments to second order (large σ; see
    /// [`GaussianBlur::clustered_sums`]).
    Clustered,
    /// By the lattice Gauss transform (full kernel, large σ).
    Lattice,
}

/// Merged sources per σ along an axis: a cube of side σ/3 holds the sources one merged
/// source stands for. Moments to second order leave a Taylor error of order (1/3)³ of the
/// kernel's third derivative, and the cut taken at the centroid an error linear in the cube;
/// measured on the 50k armadillo against the exact sums, the methods' AUC-Judd within 1.5·10⁻⁴
/// and LCC within 5·10⁻⁴ at every blur (first moments on cubes of σ/6, the merge before,
/// gave 6·10⁻⁵ and 8·10⁻⁴ for twice the work; tests and the README).
pub const CLUSTERS_PER_SIGMA: f64 = 3.0;

/// Merging is chosen when it cuts the pairs' work by at least this factor (it costs a pass
/// to merge, and its grid is coarser than the targets' blocks need).
const CLUSTER_MARGIN: f64 = 1.5;

impl GaussianBlur {
    /// The Gaussian cut at 3σ, summed exactly: [`BlurKernel::Euclidean`].
    pub fn cut_at_three_sigma(positions: Vec<DVec3>, areas: Vec<f64>) -> GaussianBlur {
        GaussianBlur {
            direct: SurfaceBlur::new(positions, areas),
            cutoff_sigmas: 3.0,
            lattice: false,
        }
    }

    /// The full Gaussian, by the lattice where that is cheaper: [`BlurKernel::Gaussian`].
    pub fn full(positions: Vec<DVec3>, areas: Vec<f64>) -> GaussianBlur {
        GaussianBlur {
            direct: SurfaceBlur::new(positions, areas),
            cutoff_sigmas: FULL_GAUSSIAN_CUTOFF_SIGMAS,
            lattice: true,
        }
    }

    /// The sum the dense maps get at σ with `channels` dense channels (the denominator one of
    /// them), none a reference. The 3σ cut: merged sources where merging cuts the sources more
    /// than 1.5 times the ten channels per map (four per reference) it costs, else the direct
    /// sum. The full Gaussian: by a cost model calibrated on the 50k armadillo at 8 and 28 channels (a direct
    /// pair, summed in f32 blocks by `cut_gaussian_sums`, costs about 0.64 + 0.02 per channel
    /// of the lattice's multiply-adds, whose passes are bound by memory and count three times).
    pub fn sum_at(&self, sigma: f64, channels: usize) -> GaussianSum {
        self.plan(sigma, &vec![true; channels.saturating_sub(1)]).0
    }

    /// [`GaussianBlur::sum_at`] for the dense maps flagged in `precise` (false: a reference,
    /// merged to first order only), with the merged sources' groups when it chooses them, so
    /// that the sources are grouped once per σ.
    fn plan(&self, sigma: f64, precise: &[bool]) -> (GaussianSum, Vec<Vec<usize>>) {
        let channels = precise.len() + 1;
        if !self.lattice {
            let groups = self.clusters(sigma);
            let gain = self.direct.sources.len() as f64 / (groups.len() as f64).max(1.0);
            // A pair costs about (channels + 32) multiply-add units in either sum (the cost
            // model below), the denominator one channel of the direct sum and, beside the
            // kernel's own, ten of the merged one.
            let dense = precise.len() as f64;
            let merged = merged_width(precise) as f64;
            let cost_ratio = (merged + 33.0) / (dense + 33.0);
            return if gain >= CLUSTER_MARGIN * cost_ratio {
                (GaussianSum::Clustered, groups)
            } else {
                (GaussianSum::Direct, Vec::new())
            };
        }
        let d = &self.direct;
        let pairs = d.direct_pairs(self.cutoff_sigmas * sigma);
        let direct = pairs * (channels as f64 + 32.0) / 50.0;
        let lattice = lattice_work(&d.positions, sigma, channels);
        let sum = if direct <= lattice {
            GaussianSum::Direct
        } else {
            GaussianSum::Lattice
        };
        (sum, Vec::new())
    }

    /// Blurs every map at σ; σ = 0 returns copies.
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Vec<Vec<f64>> {
        self.blur_with_references(maps, &[], sigma)
    }

    /// Blurs `maps` and then `references` at σ (their blurs in that order; σ = 0 returns
    /// copies). A reference is a map whose blur serves only as a sample of a distribution (the
    /// chance band's random maps): where sources merge ([`GaussianSum::Clustered`]) it is
    /// carried to first order in each cube, four channels instead of a map's ten. Everywhere
    /// else a reference is blurred as a map is.
    pub fn blur_with_references(
        &self,
        maps: &[&[f64]],
        references: &[&[f64]],
        sigma: f64,
    ) -> Vec<Vec<f64>> {
        let all: Vec<&[f64]> = maps.iter().chain(references).copied().collect();
        if sigma <= 0.0 || all.is_empty() {
            return all.iter().map(|m| m.to_vec()).collect();
        }
        let n = self.direct.positions.len();
        let sparse: Vec<bool> = all
            .iter()
            .map(|m| m.iter().filter(|x| **x != 0.0).count() * SPARSE_FRACTION < n)
            .collect();
        let (mut dense, mut precise) = (Vec::new(), Vec::new());
        for (i, (map, is_sparse)) in all.iter().zip(&sparse).enumerate() {
            if !*is_sparse {
                dense.push(*map);
                precise.push(i < maps.len());
            }
        }
        let k = dense.len();
        let rows = row_major(&dense);
        let (sum, groups) = self.plan(sigma, &precise);
        let (den, dense_num) = match sum {
            GaussianSum::Direct => cut_gaussian_sums(
                &self.direct.positions,
                &self.direct.areas,
                &rows,
                k,
                sigma,
                self.cutoff_sigmas * sigma,
            ),
            GaussianSum::Clustered => self.clustered_sums(&groups, &rows, &precise, sigma),
            GaussianSum::Lattice => self.lattice_sums(&rows, k, sigma),
        };
        let mut dense_out = column_major(&dense_num, k.max(1)).into_iter();
        let mut out = Vec::with_capacity(all.len());
        for (map, is_sparse) in all.iter().zip(&sparse) {
            let mut blurred = if *is_sparse {
                self.sparse_sum(map, sigma)
            } else {
                dense_out.next().unwrap_or_default()
            };
            for (v, x) in blurred.iter_mut().enumerate() {
                *x = if den[v] > 0.0 { *x / den[v] } else { map[v] };
            }
            out.push(blurred);
        }
        out
    }

    /// The sources grouped by cube of side σ / [`CLUSTERS_PER_SIGMA`]: each group's sources
    /// in index order, groups in the order of their cube's key (the same on any machine).
    fn clusters(&self, sigma: f64) -> Vec<Vec<usize>> {
        let d = &self.direct;
        let side = sigma / CLUSTERS_PER_SIGMA;
        let mut keyed: Vec<([i64; 3], usize)> = d
            .sources
            .iter()
            .map(|&u| {
                let c = (d.positions[u] / side).floor();
                ([c.x as i64, c.y as i64, c.z as i64], u)
            })
            .collect();
        keyed.sort_unstable();
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for (i, (key, u)) in keyed.iter().enumerate() {
            if i == 0 || keyed[i - 1].0 != *key {
                groups.push(Vec::new());
            }
            groups.last_mut().expect("pushed above").push(*u);
        }
        groups
    }

    /// The direct sums from merged sources (`groups`, from [`GaussianBlur::clusters`] at σ):
    /// each cube's sources become one at their area-weighted centroid c with their total area
    /// A. For a map x, with δ = u − c and w = v − c, the kernel K(u, v) = K(c, v)
    /// exp((δ·w)/σ² − |δ|²/2σ²) is expanded to second order in δ:
    ///
    /// Σ_u a_u x_u K(u, v) ≈ K(c, v) (M0 − tr M2/2σ² + M1·w/σ² + wᵀ M2 w/2σ⁴)
    ///
    /// with the moments M0 = Σ a x, M1 = Σ a x δ, M2 = Σ a x δδᵀ. Written out in v, the bracket
    /// is C0 + C1·v + vᵀ C2 v with C0, C1, C2 depending on the cube alone, so the sums over
    /// merged sources are plain kernel sums of ten channels (C0, C1's three, C2's six) that the
    /// exact f32 block kernel does, and v multiplies them afterwards. The denominator (x = 1)
    /// gets the same ten, so a constant map stays constant. A map not flagged in `precise` (a
    /// reference: a chance map, read only as a sample of a distribution) gets first order
    /// alone, C0 = M0 − c·M1/σ² and C1 = M1/σ² (four channels), over the first-order
    /// denominator Σ A K(c, v). The cut applies at the centroid's distance.
    fn clustered_sums(
        &self,
        groups: &[Vec<usize>],
        rows: &[f64],
        precise: &[bool],
        sigma: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let d = &self.direct;
        let k = precise.len();
        // Where each map's channels start: the denominator's ten come first.
        let mut offset = Vec::with_capacity(k);
        let mut next = SECOND_ORDER;
        for &p in precise {
            offset.push(next);
            next += if p { SECOND_ORDER } else { FIRST_ORDER };
        }
        let width = next;
        let s = 1.0 / (sigma * sigma);
        let mut merged = vec![0.0; groups.len() * width];
        let centred: Vec<(DVec3, f64)> = merged
            .par_chunks_mut(width)
            .zip(groups.par_iter())
            .map(|(row, members)| {
                let area: f64 = members.iter().map(|&u| d.areas[u]).sum();
                let c = members
                    .iter()
                    .fold(DVec3::ZERO, |acc, &u| acc + d.positions[u] * d.areas[u])
                    / area;
                let value = |j: Option<usize>, u: usize| j.map_or(1.0, |j| rows[u * k + j]);
                for (j, at) in
                    std::iter::once((None, 0)).chain((0..k).map(|j| (Some(j), offset[j])))
                {
                    let (mut m0, mut m1, mut m2) = (0.0, DVec3::ZERO, [0.0; 6]);
                    let second = j.is_none_or(|j| precise[j]);
                    for &u in members {
                        let (ax, o) = (d.areas[u] * value(j, u), d.positions[u] - c);
                        m0 += ax;
                        m1 += o * ax;
                        if second {
                            for (m, q) in m2.iter_mut().zip(symmetric_outer(o)) {
                                *m += ax * q;
                            }
                        }
                    }
                    if second {
                        second_order_terms(m0, m1, m2, c, s, &mut row[at..at + SECOND_ORDER]);
                    } else {
                        row[at] = m0 - s * m1.dot(c);
                        row[at + 1..at + FIRST_ORDER].copy_from_slice(&(m1 * s).to_array());
                    }
                }
                // Per unit area: the kernel weighs each channel by the source's area.
                row.iter_mut().for_each(|x| *x /= area);
                (c, area)
            })
            .collect();
        let (centres, areas): (Vec<DVec3>, Vec<f64>) = centred.into_iter().unzip();
        let radius = self.cutoff_sigmas * sigma;
        // Each target's sums become its denominator and k numerators as its block finishes.
        let sums = cut_gaussian_sums_then(
            &centres,
            &areas,
            &merged,
            width,
            &d.positions,
            sigma,
            radius,
            k + 1,
            |v, totals, out| {
                let (first_order_den, t, p) = (totals[0], &totals[1..], d.positions[v]);
                let den = second_order_at(&t[..SECOND_ORDER], p);
                out[0] = den;
                for (j, x) in out[1..].iter_mut().enumerate() {
                    let at = offset[j];
                    *x = if precise[j] {
                        second_order_at(&t[at..at + SECOND_ORDER], p)
                    } else {
                        // Over the first-order denominator, written over the second-order one
                        // that divides every map.
                        let first = t[at] + p.dot(DVec3::new(t[at + 1], t[at + 2], t[at + 3]));
                        first * den / first_order_den
                    };
                }
            },
        );
        split_denominator(&sums, k)
    }

    /// [`SurfaceBlur::direct_sums`] by the lattice Gauss transform.
    fn lattice_sums(&self, rows: &[f64], k: usize, sigma: f64) -> (Vec<f64>, Vec<f64>) {
        let d = &self.direct;
        let n = d.positions.len();
        // Channel 0 carries the areas (the denominator), the others area × value.
        let mut weighted = vec![0.0; n * (k + 1)];
        for v in 0..n {
            let a = d.areas[v].max(0.0);
            weighted[v * (k + 1)] = a;
            for c in 0..k {
                weighted[v * (k + 1) + 1 + c] = a * rows[v * k + c];
            }
        }
        let sums = lattice_gauss_transform(&d.positions, &weighted, k + 1, sigma);
        let mut den: Vec<f64> = sums.iter().step_by(k + 1).copied().collect();
        let mut num = vec![0.0; n * k];
        for v in 0..n {
            num[v * k..(v + 1) * k].copy_from_slice(&sums[v * (k + 1) + 1..(v + 1) * (k + 1)]);
        }
        // A vertex without area (unreferenced) is no source of its own, so its sum can be as
        // small as the lattice's error: sum it directly.
        let radius = self.cutoff_sigmas * sigma;
        let grid = SourceGrid::new(&d.positions, &d.sources, radius);
        for v in (0..n).filter(|&v| d.areas[v] <= 0.0) {
            let row = &mut num[v * k..(v + 1) * k];
            row.iter_mut().for_each(|x| *x = 0.0);
            den[v] = d.direct_sum_at(&grid, v, rows, row, sigma, radius);
        }
        (den, num)
    }

    /// Σ_u a_u s(u) K(u, v) over the non-zero vertices u of a sparse map, for every vertex v.
    fn sparse_sum(&self, map: &[f64], sigma: f64) -> Vec<f64> {
        let d = &self.direct;
        let sources = SparseSources::of(map, &d.positions, &d.areas);
        let radius2 = (self.cutoff_sigmas * sigma).powi(2);
        let inv = 1.0 / (2.0 * sigma * sigma);
        let mut sums = vec![0.0; d.positions.len()];
        sums.par_chunks_mut(SPARSE_TARGETS)
            .zip(d.positions.par_chunks(SPARSE_TARGETS))
            .for_each(|(out, targets)| {
                sources
                    .within_reach(targets, radius2)
                    .sums_dispatch(targets, radius2, inv, out)
            });
        sums
    }
}

/// Targets per parallel task of a sparse sum.
const SPARSE_TARGETS: usize = 1024;
/// Targets summed side by side: one AVX2 register of f64.
const SPARSE_LANES: usize = 4;

/// A sparse map's sources (non-zero vertices with area), in index order, coordinates apart.
struct SparseSources {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    /// a_u s(u).
    weight: Vec<f64>,
}

impl SparseSources {
    fn of(map: &[f64], positions: &[DVec3], areas: &[f64]) -> SparseSources {
        let used: Vec<usize> = (0..map.len())
            .filter(|&u| map[u] != 0.0 && areas[u] > 0.0)
            .collect();
        SparseSources {
            x: used.iter().map(|&u| positions[u].x).collect(),
            y: used.iter().map(|&u| positions[u].y).collect(),
            z: used.iter().map(|&u| positions[u].z).collect(),
            weight: used.iter().map(|&u| areas[u] * map[u]).collect(),
        }
    }

    /// The sources that can reach any of `targets` (those farther than √`radius2` from the
    /// targets' bounding box, with a margin far above the rounding of d², add nothing), in
    /// the same order: each target's sum is unchanged and small σ skips most sources.
    fn within_reach(&self, targets: &[DVec3], radius2: f64) -> SparseSources {
        let first = targets.first().copied().unwrap_or_default();
        let (lo, hi) = targets
            .iter()
            .fold((first, first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
        let cull2 = radius2 * (1.0 + 1e-9);
        let reach: Vec<usize> = (0..self.weight.len())
            .filter(|&u| {
                let q = DVec3::new(self.x[u], self.y[u], self.z[u]);
                (lo - q).max(q - hi).max(DVec3::ZERO).length_squared() <= cull2
            })
            .collect();
        let pick = |v: &[f64]| reach.iter().map(|&u| v[u]).collect();
        SparseSources {
            x: pick(&self.x),
            y: pick(&self.y),
            z: pick(&self.z),
            weight: pick(&self.weight),
        }
    }

    fn sums_dispatch(&self, targets: &[DVec3], radius2: f64, inv: f64, out: &mut [f64]) {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU has AVX2 and FMA, checked just above.
            return unsafe { self.sums_avx2(targets, radius2, inv, out) };
        }
        self.sums(targets, radius2, inv, out)
    }

    /// [`SparseSources::sums`] in AVX2 registers, four targets a register: the same
    /// operations in the same order on each lane ([`exp_of_nonpositive_avx2`]), so the same
    /// bits.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    fn sums_avx2(&self, targets: &[DVec3], radius2: f64, inv: f64, out: &mut [f64]) {
        use std::arch::x86_64::*;
        let (r2, minus_inv) = (_mm256_set1_pd(radius2), _mm256_set1_pd(-inv));
        for (lanes, sums) in targets
            .chunks(SPARSE_LANES)
            .zip(out.chunks_mut(SPARSE_LANES))
        {
            let at = |l: usize| lanes[l.min(lanes.len() - 1)];
            let px = _mm256_setr_pd(at(0).x, at(1).x, at(2).x, at(3).x);
            let py = _mm256_setr_pd(at(0).y, at(1).y, at(2).y, at(3).y);
            let pz = _mm256_setr_pd(at(0).z, at(1).z, at(2).z, at(3).z);
            let mut sum = _mm256_setzero_pd();
            for u in 0..self.weight.len() {
                let dx = _mm256_sub_pd(_mm256_set1_pd(self.x[u]), px);
                let dy = _mm256_sub_pd(_mm256_set1_pd(self.y[u]), py);
                let dz = _mm256_sub_pd(_mm256_set1_pd(self.z[u]), pz);
                let d2 = _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(dx, dx), _mm256_mul_pd(dy, dy)),
                    _mm256_mul_pd(dz, dz),
                );
                let inside = _mm256_cmp_pd::<_CMP_LE_OQ>(d2, r2);
                if _mm256_movemask_pd(inside) == 0 {
                    continue;
                }
                let e = exp_of_nonpositive_avx2(_mm256_mul_pd(d2, minus_inv));
                let term = _mm256_mul_pd(_mm256_set1_pd(self.weight[u]), e);
                sum = _mm256_blendv_pd(sum, _mm256_add_pd(sum, term), inside);
            }
            let mut kept = [0.0f64; SPARSE_LANES];
            // SAFETY: `kept` holds four f64, one unaligned 256-bit store.
            unsafe { _mm256_storeu_pd(kept.as_mut_ptr(), sum) };
            sums.copy_from_slice(&kept[..sums.len()]);
        }
    }

    /// Each target's sum over the sources within √`radius2`, in source order: the terms
    /// a_u s(u) e^{−d²·inv} of the sources in reach added one by one, as a loop over the
    /// sources would (d² as `DVec3::distance_squared` computes it; the exp is
    /// [`exp_of_nonpositive`], within 2 ulp of the library's). Four targets go side by side.
    #[inline(always)]
    fn sums(&self, targets: &[DVec3], radius2: f64, inv: f64, out: &mut [f64]) {
        for (lanes, sums) in targets
            .chunks(SPARSE_LANES)
            .zip(out.chunks_mut(SPARSE_LANES))
        {
            // Lanes past the end repeat the last target; their sums are not kept.
            let at = |l: usize| lanes[l.min(lanes.len() - 1)];
            let px: [f64; SPARSE_LANES] = std::array::from_fn(|l| at(l).x);
            let py: [f64; SPARSE_LANES] = std::array::from_fn(|l| at(l).y);
            let pz: [f64; SPARSE_LANES] = std::array::from_fn(|l| at(l).z);
            let mut sum = [0.0f64; SPARSE_LANES];
            for u in 0..self.weight.len() {
                let (qx, qy, qz, w) = (self.x[u], self.y[u], self.z[u], self.weight[u]);
                let d2: [f64; SPARSE_LANES] = std::array::from_fn(|l| {
                    let (dx, dy, dz) = (qx - px[l], qy - py[l], qz - pz[l]);
                    dx * dx + dy * dy + dz * dz
                });
                if !d2.iter().any(|&d| d <= radius2) {
                    continue;
                }
                for l in 0..SPARSE_LANES {
                    let term = w * exp_of_nonpositive(-d2[l] * inv);
                    sum[l] = if d2[l] <= radius2 {
                        sum[l] + term
                    } else {
                        sum[l]
                    };
                }
            }
            sums.copy_from_slice(&sum[..sums.len()]);
        }
    }
}

/// Which kernel blurs maps over the surface.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum BlurKernel {
    /// Euclidean Gaussian cut at 3σ (the kernel every score so far used), summed exactly, or at
    /// large σ from merged sources with their moments to second order (within 8·10⁻⁴ of a map's
    /// range; AUC-Judd within 1.5·10⁻⁴ and LCC within 5·10⁻⁴ of the exact sums on the 50k
    /// armadillo's seven maps; the chance band's random maps there to first order). Leaks
    /// between parts that are close in space and far along the surface, as every Euclidean
    /// kernel does.
    Euclidean,
    /// The full Euclidean Gaussian (cut only past 5σ, under 4·10⁻⁶ of its peak), by a lattice
    /// Gauss transform at large σ: about as fast as `euclidean` now that its exact sums run in
    /// f32 blocks (17.6 s against 17.1 s for the 50k armadillo's seven maps, 2026-12-04). Not the same numbers as
    /// `euclidean`: the 3σ cut leaves exact zeros around sparse maps (ties), the full kernel
    /// ranks them by distance (docs/ground-truth-format.md has the measured differences).
    Gaussian,
    /// Heat diffusion along the surface, one implicit step (M − tΔ)u = M s with t = σ²/2
    /// (cotangent Laplacian, lumped mass): a geodesic surrogate whose variance is σ² per axis.
    Heat,
}

/// A blur of per-vertex maps with either kernel, built once per mesh and applied at any σ.
pub enum MeshBlur {
    /// A Euclidean Gaussian (cut at 3σ, or full).
    Gaussian(GaussianBlur),
    /// Heat diffusion along the surface.
    Heat(HeatBlur),
}

impl MeshBlur {
    /// `mesh` should already be normalized: σ is in the mesh's units.
    pub fn new(mesh: &Mesh, kernel: BlurKernel) -> MeshBlur {
        match kernel {
            BlurKernel::Euclidean => MeshBlur::Gaussian(GaussianBlur::cut_at_three_sigma(
                mesh.positions.clone(),
                vertex_areas(mesh),
            )),
            BlurKernel::Gaussian => MeshBlur::Gaussian(GaussianBlur::full(
                mesh.positions.clone(),
                vertex_areas(mesh),
            )),
            BlurKernel::Heat => MeshBlur::Heat(HeatBlur::new(mesh)),
        }
    }

    /// Every map blurred at `sigma` (σ = 0: copies).
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Result<Vec<Vec<f64>>, ScoreError> {
        match self {
            MeshBlur::Gaussian(b) => Ok(b.blur(maps, sigma)),
            MeshBlur::Heat(b) => b.blur(maps, sigma),
        }
    }

    /// `maps` and then `references` blurred at `sigma`: a reference (a chance map) may be
    /// summed more coarsely where sources merge ([`GaussianBlur::blur_with_references`]);
    /// the heat kernel blurs both alike.
    pub fn blur_with_references(
        &self,
        maps: &[&[f64]],
        references: &[&[f64]],
        sigma: f64,
    ) -> Result<Vec<Vec<f64>>, ScoreError> {
        match self {
            MeshBlur::Gaussian(b) => Ok(b.blur_with_references(maps, references, sigma)),
            MeshBlur::Heat(b) => {
                let all: Vec<&[f64]> = maps.iter().chain(references).copied().collect();
                b.blur(&all, sigma)
            }
        }
    }
}

/// Blurs `maps` on `mesh` (normalized) with `kernel` at σ = `sigma`.
pub fn blur_on_mesh(
    mesh: &Mesh,
    kernel: BlurKernel,
    maps: &[&[f64]],
    sigma: f64,
) -> Result<Vec<Vec<f64>>, ScoreError> {
    MeshBlur::new(mesh, kernel).blur(maps, sigma)
}

/// Heat-diffusion blur: the cotangent Laplacian and lumped masses of a mesh, factorized anew
/// for each σ (sparse Cholesky, faer), all maps solved at once.
pub struct HeatBlur {
    n: usize,
    /// Off-diagonal cotangent weights w_ij (i < j); Δ_ij = w_ij, Δ_ii = −Σ_j w_ij.
    edges: Vec<(usize, usize, f64)>,
    mass: Vec<f64>,
}

impl HeatBlur {
    /// The cotangent Laplacian and lumped mass of `mesh`, built once.
    pub fn new(mesh: &Mesh) -> HeatBlur {
        let mut edges: Vec<(usize, usize, f64)> = Vec::new();
        for t in 0..mesh.triangles.len() {
            let idx = mesh.triangles[t].map(|i| i as usize);
            let p = idx.map(|i| mesh.positions[i]);
            for k in 0..3 {
                let (a, b, o) = (k, (k + 1) % 3, (k + 2) % 3);
                // Corner o faces edge (a, b): half its cotangent goes to that edge.
                let (u, v) = (p[a] - p[o], p[b] - p[o]);
                let s = u.cross(v).length();
                if s > 0.0 {
                    let (i, j) = (idx[a].min(idx[b]), idx[a].max(idx[b]));
                    edges.push((i, j, 0.5 * u.dot(v) / s));
                }
            }
        }
        edges.sort_by_key(|e| (e.0, e.1));
        let mut merged: Vec<(usize, usize, f64)> = Vec::with_capacity(edges.len());
        for e in edges {
            match merged.last_mut() {
                Some(last) if last.0 == e.0 && last.1 == e.1 => last.2 += e.2,
                _ => merged.push(e),
            }
        }
        HeatBlur {
            n: mesh.positions.len(),
            edges: merged,
            mass: vertex_areas(mesh),
        }
    }

    /// Diffuses every map for time t = σ²/2; σ = 0 returns copies. Vertices without area
    /// (unreferenced) keep their values.
    pub fn blur(&self, maps: &[&[f64]], sigma: f64) -> Result<Vec<Vec<f64>>, ScoreError> {
        if sigma <= 0.0 {
            return Ok(maps.iter().map(|m| m.to_vec()).collect());
        }
        use faer::sparse::{SparseColMat, Triplet};
        let t = 0.5 * sigma * sigma;
        let mut diag: Vec<f64> = self.mass.clone();
        let mut triplets = Vec::with_capacity(self.edges.len() + self.n);
        for &(i, j, w) in &self.edges {
            diag[i] += t * w;
            diag[j] += t * w;
            // Lower triangle only: the factorization reads Side::Lower.
            triplets.push(Triplet::new(j, i, -t * w));
        }
        for (i, d) in diag.iter_mut().enumerate() {
            if self.mass[i] <= 0.0 {
                *d = 1.0;
            }
            triplets.push(Triplet::new(i, i, *d));
        }
        let a = SparseColMat::<usize, f64>::try_new_from_triplets(self.n, self.n, &triplets)
            .map_err(|e| {
                ScoreError::HeatOperator(format!("cannot assemble the heat operator: {e:?}"))
            })?;
        let llt = a.sp_cholesky(faer::Side::Lower).map_err(|e| {
            ScoreError::HeatOperator(format!(
                "the heat operator is not positive definite (σ_b = {sigma}): {e:?}"
            ))
        })?;
        let mut rhs = faer::Mat::<f64>::zeros(self.n, maps.len());
        for (c, m) in maps.iter().enumerate() {
            for i in 0..self.n {
                rhs[(i, c)] = if self.mass[i] > 0.0 {
                    self.mass[i] * m[i]
                } else {
                    m[i]
                };
            }
        }
        faer::linalg::solvers::Solve::solve_in_place(&llt, rhs.as_mut());
        Ok((0..maps.len())
            .map(|c| (0..self.n).map(|i| rhs[(i, c)]).collect())
            .collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plate(n: usize) -> Mesh {
        crate::mesh::test_meshes::height_field(n, -0.5, |_, _| 0.0)
    }

    #[test]
    fn heat_blur_keeps_mass_and_spreads_a_spike_by_sigma_squared() {
        let n = 121;
        let mesh = plate(n);
        let heat = HeatBlur::new(&mesh);
        let centre = (n / 2) * n + n / 2;
        let mut spike = vec![0.0; n * n];
        spike[centre] = 1.0 / heat.mass[centre];
        let sigma = 0.05;
        let u = heat.blur(&[&spike], sigma).unwrap().remove(0);
        let mass: f64 = u.iter().zip(&heat.mass).map(|(a, m)| a * m).sum();
        assert!((mass - 1.0).abs() < 1e-9, "mass {mass}");
        let var_x: f64 = u
            .iter()
            .zip(&heat.mass)
            .zip(&mesh.positions)
            .map(|((a, m), p)| a * m * p.x * p.x)
            .sum();
        assert!(
            (var_x / (sigma * sigma) - 1.0).abs() < 0.05,
            "variance per axis {var_x}, expected {}",
            sigma * sigma
        );
        let constant = vec![0.7; n * n];
        let c = heat.blur(&[&constant], 0.1).unwrap().remove(0);
        assert!(c.iter().all(|v| (v - 0.7).abs() < 1e-9));
    }

    #[test]
    fn euclidean_blur_keeps_constants_and_averages_locally() {
        let mesh = plate(41);
        let blur = SurfaceBlur::new(mesh.positions.clone(), vertex_areas(&mesh));
        let constant = vec![2.0; 41 * 41];
        let c = blur.blur(&[&constant], 0.05).remove(0);
        assert!(c.iter().all(|v| (v - 2.0).abs() < 1e-12));
        let ramp: Vec<f64> = mesh.positions.iter().map(|p| p.x).collect();
        let r = blur.blur(&[&ramp], 0.03).remove(0);
        // A linear ramp is unchanged away from the border.
        let centre = 20 * 41 + 20;
        assert!((r[centre] - ramp[centre]).abs() < 1e-9);
    }

    #[test]
    fn euclidean_blur_equals_the_direct_sum_over_all_pairs() {
        let mesh = crate::mesh::test_meshes::icosphere(1.0, 3);
        let areas = vertex_areas(&mesh);
        let blur = SurfaceBlur::new(mesh.positions.clone(), areas.clone());
        let map: Vec<f64> = (0..mesh.positions.len())
            .map(|i| ((i * 7919) % 101) as f64)
            .collect();
        for sigma in [0.05, 0.2, 0.7] {
            let fast = blur.blur(&[&map, &areas], sigma);
            for (v, p) in mesh.positions.iter().enumerate() {
                let (mut num, mut den) = (0.0, 0.0);
                for (u, q) in mesh.positions.iter().enumerate() {
                    let d2 = p.distance_squared(*q);
                    if d2 <= 9.0 * sigma * sigma {
                        let w = areas[u] * (-d2 / (2.0 * sigma * sigma)).exp();
                        num += w * map[u];
                        den += w;
                    }
                }
                let direct = num / den;
                assert!(
                    (fast[0][v] - direct).abs() <= 1e-9 * direct.abs().max(1.0),
                    "σ {sigma}, vertex {v}: {} vs {direct}",
                    fast[0][v]
                );
            }
        }
    }

    /// Merged sources with their second moments against the exact cut sum, on a sphere of
    /// 10,242 vertices (one to a few hundred sources per merged one), for a smooth map and
    /// one of independent values per vertex (no smoothness inside a cube). Measured worst
    /// errors of the blurred value, as a fraction of the map's range: σ 0.1: 4.7·10⁻⁴ and
    /// 6.0·10⁻⁴; σ 0.2: 5.1·10⁻⁴ and 4.4·10⁻⁴; σ 0.4: 5.4·10⁻⁴ and 2.1·10⁻⁴, most of it the cut
    /// taken at a merged source's centroid, an error linear in the cube (first moments on cubes
    /// of σ/6, the merge before, gave 4·10⁻⁷ to 3.7·10⁻⁴, at twice the work on the armadillo,
    /// where its scores moved more: README); bounded at 8·10⁻⁴.
    #[test]
    fn merged_sources_stay_close_to_the_exact_sum() {
        let (mesh, areas, smooth) = sphere_with_smooth_map();
        let n = mesh.positions.len();
        let exact = SurfaceBlur::new(mesh.positions.clone(), areas.clone());
        let blur = GaussianBlur::cut_at_three_sigma(mesh.positions.clone(), areas.clone());
        let independent: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 / 100.0).collect();
        let range = |m: &[f64]| {
            m.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - m.iter().cloned().fold(f64::INFINITY, f64::min)
        };
        for sigma in [0.1, 0.2, 0.4] {
            let rows = row_major(&[&smooth, &independent]);
            let (den, num) =
                blur.clustered_sums(&blur.clusters(sigma), &rows, &[true, true], sigma);
            let want = exact.blur(&[&smooth, &independent], sigma);
            for (m, map) in [&smooth, &independent].into_iter().enumerate() {
                let worst = (0..n)
                    .map(|v| (num[v * 2 + m] / den[v] - want[m][v]).abs())
                    .fold(0.0, f64::max)
                    / range(map);
                eprintln!("σ {sigma} map {m}: worst error {worst:.2e} of the range");
                assert!(worst <= 8e-4, "σ {sigma} map {m}: {worst:.2e} of the range");
            }
        }
    }

    /// References (the chance maps) beside maps: the maps' blurs keep their bits, and where
    /// sources merge a reference is the first-order sum, Σ_g K(c_g, v) (M0_g + M1_g·(v − c_g)/σ²)
    /// over Σ_g A_g K(c_g, v), the cubes' centroids within the cut, computed here in f64 from
    /// the groups; where they do not merge it is blurred exactly as a map is.
    #[test]
    fn references_merge_at_first_order_and_leave_the_maps_bits_alone() {
        let (mesh, areas, smooth) = sphere_with_smooth_map();
        let n = mesh.positions.len();
        let blur = GaussianBlur::cut_at_three_sigma(mesh.positions.clone(), areas.clone());
        let noise = chance_like(n);
        for (sigma, merged) in [(0.02, false), (0.4, true)] {
            let both = blur.blur_with_references(&[&smooth], &[&noise], sigma);
            assert_eq!(both.len(), 2);
            assert_eq!(
                blur.plan(sigma, &[true, false]).0 == GaussianSum::Clustered,
                merged,
                "σ {sigma}"
            );
            assert_eq!(
                blur.plan(sigma, &[true]).0 == GaussianSum::Clustered,
                merged
            );
            assert_eq!(
                both[0],
                blur.blur(&[&smooth], sigma)[0],
                "σ {sigma}: the map's bits"
            );
            if !merged {
                assert_eq!(both[1], blur.blur(&[&noise], sigma)[0], "σ {sigma}");
                continue;
            }
            let d = &blur.direct;
            let (radius2, inv) = ((3.0 * sigma).powi(2), 1.0 / (2.0 * sigma * sigma));
            let cubes: Vec<(DVec3, f64, f64, DVec3)> = blur
                .clusters(sigma)
                .iter()
                .map(|members| {
                    let area: f64 = members.iter().map(|&u| d.areas[u]).sum();
                    let centre = members
                        .iter()
                        .fold(DVec3::ZERO, |acc, &u| acc + d.positions[u] * d.areas[u])
                        / area;
                    let m0: f64 = members.iter().map(|&u| d.areas[u] * noise[u]).sum();
                    let m1 = members.iter().fold(DVec3::ZERO, |acc, &u| {
                        acc + (d.positions[u] - centre) * (d.areas[u] * noise[u])
                    });
                    (centre, area, m0, m1)
                })
                .collect();
            for (v, (p, got)) in d.positions.iter().zip(&both[1]).enumerate() {
                let (mut num, mut den) = (0.0, 0.0);
                for &(c, area, m0, m1) in &cubes {
                    let d2 = c.distance_squared(*p);
                    if d2 <= radius2 {
                        let k = (-d2 * inv).exp();
                        num += k * (m0 + m1.dot(*p - c) / (sigma * sigma));
                        den += k * area;
                    }
                }
                assert!(
                    (got - num / den).abs() <= 1e-5,
                    "σ {sigma} vertex {v}: {got} vs {}",
                    num / den
                );
            }
        }
    }

    /// The unit sphere of 10,242 vertices, its vertex areas, and a smooth map on it.
    fn sphere_with_smooth_map() -> (Mesh, Vec<f64>, Vec<f64>) {
        let mesh = crate::mesh::test_meshes::icosphere(1.0, 5);
        let areas = vertex_areas(&mesh);
        let smooth = mesh
            .positions
            .iter()
            .map(|p| (3.0 * p.x).sin() + p.y * p.z)
            .collect();
        (mesh, areas, smooth)
    }

    /// Values in [0, 1) with no spatial pattern, as the chance maps are.
    fn chance_like(n: usize) -> Vec<f64> {
        (0..n)
            .map(|i| ((i * 7919 + 13) % 1009) as f64 / 1009.0)
            .collect()
    }

    /// The sparse sums against the plain loop over sources with the library's exp: within
    /// a few ulp of the sum (the exp alone differs, by at most 2 ulp), the same sources in
    /// reach (exact zeros where none is), and the AVX2 lanes bit for bit the portable code.
    #[test]
    fn sparse_sums_equal_the_loop_over_sources() {
        let mesh = crate::mesh::test_meshes::icosphere(1.0, 4);
        let n = mesh.positions.len();
        let areas = vertex_areas(&mesh);
        let mut map = vec![0.0; n];
        for (k, v) in [3, 17, n / 3, n / 2, n - 1].into_iter().enumerate() {
            map[v] = 1.0 + k as f64;
        }
        map[n / 2 + 1] = -0.5;
        let sources = SparseSources::of(&map, &mesh.positions, &areas);
        assert_eq!(sources.weight.len(), 6);
        for sigma in [0.01, 0.05, 0.2, 1.0] {
            let (radius2, inv) = ((3.0 * sigma) * (3.0 * sigma), 1.0 / (2.0 * sigma * sigma));
            // All targets at once, a few, and single ones: a single target's box is its
            // point, so culling there is by distance alone, tight at the cutoff.
            let sets = [&mesh.positions[..], &mesh.positions[5..12]]
                .into_iter()
                .chain((0..n).step_by(5).map(|v| &mesh.positions[v..v + 1]));
            for targets in sets {
                let mut portable = vec![0.0; targets.len()];
                let reach = sources.within_reach(targets, radius2);
                reach.sums(targets, radius2, inv, &mut portable);
                let mut all = vec![0.0; targets.len()];
                sources.sums(targets, radius2, inv, &mut all);
                assert_eq!(portable, all, "σ {sigma}: culling changed a sum");
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    let mut lanes = vec![0.0; targets.len()];
                    // SAFETY: the CPU has AVX2 and FMA, checked just above.
                    unsafe { reach.sums_avx2(targets, radius2, inv, &mut lanes) };
                    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&lanes), bits(&portable), "σ {sigma}");
                }
                for (p, got) in targets.iter().zip(&portable) {
                    let (mut want, mut scale, mut reached) = (0.0, 0.0, false);
                    for u in (0..n).filter(|&u| map[u] != 0.0) {
                        let d2 = mesh.positions[u].distance_squared(*p);
                        if d2 <= radius2 {
                            let term = areas[u] * map[u] * (-d2 * inv).exp();
                            (want, scale, reached) = (want + term, scale + term.abs(), true);
                        }
                    }
                    assert!(
                        (got - want).abs() <= 8.0 * f64::EPSILON * scale,
                        "σ {sigma}: {got} vs {want}"
                    );
                    if !reached {
                        assert_eq!(*got, 0.0, "σ {sigma}: a sum without sources in reach");
                    }
                }
            }
        }
    }

    #[test]
    fn the_scoring_blur_routes_sparse_maps_without_changing_the_three_sigma_sum() {
        let mesh = crate::mesh::test_meshes::icosphere(1.0, 4);
        let n = mesh.positions.len();
        let areas = vertex_areas(&mesh);
        let exact = SurfaceBlur::new(mesh.positions.clone(), areas.clone());
        let routed = GaussianBlur::cut_at_three_sigma(mesh.positions.clone(), areas.clone());
        let dense: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64).collect();
        let mut sparse = vec![0.0; n];
        sparse[3] = 2.0;
        sparse[n / 2] = 1.0;
        for sigma in [0.02, 0.1, 0.3] {
            // The scoring blur sums in f32 blocks (cut_gaussian_sums.rs): within 10⁻⁵ of
            // each map's largest value of the f64 sum.
            let a = exact.blur(&[&dense, &sparse], sigma);
            let b = routed.blur(&[&dense, &sparse], sigma);
            for (m, largest) in [(0, 100.0), (1, 2.0)] {
                for v in 0..n {
                    assert!(
                        (a[m][v] - b[m][v]).abs() <= 1e-5 * largest,
                        "σ {sigma} map {m} vertex {v}: {} vs {}",
                        a[m][v],
                        b[m][v]
                    );
                }
            }
            // Only sparse maps: nothing dense is summed, the denominator still is.
            let (a, b) = (
                exact.blur(&[&sparse], sigma),
                routed.blur(&[&sparse], sigma),
            );
            for v in 0..n {
                assert!((a[0][v] - b[0][v]).abs() <= 1e-5 * 2.0);
            }
            // The full Gaussian through the lattice stays within 10⁻⁵ of the map's range of
            // the full Gaussian summed directly.
            let full = GaussianBlur::full(mesh.positions.clone(), areas.clone());
            let mut direct = GaussianBlur::full(mesh.positions.clone(), areas.clone());
            direct.lattice = false;
            let (fs, ds) = (full.blur(&[&sparse], sigma), direct.blur(&[&sparse], sigma));
            for v in 0..n {
                assert!(
                    (fs[0][v] - ds[0][v]).abs() <= 1e-5 * 2.0,
                    "σ {sigma}, vertex {v}"
                );
            }
            let (f, d) = (full.blur(&[&dense], sigma), direct.blur(&[&dense], sigma));
            for v in 0..n {
                assert!(
                    (f[0][v] - d[0][v]).abs() <= 1e-5 * 100.0,
                    "σ {sigma}, vertex {v}"
                );
            }
        }
    }
}

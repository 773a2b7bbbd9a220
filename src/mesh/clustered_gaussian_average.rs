//! Truncated Gaussian weighted averages of a per-point value, summed over clusters of points:
//!
//! A(v) = Σ_{j: ‖p_j−v‖<R} a_j f_j e^{−‖p_j−v‖²/2σ²} / Σ_{j: ‖p_j−v‖<R} a_j e^{−‖p_j−v‖²/2σ²}.
//!
//! MS (R = 2σ, at eight σ) and SI's final smoothing (R = 3σ) spend nearly all their time in
//! this sum: on an 800k-vertex mesh each vertex sees tens of thousands of sources at the
//! widest σ. Here the sources are grouped into cubes of side σ/`cells_per_sigma`, and each
//! cube enters every target's sum through its weight, centroid c and second moments, by the
//! Taylor expansion of the Gaussian around the centroid (u = c − v, d = p − c, s = 1/2σ²):
//!
//! Σ a f e^{−s‖u+d‖²} ≈ e^{−s‖u‖²} (Σaf − 2s u·Σafd − s Σaf‖d‖² + 2s² uᵀ(Σaf ddᵀ)u),
//!
//! whose first neglected term is third order in ‖d‖/σ (the numerator keeps f's mean and its
//! first moment; Σa(f − f̄)ddᵀ is third order where f is smooth). The hard cutoff is the
//! main error left: a cube straddling R is counted by the share of it inside R, read off a
//! linear ramp over its spread along the surface, rather than point by point. Both errors
//! shrink as the cubes do; the tests here and tests/gaussian_sum.rs measure them against
//! the exact sum, and docs/baselines.md states the bounds.
//!
//! The pair loop runs in f32, eight lanes at a time, with an exp that needs no libm: the
//! same code on every x86-64 (AVX2 when the CPU has it, SSE2 otherwise, with identical
//! results since no step is fused or reordered) and the same bytes on any number of threads.
use crate::mesh::geometry::symmetric_outer;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

/// How the truncated Gaussian sums are computed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum GaussianSum {
    /// Every vertex within the cutoff: the definition, and O(n · vertices per ball).
    Exact,
    /// Over cubes of side σ/`cells_per_sigma`, each by its weight, centroid and second
    /// moments (this module): the cost per vertex no longer
    /// grows with the mesh's density.
    Clustered {
        /// Cubes per σ along each axis.
        cells_per_sigma: f64,
    },
}

const LANES: usize = 8;

/// One cluster's coefficients for a given σ, f32, in the order the pair loop reads them.
#[derive(Clone, Copy, Default)]
struct Cluster {
    /// Centroid.
    c: [f32; 3],
    /// Σa − s Σa‖d‖² and 2s²Σa ddᵀ (xx, yy, zz, 2xy, 2xz, 2yz): the denominator's expansion.
    w0: f32,
    wq: [f32; 6],
    /// The numerator is the cluster's mean value f̄ times the denominator's expansion plus
    /// that of Σa(f − f̄)e^{…}: −2s Σa(f − f̄)d and −s Σa(f − f̄)‖d‖² (its quadratic term
    /// is third order where f varies smoothly, like the terms the expansion drops).
    mean: f32,
    fg: [f32; 3],
    f0: f32,
    /// 1/(4Ra), a = √3 times the cluster's spread along the surface: the slope of the
    /// cutoff ramp in ‖u‖² (R² − ‖u‖² ≈ 2R(R − ‖u‖) where the ramp is not flat).
    ramp: f32,
}

/// The candidates of one target cell, struct-of-arrays and padded to whole lanes.
#[derive(Default)]
struct Candidates {
    cols: Vec<[f32; LANES]>,
}

const COLS: usize = 16;

impl Candidates {
    fn push_all(&mut self, list: &[Cluster]) {
        let chunks = list.len().div_ceil(LANES);
        self.cols.clear();
        self.cols.resize(chunks * COLS, [0.0; LANES]);
        for (i, k) in list.iter().enumerate() {
            let (chunk, lane) = (i / LANES, i % LANES);
            let base = chunk * COLS;
            let vals = [
                k.c[0], k.c[1], k.c[2], k.w0, k.wq[0], k.wq[1], k.wq[2], k.wq[3], k.wq[4], k.wq[5],
                k.mean, k.fg[0], k.fg[1], k.fg[2], k.f0, k.ramp,
            ];
            for (col, v) in vals.iter().enumerate() {
                self.cols[base + col][lane] = *v;
            }
        }
        // Padding lanes sit far away: outside every cutoff, and exp never sees them.
        for i in list.len()..chunks * LANES {
            let (chunk, lane) = (i / LANES, i % LANES);
            for col in 0..3 {
                self.cols[chunk * COLS + col][lane] = 1.0e18;
            }
        }
    }
}

/// e^x for x in [−87, 0]: 2^n · e^r with |r| ≤ ln2/2 and a degree-6 Taylor polynomial
/// (relative error below 2e-7). Only adds, multiplies and bit moves, so it vectorizes.
#[inline(always)]
fn exp_nonpositive(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0; // 1.5 · 2^23: adding it rounds to an integer
    let x = x.max(-87.0);
    let t = x * std::f32::consts::LOG2_E + MAGIC;
    let n_bits = t.to_bits() as i32 - MAGIC.to_bits() as i32;
    let n = t - MAGIC;
    let r = x - n * 0.693_145_75 - n * 1.428_606_8e-6;
    let p = 1.0
        + r * (1.0
            + r * (0.5
                + r * (1.0 / 6.0 + r * (1.0 / 24.0 + r * (1.0 / 120.0 + r * (1.0 / 720.0))))));
    f32::from_bits(((n_bits + 127) << 23) as u32) * p
}

/// Numerator and denominator at one target over all candidates (lane-wise, then summed in
/// a fixed order).
#[inline(always)]
fn pair_sums(cands: &Candidates, v: [f32; 3], s: f32, r2_max: f32) -> (f64, f64) {
    let mut num = [0.0f32; LANES];
    let mut den = [0.0f32; LANES];
    for chunk in cands.cols.chunks_exact(COLS) {
        for l in 0..LANES {
            let ux = chunk[0][l] - v[0];
            let uy = chunk[1][l] - v[1];
            let uz = chunk[2][l] - v[2];
            let r2 = ux * ux + uy * uy + uz * uz;
            let e = exp_nonpositive(-s * r2);
            let (xx, yy, zz, xy, xz, yz) = (ux * ux, uy * uy, uz * uz, ux * uy, ux * uz, uy * uz);
            let wq = chunk[4][l] * xx
                + chunk[5][l] * yy
                + chunk[6][l] * zz
                + chunk[7][l] * xy
                + chunk[8][l] * xz
                + chunk[9][l] * yz;
            let fg = chunk[11][l] * ux + chunk[12][l] * uy + chunk[13][l] * uz;
            // The share of the cluster within R, if its points were spread uniformly along u
            // with the variance its second moments give.
            let share = (0.5 + (r2_max - r2) * chunk[15][l]).clamp(0.0, 1.0);
            let e = e * share;
            let d = chunk[3][l] + wq;
            den[l] += e * d;
            num[l] += e * (chunk[10][l] * d + fg + chunk[14][l]);
        }
    }
    let (mut n, mut d) = (0.0f64, 0.0f64);
    for l in 0..LANES {
        n += num[l] as f64;
        d += den[l] as f64;
    }
    (n, d)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn pair_sums_avx2(cands: &Candidates, v: [f32; 3], s: f32, r2_max: f32) -> (f64, f64) {
    pair_sums(cands, v, s, r2_max)
}

fn pair_sums_dispatch(cands: &Candidates, v: [f32; 3], s: f32, r2_max: f32) -> (f64, f64) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU has AVX2, checked just above.
            return unsafe { pair_sums_avx2(cands, v, s, r2_max) };
        }
    }
    pair_sums(cands, v, s, r2_max)
}

fn cell_of(p: DVec3, origin: DVec3, size: f64) -> [i64; 3] {
    let c = ((p - origin) / size).floor();
    [c.x as i64, c.y as i64, c.z as i64]
}

/// Clusters in fine cells of side h, sorted by the coarse cell (side g, a whole number of
/// fine cells) holding them, so each coarse cell's clusters are contiguous.
struct ClusterGrid {
    clusters: Vec<Cluster>,
    /// Occupied coarse cells in order; `starts[i]..starts[i + 1]` indexes `clusters`.
    coarse_keys: Vec<[i64; 3]>,
    coarse_starts: Vec<usize>,
}

/// The weighted points of one cluster, relative to `origin`.
struct Members<'a> {
    sources: &'a [DVec3],
    weights: &'a [f64],
    values: &'a [f64],
    origin: DVec3,
}

impl Members<'_> {
    /// The cluster of sources `js`: its centroid, mean and the moments of the second-order
    /// expansion of the Gaussian about the centroid (s = 1/2σ²).
    fn cluster(
        &self,
        js: impl Iterator<Item = usize> + Clone,
        s: f64,
        cutoff: f64,
        h: f64,
    ) -> Cluster {
        let (sources, weights, values) = (self.sources, self.weights, self.values);
        let (mut w, mut wp, mut f) = (0.0, DVec3::ZERO, 0.0);
        for j in js.clone() {
            w += weights[j];
            wp += weights[j] * (sources[j] - self.origin);
            f += weights[j] * values[j];
        }
        let (c, mean) = (wp / w, f / w);
        let (mut wm, mut fgv, mut fd2) = ([0.0f64; 6], DVec3::ZERO, 0.0);
        for j in js {
            let d = sources[j] - self.origin - c;
            let (a, af) = (weights[j], weights[j] * (values[j] - mean));
            let dd = symmetric_outer(d);
            for k in 0..6 {
                wm[k] += a * dd[k];
            }
            fgv += af * d;
            fd2 += af * d.length_squared();
        }
        let q = 2.0 * s * s;
        Cluster {
            c: [c.x as f32, c.y as f32, c.z as f32],
            w0: (w - s * (wm[0] + wm[1] + wm[2])) as f32,
            wq: [
                (q * wm[0]) as f32,
                (q * wm[1]) as f32,
                (q * wm[2]) as f32,
                (2.0 * q * wm[3]) as f32,
                (2.0 * q * wm[4]) as f32,
                (2.0 * q * wm[5]) as f32,
            ],
            mean: mean as f32,
            fg: [
                (-2.0 * s * fgv.x) as f32,
                (-2.0 * s * fgv.y) as f32,
                (-2.0 * s * fgv.z) as f32,
            ],
            f0: (-s * fd2) as f32,
            ramp: {
                // Points on a surface spread over two of the three axes.
                let a = (1.5 * (wm[0] + wm[1] + wm[2]) / w).sqrt();
                (1.0 / (4.0 * cutoff * a.max(1e-9 * h))) as f32
            },
        }
    }
}

/// Targets are handled in cells that share one candidate list: the clusters within R plus
/// the cell's half-diagonal of its centre. Small cells waste fewer candidates, but each
/// cell costs a gather, so a cell should hold several targets: side R/4 unless sparse
/// data leave fewer than 24 sources per occupied cell, then R/2, then R.
fn target_cell_side(sources: &[DVec3], origin: DVec3, cutoff: f64) -> f64 {
    [0.25, 0.5]
        .into_iter()
        .map(|f| f * cutoff)
        .find(|&g| {
            let mut keys: Vec<[i64; 3]> =
                sources.par_iter().map(|p| cell_of(*p, origin, g)).collect();
            keys.par_sort_unstable();
            keys.dedup();
            sources.len() >= 24 * keys.len()
        })
        .unwrap_or(cutoff)
}

impl ClusterGrid {
    fn new(members: &Members, h: f64, fine_per_coarse: i64, s: f64, cutoff: f64) -> ClusterGrid {
        let mut keyed: Vec<([i64; 3], [i64; 3], usize)> = members
            .sources
            .par_iter()
            .enumerate()
            .map(|(j, p)| {
                let fine = cell_of(*p, members.origin, h);
                let coarse = fine.map(|f| f.div_euclid(fine_per_coarse));
                (coarse, fine, j)
            })
            .collect();
        keyed.par_sort_unstable();
        let mut grid = ClusterGrid {
            clusters: Vec::new(),
            coarse_keys: Vec::new(),
            coarse_starts: Vec::new(),
        };
        let mut i = 0;
        while i < keyed.len() {
            let mut end = i + 1;
            while end < keyed.len() && keyed[end].0 == keyed[i].0 && keyed[end].1 == keyed[i].1 {
                end += 1;
            }
            if grid.coarse_keys.last() != Some(&keyed[i].0) {
                grid.coarse_keys.push(keyed[i].0);
                grid.coarse_starts.push(grid.clusters.len());
            }
            let js = keyed[i..end].iter().map(|&(_, _, j)| j);
            grid.clusters.push(members.cluster(js, s, cutoff, h));
            i = end;
        }
        grid.coarse_starts.push(grid.clusters.len());
        grid
    }

    /// Into `list`: the clusters of the coarse cells within `span` of `key` whose centroid
    /// is within `reach` of `centre`.
    fn gather(&self, key: [i64; 3], span: i64, centre: DVec3, reach: f64, list: &mut Vec<Cluster>) {
        list.clear();
        for dx in -span..=span {
            for dy in -span..=span {
                let first = [key[0] + dx, key[1] + dy, key[2] - span];
                let last = [key[0] + dx, key[1] + dy, key[2] + span];
                let from = self.coarse_keys.partition_point(|k| *k < first);
                let to = self.coarse_keys.partition_point(|k| *k <= last);
                for cell in from..to {
                    for k in &self.clusters[self.coarse_starts[cell]..self.coarse_starts[cell + 1]]
                    {
                        let c = DVec3::new(k.c[0] as f64, k.c[1] as f64, k.c[2] as f64);
                        if c.distance_squared(centre) <= reach * reach {
                            list.push(*k);
                        }
                    }
                }
            }
        }
    }
}

/// A target's index keyed by the grid cell holding it.
type CellKeyed = ([i64; 3], usize);

/// Targets sorted by the cell of side `g` holding them, and the (start, end) of each cell's run.
fn targets_by_cell(
    targets: &[DVec3],
    origin: DVec3,
    g: f64,
) -> (Vec<CellKeyed>, Vec<(usize, usize)>) {
    let mut order: Vec<CellKeyed> = targets
        .par_iter()
        .enumerate()
        .map(|(t, p)| (cell_of(*p, origin, g), t))
        .collect();
    order.par_sort_unstable();
    let mut groups: Vec<(usize, usize)> = Vec::new();
    let mut a = 0;
    while a < order.len() {
        let mut b = a + 1;
        while b < order.len() && order[b].0 == order[a].0 {
            b += 1;
        }
        groups.push((a, b));
        a = b;
    }
    (order, groups)
}

/// A(v) at every target (`None` where no cluster lies within `cutoff`). `weights` must be
/// positive; sources with weight 0 should be left out by the caller.
pub fn clustered_gaussian_average(
    sources: &[DVec3],
    weights: &[f64],
    values: &[f64],
    targets: &[DVec3],
    sigma: f64,
    cutoff: f64,
    cells_per_sigma: f64,
) -> Vec<Option<f64>> {
    assert!(sources.len() == weights.len() && sources.len() == values.len());
    let usable = |x: f64| x > 0.0 && x.is_finite();
    if sources.is_empty()
        || targets.is_empty()
        || !usable(sigma)
        || !usable(cutoff)
        || !usable(cells_per_sigma)
    {
        // No kernel to sum with (a mesh of zero extent has σ = 0): nothing is in reach.
        return vec![None; targets.len()];
    }
    // Coordinates relative to the sources' centre keep f32 differences accurate.
    let (mut lo, mut hi) = (sources[0], sources[0]);
    for p in sources {
        lo = lo.min(*p);
        hi = hi.max(*p);
    }
    let origin = 0.5 * (lo + hi);
    let h = sigma / cells_per_sigma;
    let fine_per_coarse = (target_cell_side(sources, origin, cutoff) / h)
        .ceil()
        .max(1.0) as i64;
    let g = h * fine_per_coarse as f64;
    let s = 1.0 / (2.0 * sigma * sigma);
    let members = Members {
        sources,
        weights,
        values,
        origin,
    };
    let grid = ClusterGrid::new(&members, h, fine_per_coarse, s, cutoff);
    let (target_order, groups) = targets_by_cell(targets, origin, g);
    let reach = cutoff + 0.5 * 3f64.sqrt() * (g + 2.0 * h);
    let span = (reach / g + 0.5).ceil() as i64;
    let (sf, r2_max) = (s as f32, (cutoff * cutoff) as f32);
    let results: Vec<Vec<(usize, Option<f64>)>> = groups
        .par_iter()
        .map_init(
            || (Vec::<Cluster>::new(), Candidates::default()),
            |(list, cands), &(a, b)| {
                let key = target_order[a].0;
                let centre = DVec3::new(
                    (key[0] as f64 + 0.5) * g,
                    (key[1] as f64 + 0.5) * g,
                    (key[2] as f64 + 0.5) * g,
                );
                grid.gather(key, span, centre, reach, list);
                cands.push_all(list);
                target_order[a..b]
                    .iter()
                    .map(|&(_, t)| {
                        let p = targets[t] - origin;
                        let (num, den) = pair_sums_dispatch(
                            cands,
                            [p.x as f32, p.y as f32, p.z as f32],
                            sf,
                            r2_max,
                        );
                        (t, (den > 0.0).then(|| num / den))
                    })
                    .collect()
            },
        )
        .collect();
    let mut out = vec![None; targets.len()];
    for (t, v) in results.into_iter().flatten() {
        out[t] = v;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_meshes::icosphere;

    fn exact_average(
        sources: &[DVec3],
        weights: &[f64],
        values: &[f64],
        v: DVec3,
        sigma: f64,
        cutoff: f64,
    ) -> Option<f64> {
        let (mut num, mut den) = (0.0, 0.0);
        for ((p, a), f) in sources.iter().zip(weights).zip(values) {
            let d2 = p.distance_squared(v);
            if d2 < cutoff * cutoff {
                let w = a * (-d2 / (2.0 * sigma * sigma)).exp();
                num += w * f;
                den += w;
            }
        }
        (den > 0.0).then(|| num / den)
    }

    /// A sphere of 40,962 vertices (spacing ~0.017) with a value that varies at every scale,
    /// uneven weights, and targets on and off the surface: at σ where a cluster holds 1 to 30
    /// points the clustered average stays within 0.2% of the value range (~4.6) of the exact one
    /// at every target, within 0.02% on average (measured: ≤ 4.4e-3, mean ≤ 6e-4).
    #[test]
    fn clustered_average_is_close_to_the_exact_sum() {
        let mesh = icosphere(1.0, 6);
        let sources = &mesh.positions;
        let weights: Vec<f64> = (0..sources.len())
            .map(|i| 0.5 + (i % 7) as f64 / 7.0)
            .collect();
        let values: Vec<f64> = sources
            .iter()
            .map(|p| (5.0 * p.x).sin() + (13.0 * p.y * p.z).cos() + 0.3 * (40.0 * p.z).sin())
            .collect();
        let mut targets: Vec<DVec3> = sources.iter().step_by(13).copied().collect();
        targets.extend(sources.iter().step_by(29).map(|p| *p * 1.03));
        for (sigma, reach) in [(0.1, 2.0), (0.3, 2.0), (0.2, 3.0)] {
            let fast = clustered_gaussian_average(
                sources,
                &weights,
                &values,
                &targets,
                sigma,
                reach * sigma,
                6.0,
            );
            let (mut worst, mut total) = (0.0f64, 0.0);
            for (t, got) in targets.iter().zip(&fast) {
                let want = exact_average(sources, &weights, &values, *t, sigma, reach * sigma);
                let (got, want) = (
                    got.expect("a cluster in reach"),
                    want.expect("a source in reach"),
                );
                worst = worst.max((got - want).abs());
                total += (got - want).abs();
            }
            let mean = total / targets.len() as f64;
            eprintln!("σ {sigma}, cutoff {reach}σ: worst {worst:.2e}, mean {mean:.2e}");
            assert!(
                worst < 0.01 && mean < 1e-3,
                "σ {sigma}: worst {worst}, mean {mean}"
            );
        }
    }

    #[test]
    fn no_sources_in_reach_gives_none_and_one_source_gives_its_value() {
        let sources = [DVec3::new(0.0, 0.0, 0.0)];
        let targets = [DVec3::new(0.01, 0.0, 0.0), DVec3::new(5.0, 0.0, 0.0)];
        let got = clustered_gaussian_average(&sources, &[2.0], &[0.25], &targets, 0.1, 0.2, 6.0);
        assert_eq!(got[1], None);
        assert!((got[0].unwrap() - 0.25).abs() < 1e-6, "{got:?}");
        assert!(
            clustered_gaussian_average(&[], &[], &[], &targets, 0.1, 0.2, 6.0)
                .iter()
                .all(Option::is_none)
        );
    }

    /// The AVX2 build of the pair loop must give the plain build's bits: that is what makes
    /// the maps the same on every x86-64.
    #[test]
    fn avx2_and_plain_pair_loops_agree_bit_for_bit() {
        #[cfg(target_arch = "x86_64")]
        {
            if !std::arch::is_x86_feature_detected!("avx2") {
                eprintln!("no AVX2 on this CPU: only the plain loop runs here");
                return;
            }
            let mut list = Vec::new();
            let mut x = 0x9E37_79B9_7F4A_7C15u64;
            let mut next = || {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                (x >> 40) as f32 / (1u64 << 24) as f32 - 0.5
            };
            for _ in 0..1003 {
                list.push(Cluster {
                    c: [next(), next(), next()],
                    w0: 1.0 + next(),
                    wq: [next(), next(), next(), next(), next(), next()],
                    mean: next(),
                    fg: [next(), next(), next()],
                    f0: next(),
                    ramp: 10.0 * (next() + 0.6),
                });
            }
            let mut cands = Candidates::default();
            cands.push_all(&list);
            for _ in 0..50 {
                let v = [next(), next(), next()];
                let plain = pair_sums(&cands, v, 3.0, 0.3);
                // SAFETY: AVX2 is present, checked above.
                let wide = unsafe { pair_sums_avx2(&cands, v, 3.0, 0.3) };
                assert_eq!(plain.0.to_bits(), wide.0.to_bits());
                assert_eq!(plain.1.to_bits(), wide.1.to_bits());
            }
        }
    }

    #[test]
    fn exp_matches_libm_over_its_range() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let x = -87.0 * i as f64 / 200_000.0;
            let exact = x.exp();
            let ours = exp_nonpositive(x as f32) as f64;
            // Relative to the f32 input's own rounding (|x| ε_f32).
            let input_err = (x - (x as f32) as f64).abs();
            let rel = ((ours - exact) / exact).abs() - input_err;
            worst = worst.max(rel);
        }
        assert!(worst < 5e-7, "worst relative error {worst}");
    }
}

//! "SRI": surface regions of interest (Leifman, Shtrom, Tal, CVPR 2012; TPAMI 2016), as
//! reconstructed in docs/baselines.md (no public code exists; every choice the papers'
//! abstracts leave open is a parameter here):
//! 1. vertex descriptors: spin images at each support radius, reduced by PCA;
//! 2. distinctness (after Goferman et al.'s context-aware saliency): a vertex is distinct
//!    when even its most similar vertices are far from it in descriptor space, where
//!    nearby look-alikes count less: d(i, j) = ‖u_i − u_j‖ / (1 + c·g(i, j)) with g the
//!    geodesic distance, D(i) = 1 − exp(−mean of the K smallest d(i, ·)), averaged over radii;
//! 3. shape extremities: patches on the convex hull of a multidimensional-scaling embedding of
//!    the geodesic distances that are also local maxima of distance from its centre (tips of
//!    limbs, ears, tails);
//! 4. association: foci = the most distinct vertices and the extremities; every vertex gains
//!    A(v) = max over foci f of value_f · exp(−g(v, f)² / 2σ²), so regions near foci rise
//!    (a distinct focus is worth how far its D stands above the median vertex's, an extremity by how far it reaches past the median
//!    radius of the embedding); S = ½ (D + A).
//!
//! Geodesic distances are coarse: between patch centres along the patch adjacency graph
//! (never below the straight distance; the straight distance across components).
use crate::saliency::SaliencyError;
use faer::Mat;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::pca::{pca_project, symmetric_eigen};
use super::spin_images::spin_images;
use super::working_copy::{RawSpread, WorkingCopy, WorkingCopyReport};
use crate::gaze_model::view_visibility::fibonacci_directions;
use crate::mesh::edge_graph::distance_or_euclidean;
use crate::mesh::over_segmentation::{over_segment, Patches};
use crate::mesh::Mesh;
use crate::total_order_key::{from_total_order_key, total_order_key};

/// Parameters of SRI (Leifman et al. 2012); docs/baselines.md gives the choices.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SriParams {
    /// Vertices of the simplified working copy.
    pub vertices: usize,
    /// Spin-image support radii (normalized units: half the bounding-box diagonal = 1).
    pub radii: Vec<f64>,
    /// Spin-image bins along α (distance from the normal axis).
    pub alpha_bins: usize,
    /// Spin-image bins along β (height along the normal).
    pub beta_bins: usize,
    /// Principal components kept of each spin image.
    pub pca_dims: usize,
    /// K: how many most similar vertices a vertex's distinctness averages over.
    pub most_similar: usize,
    /// c: how much geodesic distance discounts a look-alike (Goferman et al.'s 3).
    pub geodesic_weight: f64,
    /// Spin-image distance (images sum to 1) that counts as "unlike": D = 1 − exp(−d/this).
    pub distance_scale: f64,
    /// Patches for the coarse geodesic distances and the extremities.
    pub patches: usize,
    /// Vertices whose distinctness is at least this fraction of the largest are foci.
    pub focus_threshold: f64,
    /// σ of the association's geodesic Gaussian (normalized units).
    pub association_sigma: f64,
    /// Directions probed to find the embedding's convex hull.
    pub hull_directions: usize,
    /// An extremity at this multiple of the embedding's median radius (or farther) is a
    /// focus of full weight; one at the median radius weighs nothing.
    pub extremity_reach: f64,
    /// Seed of the random steps.
    pub seed: u64,
}

impl Default for SriParams {
    fn default() -> Self {
        SriParams {
            vertices: 10_000,
            radii: vec![0.05, 0.1, 0.2],
            alpha_bins: 8,
            beta_bins: 16,
            pca_dims: 16,
            most_similar: 64,
            geodesic_weight: 3.0,
            distance_scale: 0.1,
            patches: 500,
            focus_threshold: 0.8,
            association_sigma: 0.1,
            hull_directions: 2000,
            extremity_reach: 1.5,
            seed: 1,
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct SriReport {
    pub working_copy: WorkingCopyReport,
    /// The map on the working copy before rescaling.
    pub raw: RawSpread,
    /// The two terms of S = ½ (D + A).
    pub distinctness: RawSpread,
    pub association: RawSpread,
    pub patches: usize,
    pub extremities: usize,
    pub distinct_foci: usize,
}

/// SRI's map of `mesh`, one value per input vertex, with its report.
pub fn surface_regions_of_interest(
    mesh: &Mesh,
    params: &SriParams,
) -> Result<(Vec<f64>, SriReport), SaliencyError> {
    if params.radii.is_empty() || params.most_similar == 0 {
        return Err(SaliencyError::Invalid(
            "sri needs at least one radius and most_similar ≥ 1".into(),
        ));
    }
    let work = WorkingCopy::new(mesh, params.vertices).map_err(SaliencyError::Compute)?;
    let n = work.len();
    let patches = over_segment(&work.mesh, &work.graph, params.patches, params.seed);
    let centre_distance = patches.centre_distances(&work.mesh);
    let geodesic = |i: usize, j: usize| {
        let (a, b) = (patches.label[i] as usize, patches.label[j] as usize);
        distance_or_euclidean(
            centre_distance[a][b],
            work.mesh.positions[i],
            work.mesh.positions[j],
        )
    };

    // Per radius: PCA-reduced spin images (an orthogonal projection, so distances stay in
    // the images' own units: a featureless shape stays featureless) as f32, stored dimension
    // by dimension so the pair loop below runs across many vertices j at once.
    let to_units = 1.0 / params.distance_scale;
    let mut scales = Vec::with_capacity(params.radii.len());
    for &radius in &params.radii {
        let images = spin_images(&work, radius, params.alpha_bins, params.beta_bins);
        let u = pca_project(&images, params.pca_dims).map_err(SaliencyError::Compute)?;
        scales.push(DescriptorColumns::new(&u, to_units));
    }
    let k = params.most_similar.min(n - 1).max(1);
    let pairs = PairTerms {
        x: work.mesh.positions.iter().map(|p| p.x).collect(),
        y: work.mesh.positions.iter().map(|p| p.y).collect(),
        z: work.mesh.positions.iter().map(|p| p.z).collect(),
        label: &patches.label,
        centre_distance: &centre_distance,
        geodesic_weight: params.geodesic_weight,
        scales: &scales,
    };
    // One pass over all pairs serves every radius: the geodesic term is shared.
    let distinctness: Vec<f64> = (0..n)
        .into_par_iter()
        .map_init(
            || PairScratch::new(n, scales.len()),
            |scratch, i| {
                pairs.discounted_distances(i, scratch);
                (0..scales.len())
                    .map(|s| 1.0 - (-scratch.mean_of_smallest(s, i, n, k)).exp())
                    .sum::<f64>()
                    / scales.len() as f64
            },
        )
        .collect();
    let max_d = distinctness.iter().cloned().fold(0.0, f64::max);
    let extremities = extremity_patches(&work, &patches, &centre_distance, params.hull_directions)
        .map_err(SaliencyError::Compute)?;
    // Foci are picked relative to the most distinct vertex but weigh how far they stand above
    // the typical (median) vertex, so on a shape with nothing distinct no focus lifts its
    // surroundings.
    let mut sorted = distinctness.clone();
    sorted.sort_by(f64::total_cmp);
    let typical = sorted[n / 2];
    let mut foci: Vec<(usize, f64)> = (0..n)
        .filter(|&v| max_d > 0.0 && distinctness[v] >= params.focus_threshold * max_d)
        .map(|v| (v, ((distinctness[v] - typical) / (1.0 - typical)).max(0.0)))
        .collect();
    let distinct_foci = foci.len();
    foci.extend(extremities.iter().filter_map(|&(p, reach)| {
        let weight = ((reach - 1.0) / (params.extremity_reach - 1.0)).clamp(0.0, 1.0);
        (weight > 0.0).then_some((patches.centres[p], weight))
    }));
    let inv = 1.0 / (2.0 * params.association_sigma * params.association_sigma);
    let association: Vec<f64> = (0..n)
        .into_par_iter()
        .map(|v| {
            foci.iter()
                .map(|&(f, value)| {
                    let g = geodesic(v, f);
                    value * (-g * g * inv).exp()
                })
                .fold(0.0, f64::max)
        })
        .collect();
    let saliency: Vec<f64> = (0..n)
        .map(|v| 0.5 * (distinctness[v] + association[v]))
        .collect();
    Ok((
        work.carry_back(&saliency),
        SriReport {
            working_copy: work.report(),
            raw: RawSpread::of(&saliency, &work.areas),
            distinctness: RawSpread::of(&distinctness, &work.areas),
            association: RawSpread::of(&association, &work.areas),
            patches: patches.len(),
            extremities: extremities.len(),
            distinct_foci,
        },
    ))
}

/// One radius's reduced descriptors as f32 columns: `values[c * stride + j]` is dimension c
/// of vertex j, dimensions zero-padded to a multiple of 8 and vertices to `stride`, a
/// multiple of `PAIR_BLOCK`, so the pair loop runs whole blocks only.
struct DescriptorColumns {
    dims: usize,
    stride: usize,
    values: Vec<f32>,
}

impl DescriptorColumns {
    fn new(rows: &[Vec<f64>], scale: f64) -> Self {
        let stride = rows.len().div_ceil(PAIR_BLOCK) * PAIR_BLOCK;
        let dims = rows.first().map_or(0, |r| r.len()).div_ceil(8) * 8;
        let mut values = vec![0.0f32; dims * stride];
        for (j, row) in rows.iter().enumerate() {
            for (c, &x) in row.iter().enumerate() {
                values[c * stride + j] = (x * scale) as f32;
            }
        }
        DescriptorColumns {
            dims,
            stride,
            values,
        }
    }
}

/// Vertices j handled together: 8 lanes of f32 for each of them stay in L1.
const PAIR_BLOCK: usize = 64;

/// What the distinctness pair loop reads: positions, patches and descriptors.
struct PairTerms<'a> {
    x: Vec<f64>,
    y: Vec<f64>,
    z: Vec<f64>,
    label: &'a [u32],
    centre_distance: &'a [Vec<f64>],
    geodesic_weight: f64,
    scales: &'a [DescriptorColumns],
}

/// Per-thread buffers of the pair loop, `PAIR_BLOCK`-padded: `rows[s][j]` is d(i, j) at
/// radius s for every j (j = i included, the padding after n meaningless).
struct PairScratch {
    discount: Vec<f64>,
    path: Vec<f64>,
    rows: Vec<Vec<f64>>,
    /// The k smallest of a row seen so far, as total-order keys (largest on top).
    smallest: std::collections::BinaryHeap<i64>,
}

impl PairScratch {
    fn new(n: usize, scales: usize) -> Self {
        let stride = n.div_ceil(PAIR_BLOCK) * PAIR_BLOCK;
        PairScratch {
            discount: vec![0.0; stride],
            path: vec![0.0; n],
            rows: vec![vec![0.0; stride]; scales],
            smallest: std::collections::BinaryHeap::with_capacity(PAIR_BLOCK),
        }
    }

    /// Mean of the k smallest d(i, j), j ≠ i, at radius s.
    fn mean_of_smallest(&mut self, s: usize, i: usize, n: usize, k: usize) -> f64 {
        mean_of_k_smallest(&self.rows[s][..n], i, k, &mut self.smallest)
    }
}

/// Mean of the k smallest values of `row` other than `row[skip]` (by `f64::total_cmp`; all
/// of them if fewer), summed in ascending order. One pass keeping the k smallest so far in a
/// max-heap: a block of 64 values is looked at one by one only if one of them is not above
/// the heap's top (a test that runs on whole vectors), which after the first blocks is rare,
/// where a quickselect of the whole row moved every value several times.
fn mean_of_k_smallest(
    row: &[f64],
    skip: usize,
    k: usize,
    heap: &mut std::collections::BinaryHeap<i64>,
) -> f64 {
    const BLOCK: usize = 64;
    heap.clear();
    let mut top = f64::NAN;
    for (b, block) in row.chunks(BLOCK).enumerate() {
        let start = b * BLOCK;
        let full = heap.len() >= k;
        // `!(x > top)` also holds for NaN (and for any x when top is NaN): such blocks take
        // the exact path, so the test only ever skips blocks of values above the top.
        #[allow(clippy::neg_cmp_op_on_partial_ord)] // NaN must count as a candidate
        let candidate = block.iter().fold(false, |any, &x| any | !(x > top));
        if full && !candidate && !(start..start + block.len()).contains(&skip) {
            continue;
        }
        for (t, &x) in block.iter().enumerate() {
            if start + t == skip {
                continue;
            }
            let key = total_order_key(x);
            if heap.len() < k {
                heap.push(key);
            } else if heap.peek().is_some_and(|&largest| key < largest) {
                if let Some(mut largest) = heap.peek_mut() {
                    *largest = key;
                }
            } else {
                continue;
            }
            if heap.len() >= k {
                top = heap
                    .peek()
                    .map_or(f64::NAN, |&key| from_total_order_key(key));
            }
        }
    }
    let mut kept: Vec<i64> = heap.drain().collect();
    kept.sort_unstable();
    let count = kept.len().max(1);
    kept.into_iter().map(from_total_order_key).sum::<f64>() / count as f64
}

impl PairTerms<'_> {
    fn discounted_distances(&self, i: usize, scratch: &mut PairScratch) {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F, checked just above.
                return unsafe { self.discounted_distances_avx512(i, scratch) };
            }
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2, checked just above.
                return unsafe { self.discounted_distances_avx2(i, scratch) };
            }
        }
        self.discounted_distances_portable(i, scratch)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    fn discounted_distances_avx512(&self, i: usize, scratch: &mut PairScratch) {
        self.discounted_distances_portable(i, scratch)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn discounted_distances_avx2(&self, i: usize, scratch: &mut PairScratch) {
        self.discounted_distances_portable(i, scratch)
    }

    /// d(i, j) = ‖u_i − u_j‖ / (1 + c·g(i, j)) for every j and radius. Every value is the
    /// same IEEE sequence of operations in every build (no fused multiply-add, the eight
    /// lanes of the descriptor distance summed in lane order), so SIMD width does not
    /// change a bit: the geodesic g is the patch-centre path, never below the straight
    /// distance, or the straight distance across components.
    #[inline(always)]
    fn discounted_distances_portable(&self, i: usize, scratch: &mut PairScratch) {
        let from_patch = &self.centre_distance[self.label[i] as usize];
        for (path, &l) in scratch.path.iter_mut().zip(self.label) {
            *path = from_patch[l as usize];
        }
        let (xi, yi, zi) = (self.x[i], self.y[i], self.z[i]);
        let c = self.geodesic_weight;
        let positions = self.x.iter().zip(&self.y).zip(&self.z);
        for ((discount, ((x, y), z)), &path) in scratch
            .discount
            .iter_mut()
            .zip(positions)
            .zip(&scratch.path)
        {
            let (dx, dy, dz) = (xi - x, yi - y, zi - z);
            let straight = (dx * dx + dy * dy + dz * dz).sqrt();
            let g = if path.is_finite() {
                path.max(straight)
            } else {
                straight
            };
            *discount = 1.0 / (1.0 + c * g);
        }
        debug_assert_eq!(scratch.discount.len() % PAIR_BLOCK, 0);
        for (scale, row) in self.scales.iter().zip(scratch.rows.iter_mut()) {
            let own: Vec<f32> = (0..scale.dims)
                .map(|d| scale.values[d * scale.stride + i])
                .collect();
            let blocks = row
                .chunks_exact_mut(PAIR_BLOCK)
                .zip(scratch.discount.chunks_exact(PAIR_BLOCK));
            for (b, (out, discount)) in blocks.enumerate() {
                let start = b * PAIR_BLOCK;
                let mut lanes = [[0.0f32; PAIR_BLOCK]; 8];
                for (d, &u) in own.iter().enumerate() {
                    let at = d * scale.stride + start;
                    let column = &scale.values[at..at + PAIR_BLOCK];
                    for (lane, &v) in lanes[d % 8].iter_mut().zip(column) {
                        let diff = u - v;
                        *lane += diff * diff;
                    }
                }
                for t in 0..PAIR_BLOCK {
                    let mut sum = lanes[0][t];
                    for lane in &lanes[1..] {
                        sum += lane[t];
                    }
                    out[t] = (sum as f64).sqrt() * discount[t];
                }
            }
        }
    }
}

/// Patches whose centres lie on the convex hull of a 3-D classical MDS embedding of the
/// centre-to-centre geodesic distances and are farther from the embedding's centroid than
/// every neighbouring patch, each with its distance from the centroid over the median's.
fn extremity_patches(
    work: &WorkingCopy,
    patches: &Patches,
    centre_distance: &[Vec<f64>],
    directions: usize,
) -> Result<Vec<(usize, f64)>, String> {
    let p = patches.len();
    if p < 4 {
        return Ok(Vec::new());
    }
    // Double-centred squared distances: B = −½ J D² J.
    let pos = |a: usize| work.mesh.positions[patches.centres[a]];
    let mut sq = Mat::<f64>::zeros(p, p);
    for a in 0..p {
        for b in 0..p {
            let g = distance_or_euclidean(centre_distance[a][b], pos(a), pos(b));
            sq[(a, b)] = g * g;
        }
    }
    let row_mean: Vec<f64> = (0..p)
        .map(|a| (0..p).map(|b| sq[(a, b)]).sum::<f64>() / p as f64)
        .collect();
    let all_mean = row_mean.iter().sum::<f64>() / p as f64;
    let mut b = Mat::<f64>::zeros(p, p);
    for i in 0..p {
        for j in 0..p {
            b[(i, j)] = -0.5 * (sq[(i, j)] - row_mean[i] - row_mean[j] + all_mean);
        }
    }
    let (values, vectors) = symmetric_eigen(&b)?;
    let embedding: Vec<[f64; 3]> = (0..p)
        .map(|i| {
            std::array::from_fn(|k| {
                let col = p - 1 - k;
                values[col].max(0.0).sqrt() * vectors[(i, col)]
            })
        })
        .collect();
    let mut on_hull = vec![false; p];
    for d in fibonacci_directions(directions) {
        let d = d.to_array();
        let best = (0..p)
            .max_by(|&x, &y| {
                let dx: f64 = (0..3).map(|k| embedding[x][k] * d[k]).sum();
                let dy: f64 = (0..3).map(|k| embedding[y][k] * d[k]).sum();
                dx.total_cmp(&dy).then(y.cmp(&x))
            })
            .expect("p ≥ 4");
        on_hull[best] = true;
    }
    let centroid: [f64; 3] =
        std::array::from_fn(|k| embedding.iter().map(|e| e[k]).sum::<f64>() / p as f64);
    let radius: Vec<f64> = embedding
        .iter()
        .map(|e| {
            (0..3)
                .map(|k| (e[k] - centroid[k]).powi(2))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let mut sorted = radius.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[p / 2].max(f64::MIN_POSITIVE);
    Ok((0..p)
        .filter(|&a| on_hull[a] && patches.adjacency[a].iter().all(|&q| radius[q] < radius[a]))
        .map(|a| (a, radius[a] / median))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// The heap's mean equals sorting the whole row by `total_cmp` and summing the k first in
    /// order, bit for bit, on rows with ties, zeros, −0, infinities and fewer values than k.
    #[test]
    fn the_k_smallest_mean_equals_sorting_the_row() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut heap = std::collections::BinaryHeap::new();
        for case in 0..400 {
            let n = (next() % 700) as usize;
            let k = 1 + (next() % 80) as usize;
            let row: Vec<f64> = (0..n)
                .map(|_| match next() % 10 {
                    0 => 0.0,
                    1 => -0.0,
                    2 => 0.25,
                    3 if case % 7 == 0 => f64::INFINITY,
                    4 if case % 11 == 0 => f64::NAN,
                    _ => (next() % 1_000_000) as f64 / 7919.0,
                })
                .collect();
            let mut sorted = row.clone();
            sorted.sort_by(f64::total_cmp);
            let take = k.min(n);
            let want = sorted[..take].iter().sum::<f64>() / take.max(1) as f64;
            let got = mean_of_k_smallest(&row, n, k, &mut heap);
            assert_eq!(got.to_bits(), want.to_bits(), "case {case}: n {n}, k {k}");
            // Leaving one value out is the same as removing it from the row.
            if n > 0 {
                let skip = (next() % n as u64) as usize;
                let mut rest = row.clone();
                rest.remove(skip);
                rest.sort_by(f64::total_cmp);
                let take = k.min(n - 1);
                let want = rest[..take].iter().sum::<f64>() / take.max(1) as f64;
                let got = mean_of_k_smallest(&row, skip, k, &mut heap);
                assert_eq!(got.to_bits(), want.to_bits(), "case {case}: skip {skip}");
            }
        }
    }

    /// d(i, j) as the pair loop first computed it, one pair at a time: row-major f32
    /// descriptors, their 8-lane distance summed in lane order, glam's straight distance.
    fn one_pair(terms: &PairTerms, rows: &[Vec<Vec<f32>>], i: usize, j: usize) -> Vec<f64> {
        let at = |v: usize| DVec3::new(terms.x[v], terms.y[v], terms.z[v]);
        let straight = at(i).distance(at(j));
        let path = terms.centre_distance[terms.label[i] as usize][terms.label[j] as usize];
        let g = if path.is_finite() {
            path.max(straight)
        } else {
            straight
        };
        let discount = 1.0 / (1.0 + terms.geodesic_weight * g);
        rows.iter()
            .map(|scale| {
                let mut lanes = [0.0f32; 8];
                for (a, b) in scale[i].chunks_exact(8).zip(scale[j].chunks_exact(8)) {
                    for k in 0..8 {
                        let d = a[k] - b[k];
                        lanes[k] += d * d;
                    }
                }
                (lanes.iter().sum::<f32>() as f64).sqrt() * discount
            })
            .collect()
    }

    /// The blocked, column-wise loop must give every pair's value to the bit, in every SIMD
    /// width this CPU has: the maps of earlier versions stay the same bytes.
    #[test]
    fn the_blocked_pair_loop_matches_the_pairwise_definition_bit_for_bit() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // 150 vertices: two whole blocks and a partial one; 16 and 5 (padded to 8) dims.
        let n = 150;
        let descriptors: Vec<Vec<Vec<f64>>> = [16, 5]
            .iter()
            .map(|&d| {
                (0..n)
                    .map(|_| (0..d).map(|_| next() - 0.5).collect())
                    .collect()
            })
            .collect();
        let label: Vec<u32> = (0..n).map(|_| (next() * 4.0) as u32).collect();
        // Patch 3 is another component: no path to it.
        let centre_distance: Vec<Vec<f64>> = (0..4)
            .map(|a| {
                (0..4)
                    .map(|b| {
                        if a == b {
                            0.0
                        } else if a == 3 || b == 3 {
                            f64::INFINITY
                        } else {
                            0.3 + 0.1 * (a + b) as f64
                        }
                    })
                    .collect()
            })
            .collect();
        let scale = 10.0;
        let scales: Vec<DescriptorColumns> = descriptors
            .iter()
            .map(|u| DescriptorColumns::new(u, scale))
            .collect();
        let rows: Vec<Vec<Vec<f32>>> = descriptors
            .iter()
            .map(|u| {
                u.iter()
                    .map(|r| {
                        let mut v: Vec<f32> = r.iter().map(|x| (x * scale) as f32).collect();
                        v.resize(r.len().div_ceil(8) * 8, 0.0);
                        v
                    })
                    .collect()
            })
            .collect();
        let terms = PairTerms {
            x: (0..n).map(|_| next()).collect(),
            y: (0..n).map(|_| next()).collect(),
            z: (0..n).map(|_| next()).collect(),
            label: &label,
            centre_distance: &centre_distance,
            geodesic_weight: 3.0,
            scales: &scales,
        };
        type Variant = fn(&PairTerms, usize, &mut PairScratch);
        let mut variants: Vec<(&str, Variant)> = vec![
            ("dispatched", |t, i, s| t.discounted_distances(i, s)),
            ("portable", |t, i, s| t.discounted_distances_portable(i, s)),
        ];
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                variants.push(("avx2", |t, i, s| unsafe {
                    t.discounted_distances_avx2(i, s)
                }));
            }
            if std::arch::is_x86_feature_detected!("avx512f") {
                variants.push(("avx512", |t, i, s| unsafe {
                    t.discounted_distances_avx512(i, s)
                }));
            }
        }
        for (name, variant) in variants {
            let mut scratch = PairScratch::new(n, scales.len());
            for i in [0, 1, 63, 64, 100, 149] {
                variant(&terms, i, &mut scratch);
                for j in (0..n).filter(|&j| j != i) {
                    let expected = one_pair(&terms, &rows, i, j);
                    for (s, e) in expected.iter().enumerate() {
                        assert_eq!(
                            scratch.rows[s][j].to_bits(),
                            e.to_bits(),
                            "{name}: d({i}, {j}) at scale {s}"
                        );
                    }
                }
            }
        }
    }
}

//! Gaussian Euclidean distance transform (GEDT) of a surface: exp(-d²/(2s²)) with d the
//! distance to the nearest triangle. The harmonic shape descriptor samples this field on
//! spheres (Kazhdan et al. 2003; paper §3.3: a 256³ grid).
//!
//! The grid is built in three steps, each O(voxels):
//! 1. seed: voxels within one voxel of a triangle get their exact squared distance to it;
//! 2. a separable exact distance transform (Felzenszwalb & Huttenlocher 2012) of those seeds
//!    spreads to every voxel the triangle of the seed that minimizes |x - y|² + d(y)²;
//! 3. each voxel's value is the Gaussian of its exact distance to that triangle.
//!
//! Unlike a voxelized EDT (ShapeSPH rasterizes the surface and measures to voxel centres,
//! an error up to half a voxel diagonal) the distance near the surface is exact, which matters
//! when the smallest ball (radius 0.02) spans only a few voxels.
use crate::saliency::SaliencyError;
use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::mesh::geometry::closest_point_on_triangle;
use crate::mesh::Mesh;

/// Anything that gives the Gaussian distance field at a point of the normalized frame.
pub trait GaussianField: Sync {
    /// The field at `p`.
    fn value(&self, p: DVec3) -> f32;

    /// The shortest length over which the field can change (a grid's voxel size), or None
    /// when it has no such floor (the exact field).
    fn detail_length(&self) -> Option<f64> {
        None
    }

    /// Values at `center + radius * d` for each unit direction `d`. The grid overrides this
    /// with a faster path; the result must equal calling `value` at each point.
    fn values_on_sphere(
        &self,
        center: DVec3,
        radius: f64,
        directions: &[glam::Vec3],
        out: &mut [f32],
    ) {
        for (o, d) in out.iter_mut().zip(directions) {
            *o = self.value(center + d.as_dvec3() * radius);
        }
    }
}

/// The distance-field grid.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridParams {
    /// Voxels per side (paper: 256).
    pub resolution: usize,
    /// Gaussian width in voxels (ShapeSPH's default fall-off √8).
    pub sigma_voxels: f64,
}

impl Default for GridParams {
    fn default() -> Self {
        GridParams {
            resolution: 256,
            sigma_voxels: 8f64.sqrt(),
        }
    }
}

/// The field sampled on a cubic grid, read by trilinear interpolation.
pub struct GridField {
    origin: DVec3,
    /// Voxel size in normalized units.
    pub h: f64,
    /// Voxels per side.
    pub resolution: usize,
    /// Gaussian width in normalized units.
    pub sigma: f64,
    values: Vec<f32>,
}

const NO_TRIANGLE: u32 = u32::MAX;

/// Origin (lower corner) and voxel size of the cubic grid for a mesh with bounds [lo, hi]:
/// the mesh plus `reach` plus 4 Gaussian widths and 2 voxels (trilinear neighbours) on every
/// side. Widths and voxels scale with the cube side L = side + 2·margin, which is solved for L.
pub fn grid_geometry(
    lo: DVec3,
    hi: DVec3,
    reach: f64,
    params: GridParams,
) -> Result<(DVec3, f64), String> {
    let r = params.resolution;
    if !(16..=1024).contains(&r) {
        return Err(format!("grid resolution {r} is out of range (16 to 1024)"));
    }
    if !(params.sigma_voxels > 0.0 && params.sigma_voxels.is_finite()) {
        return Err(format!(
            "the Gaussian width must be positive (got {} voxels)",
            params.sigma_voxels
        ));
    }
    let side = (hi - lo).max_element();
    let voxel_margin = 4.0 * params.sigma_voxels + 2.0;
    let shrink = 1.0 - 2.0 * voxel_margin / r as f64;
    if shrink < 0.25 {
        return Err(format!(
            "grid resolution {r} is too small for a Gaussian of {} voxels",
            params.sigma_voxels
        ));
    }
    let length = (side + 2.0 * reach) / shrink;
    let h = length / r as f64;
    Ok(((lo + hi) * 0.5 - DVec3::splat(length * 0.5), h))
}

impl GridField {
    /// Builds the field of `mesh` (already normalized) on a grid that covers the mesh plus
    /// `reach` (the largest sphere radius that will be sampled) and the Gaussian's tail.
    pub fn build(mesh: &Mesh, reach: f64, params: GridParams) -> Result<GridField, SaliencyError> {
        let r = params.resolution;
        let (lo, hi) = mesh
            .referenced_bounds()
            .ok_or_else(|| SaliencyError::Compute("the mesh has no triangle".into()))?;
        let (origin, h) = grid_geometry(lo, hi, reach, params).map_err(SaliencyError::Invalid)?;
        let n = r * r * r;
        let mut dist2 = vec![f32::INFINITY; n];
        let mut tri = vec![NO_TRIANGLE; n];
        seed_near_surface(mesh, origin, h, r, &mut dist2, &mut tri);
        let sigma = params.sigma_voxels * h;
        let cutoff2 = gaussian_cutoff2(sigma, h);
        distance_transform_3d(r, &mut dist2, &mut tri, cutoff2);
        let values = gaussian_of_exact_distance(mesh, (origin, h, r), sigma, cutoff2, &dist2, &tri);
        Ok(GridField {
            origin,
            h,
            resolution: r,
            sigma,
            values,
        })
    }

    /// Trilinear value at grid coordinates `u` (voxel centres at integers).
    #[inline]
    fn trilinear(&self, u: glam::Vec3) -> f32 {
        let limit = (self.resolution - 1) as f32;
        // Each coordinate compared on its own, as the AVX2 path does: a NaN fails (glam's
        // min_element would pass over it).
        if !(u.x >= 0.0 && u.y >= 0.0 && u.z >= 0.0 && u.x < limit && u.y < limit && u.z < limit) {
            return 0.0;
        }
        // SAFETY: 0 <= u < resolution - 1 <= 1023 was just checked (NaN fails it too), so
        // each coordinate fits an i32. `as usize` from f32 saturates in ~30 instructions; this
        // is the innermost loop of the descriptors.
        let (x, y, z) = unsafe {
            (
                u.x.to_int_unchecked::<i32>() as usize,
                u.y.to_int_unchecked::<i32>() as usize,
                u.z.to_int_unchecked::<i32>() as usize,
            )
        };
        let (tx, ty, tz) = (u.x - x as f32, u.y - y as f32, u.z - z as f32);
        let r = self.resolution;
        let i = (z * r + y) * r + x;
        // SAFETY: 0 <= x, y, z < r - 1 was checked above, so i + r² + r + 1 (the far corner)
        // is below r³ = values.len(). This is the innermost loop of the descriptors.
        let at = |k: usize| unsafe { *self.values.get_unchecked(k) };
        let lerp = |a: f32, b: f32, s: f32| a + (b - a) * s;
        let c00 = lerp(at(i), at(i + 1), tx);
        let c10 = lerp(at(i + r), at(i + r + 1), tx);
        let c01 = lerp(at(i + r * r), at(i + r * r + 1), tx);
        let c11 = lerp(at(i + r * r + r), at(i + r * r + r + 1), tx);
        lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), tz)
    }
}

impl GaussianField for GridField {
    fn value(&self, p: DVec3) -> f32 {
        self.trilinear(((p - self.origin) / self.h - DVec3::splat(0.5)).as_vec3())
    }

    fn detail_length(&self) -> Option<f64> {
        Some(self.h)
    }

    fn values_on_sphere(
        &self,
        center: DVec3,
        radius: f64,
        directions: &[glam::Vec3],
        out: &mut [f32],
    ) {
        // Grid coordinates in f32: at most 1024 voxels, so the error is ~1e-4 voxel.
        let c = ((center - self.origin) / self.h - DVec3::splat(0.5)).as_vec3();
        let s = (radius / self.h) as f32;
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2, checked just above.
                let done = unsafe { self.trilinear_on_sphere_avx2(c, s, directions, out) };
                for (o, d) in out[done..].iter_mut().zip(&directions[done..]) {
                    *o = self.trilinear(c + *d * s);
                }
                return;
            }
        }
        for (o, d) in out.iter_mut().zip(directions) {
            *o = self.trilinear(c + *d * s);
        }
    }
}

impl GridField {
    /// [`GridField::trilinear`] at `c + d * s` for the directions, eight at a time with AVX2
    /// gathers; returns how many it did (a multiple of 8; the caller does the rest). The same
    /// operations in the same order as the scalar path, without fused multiply-adds, so the
    /// same bits (unit-tested): the descriptors spend most of their time here.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn trilinear_on_sphere_avx2(
        &self,
        c: glam::Vec3,
        s: f32,
        directions: &[glam::Vec3],
        out: &mut [f32],
    ) -> usize {
        use std::arch::x86_64::*;
        let n = directions.len().min(out.len()) / 8 * 8;
        let r = self.resolution as i32;
        let limit = _mm256_set1_ps((self.resolution - 1) as f32);
        let zero = _mm256_setzero_ps();
        let (cx, cy, cz) = (
            _mm256_set1_ps(c.x),
            _mm256_set1_ps(c.y),
            _mm256_set1_ps(c.z),
        );
        let sv = _mm256_set1_ps(s);
        let rv = _mm256_set1_epi32(r);
        let (dr, dr2) = (r, r * r);
        // Float offsets of x, y, z of directions[k] from directions[k - k % 8].
        let lanes = _mm256_setr_epi32(0, 3, 6, 9, 12, 15, 18, 21);
        let base = self.values.as_ptr();
        let lerp = |a: __m256, b: __m256, t: __m256| {
            _mm256_add_ps(a, _mm256_mul_ps(_mm256_sub_ps(b, a), t))
        };
        for k in (0..n).step_by(8) {
            // SAFETY: directions[k..k + 8] exist (k + 8 <= n); Vec3 is three packed f32.
            let d = directions.as_ptr().add(k) as *const f32;
            let dx = _mm256_i32gather_ps::<4>(d, lanes);
            let dy = _mm256_i32gather_ps::<4>(d.add(1), lanes);
            let dz = _mm256_i32gather_ps::<4>(d.add(2), lanes);
            let ux = _mm256_add_ps(cx, _mm256_mul_ps(dx, sv));
            let uy = _mm256_add_ps(cy, _mm256_mul_ps(dy, sv));
            let uz = _mm256_add_ps(cz, _mm256_mul_ps(dz, sv));
            let inside = _mm256_and_ps(
                _mm256_and_ps(
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_GE_OQ>(ux, zero),
                        _mm256_cmp_ps::<_CMP_GE_OQ>(uy, zero),
                    ),
                    _mm256_and_ps(
                        _mm256_cmp_ps::<_CMP_GE_OQ>(uz, zero),
                        _mm256_cmp_ps::<_CMP_LT_OQ>(ux, limit),
                    ),
                ),
                _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(uy, limit),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(uz, limit),
                ),
            );
            // Lanes outside the grid read voxel 0 (its neighbours exist too) and are zeroed
            // at the end, as the scalar path returns 0 for them.
            let (ux, uy, uz) = (
                _mm256_and_ps(ux, inside),
                _mm256_and_ps(uy, inside),
                _mm256_and_ps(uz, inside),
            );
            let (x, y, z) = (
                _mm256_cvttps_epi32(ux),
                _mm256_cvttps_epi32(uy),
                _mm256_cvttps_epi32(uz),
            );
            let tx = _mm256_sub_ps(ux, _mm256_cvtepi32_ps(x));
            let ty = _mm256_sub_ps(uy, _mm256_cvtepi32_ps(y));
            let tz = _mm256_sub_ps(uz, _mm256_cvtepi32_ps(z));
            let i = _mm256_add_epi32(
                _mm256_mullo_epi32(_mm256_add_epi32(_mm256_mullo_epi32(z, rv), y), rv),
                x,
            );
            // SAFETY: every lane's i satisfies 0 <= x, y, z < r - 1 (or is voxel 0), so
            // i + r² + r + 1 < r³ = values.len(), as in the scalar path.
            // Voxels x and x + 1 are neighbours in memory: each lane gathers the pair as one
            // 8-byte element (half the gathered elements), then the pairs are split.
            let pairs = |offset: i32| {
                let at = _mm256_add_epi32(i, _mm256_set1_epi32(offset));
                let lo = _mm256_castpd_ps(_mm256_i32gather_pd::<4>(
                    base as *const f64,
                    _mm256_castsi256_si128(at),
                ));
                let hi = _mm256_castpd_ps(_mm256_i32gather_pd::<4>(
                    base as *const f64,
                    _mm256_extracti128_si256::<1>(at),
                ));
                // Per 128-bit half: [first of lo0, lo1, hi0, hi1]; then the 64-bit blocks
                // back into lane order.
                let first = _mm256_shuffle_ps::<0b10_00_10_00>(lo, hi);
                let second = _mm256_shuffle_ps::<0b11_01_11_01>(lo, hi);
                let order = |v: __m256| {
                    _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)))
                };
                (order(first), order(second))
            };
            let (v000, v100) = pairs(0);
            let (v010, v110) = pairs(dr);
            let (v001, v101) = pairs(dr2);
            let (v011, v111) = pairs(dr2 + dr);
            let c00 = lerp(v000, v100, tx);
            let c10 = lerp(v010, v110, tx);
            let c01 = lerp(v001, v101, tx);
            let c11 = lerp(v011, v111, tx);
            let v = lerp(lerp(c00, c10, ty), lerp(c01, c11, ty), tz);
            _mm256_storeu_ps(out.as_mut_ptr().add(k), _mm256_and_ps(v, inside));
        }
        n
    }
}

/// Exact squared distance (in voxel units²) from voxels within one voxel of each triangle.
/// Parallel over slabs of z so each thread writes only its own part of the grid.
fn seed_near_surface(
    mesh: &Mesh,
    origin: DVec3,
    h: f64,
    r: usize,
    dist2: &mut [f32],
    tri: &mut [u32],
) {
    const SLAB: usize = 4;
    // Voxel units. Above half a voxel diagonal (0.866), so the voxel holding any surface
    // point is seeded and the transform never starts more than that from the surface.
    const SEED_RADIUS: f64 = 0.9;
    let n_slabs = r.div_ceil(SLAB);
    // Voxel centres i + 0.5 within [lo - R, hi + R].
    let range_of = |lo: f64, hi: f64| -> (usize, usize) {
        let a = (lo - 0.5 - SEED_RADIUS).ceil().max(0.0) as usize;
        let b = ((hi - 0.5 + SEED_RADIUS).floor().min((r - 1) as f64)).max(0.0) as usize;
        (a, b)
    };
    // Vertices in voxel units, each transformed once (the same arithmetic per vertex as
    // transforming a triangle's corners, so the same bits).
    let voxel_positions: Vec<DVec3> = mesh
        .positions
        .par_iter()
        .map(|&p| (p - origin) / h)
        .collect();
    let corners = |t: usize| mesh.triangles[t].map(|i| voxel_positions[i as usize]);
    let boxes: Vec<[(usize, usize); 3]> = (0..mesh.triangles.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = corners(t);
            let lo = a.min(b).min(c);
            let hi = a.max(b).max(c);
            [
                range_of(lo.x, hi.x),
                range_of(lo.y, hi.y),
                range_of(lo.z, hi.z),
            ]
        })
        .collect();
    // Triangles of each slab, in triangle order (a counting sort: one pass to count, one to
    // place), so a slab visits them in the same order whatever the thread count.
    let slabs_of = |b: &[(usize, usize); 3]| b[2].0 / SLAB..b[2].1 / SLAB + 1;
    let mut starts = vec![0usize; n_slabs + 1];
    for b in &boxes {
        for s in slabs_of(b) {
            starts[s + 1] += 1;
        }
    }
    for s in 0..n_slabs {
        starts[s + 1] += starts[s];
    }
    let mut slab_triangles = vec![0u32; starts[n_slabs]];
    let mut next = starts.clone();
    for (t, b) in boxes.iter().enumerate() {
        for s in slabs_of(b) {
            slab_triangles[next[s]] = t as u32;
            next[s] += 1;
        }
    }
    let slab_len = SLAB * r * r;
    dist2
        .par_chunks_mut(slab_len)
        .zip(tri.par_chunks_mut(slab_len))
        .enumerate()
        .for_each(|(s, (d2, tr))| {
            let z_begin = s * SLAB;
            let z_end = (z_begin + SLAB).min(r);
            for &t in &slab_triangles[starts[s]..starts[s + 1]] {
                let [a, b, c] = corners(t as usize);
                let normal = (b - a).cross(c - a).normalize_or_zero();
                // No point of the triangle is farther than `spread` from its centroid, so a
                // voxel farther than spread + SEED_RADIUS from the centroid is not seeded by
                // it (the margin keeps rounding from rejecting a voxel the exact test keeps).
                let centroid = (a + b + c) / 3.0;
                let spread = (a - centroid)
                    .length_squared()
                    .max((b - centroid).length_squared())
                    .max((c - centroid).length_squared())
                    .sqrt();
                let reject2 = (spread + SEED_RADIUS + 1e-6).powi(2);
                let [bx, by, bz] = boxes[t as usize];
                for z in bz.0.max(z_begin)..=bz.1.min(z_end - 1) {
                    for y in by.0..=by.1 {
                        for x in bx.0..=bx.1 {
                            let p = DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5);
                            if (p - centroid).length_squared() > reject2 {
                                continue;
                            }
                            // The plane is never farther than the triangle: a cheap rejection.
                            if normal.dot(p - a).abs() > SEED_RADIUS {
                                continue;
                            }
                            let q = closest_point_on_triangle(p, a, b, c);
                            let dd = (p - q).length_squared();
                            let i = ((z - z_begin) * r + y) * r + x;
                            if dd <= SEED_RADIUS * SEED_RADIUS && (dd as f32) < d2[i] {
                                d2[i] = dd as f32;
                                tr[i] = t;
                            }
                        }
                    }
                }
            }
        });
}

/// 1D lower envelope of parabolas: out[q] = min_p (q - p)² + f[p], with the argmin's label.
/// `f` entries of +inf are not seeds. `base` is the index of `f[0]` on the whole grid line:
/// positions enter the arithmetic as base + q, so a window gives the bytes the whole line
/// would. Values above `cutoff2` come out as +inf without a label.
fn envelope_1d(
    f: &[f32],
    label: &[u32],
    base: usize,
    cutoff2: f32,
    out: &mut [f32],
    out_label: &mut [u32],
    hull: &mut Hull,
) {
    let n = f.len();
    let Hull { v, z } = hull;
    v.clear();
    z.clear();
    for q in 0..n {
        if !f[q].is_finite() {
            continue;
        }
        let gq = (base + q) as f64;
        let fq = f[q] as f64 + gq * gq;
        loop {
            match v.last() {
                None => {
                    v.push(q);
                    z.push(f64::NEG_INFINITY);
                    break;
                }
                Some(&p) => {
                    let gp = (base + p) as f64;
                    let fp = f[p] as f64 + gp * gp;
                    let s = (fq - fp) / (2.0 * (gq - gp));
                    if s <= *z.last().unwrap() {
                        v.pop();
                        z.pop();
                        continue;
                    }
                    v.push(q);
                    z.push(s);
                    break;
                }
            }
        }
    }
    if v.is_empty() {
        out.fill(f32::INFINITY);
        out_label.fill(NO_TRIANGLE);
        return;
    }
    let mut k = 0;
    for q in 0..n {
        while k + 1 < v.len() && z[k + 1] < (base + q) as f64 {
            k += 1;
        }
        let p = v[k];
        let dq = q as f64 - p as f64;
        let value = (dq * dq + f[p] as f64) as f32;
        if value <= cutoff2 {
            out[q] = value;
            out_label[q] = label[p];
        } else {
            out[q] = f32::INFINITY;
            out_label[q] = NO_TRIANGLE;
        }
    }
}

/// The lower envelope under construction: the parabolas kept (`v`) and where each starts
/// to be the lowest (`z`). Reused from line to line.
#[derive(Default)]
struct Hull {
    v: Vec<usize>,
    z: Vec<f64>,
}

/// Inclusive index range, or None when empty.
type Span = Option<(usize, usize)>;

fn union(a: Span, b: Span) -> Span {
    match (a, b) {
        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1))),
        (x, None) | (None, x) => x,
    }
}

/// `span` widened by `reach` on both sides, within 0..r.
fn widen(span: Span, reach: usize, r: usize) -> Span {
    span.map(|(a, b)| (a.saturating_sub(reach), (b + reach).min(r - 1)))
}

/// Runs the 1D envelope along x, then y, then z, each pass cut at `cutoff2` (voxel units²).
/// Every pass adds a non-negative square, so a voxel whose final distance is within the cutoff
/// saw every partial sum within it too: cutting the passes changes no value the Gaussian keeps
/// (it keeps nothing beyond the cutoff), and lets the y and z passes visit only the box that
/// the previous pass left finite instead of the whole grid (the bunny's 256³ field: 0.33 s ->
/// see the commit). Lines are gathered in blocks of 16 so each strided read pulls a whole cache
/// line.
fn distance_transform_3d(r: usize, dist2: &mut [f32], tri: &mut [u32], cutoff2: f32) {
    // A finite value spreads at most `reach` voxels along a pass before the cut.
    let reach = (cutoff2.max(0.0).sqrt() as usize + 1).min(r);
    // Along x: contiguous lines; each line reports where it is finite.
    let line_spans: Vec<Span> = dist2
        .par_chunks_mut(r)
        .zip(tri.par_chunks_mut(r))
        .map_init(
            || (vec![0f32; r], vec![0u32; r], Hull::default()),
            |(f, l, hull), (d, t)| {
                f.copy_from_slice(d);
                l.copy_from_slice(t);
                envelope_1d(f, l, 0, cutoff2, d, t, hull);
                let first = d.iter().position(|x| x.is_finite())?;
                let last = d.iter().rposition(|x| x.is_finite())?;
                Some((first, last))
            },
        )
        .collect();
    // Along y: within each z slice, stride r, over the x columns and the y window that can
    // hold a finite value. Each slice reports its finite box (x span, y span).
    let slice_boxes: Vec<(Span, Span)> = dist2
        .par_chunks_mut(r * r)
        .zip(tri.par_chunks_mut(r * r))
        .enumerate()
        .map_init(
            || Scratch::new(r),
            |s, (zi, (d, t))| {
                let lines = &line_spans[zi * r..(zi + 1) * r];
                let xs = lines.iter().fold(None, |acc, &l| union(acc, l));
                let ys = widen(
                    lines
                        .iter()
                        .position(|l| l.is_some())
                        .zip(lines.iter().rposition(|l| l.is_some())),
                    reach,
                    r,
                );
                let (Some((x_lo, x_hi)), Some((y_lo, y_hi))) = (xs, ys) else {
                    return (None, None);
                };
                for x0 in (x_lo..=x_hi).step_by(BLOCK) {
                    let w = BLOCK.min(x_hi + 1 - x0);
                    s.run_block(
                        w,
                        y_lo..y_hi + 1,
                        |line, pos| pos * r + x0 + line,
                        d,
                        t,
                        cutoff2,
                    );
                }
                (xs, ys)
            },
        )
        .collect();
    // Along z: stride r², split the work by y rows, which touch disjoint voxels.
    let d_ptr = SharedMut(dist2.as_mut_ptr());
    let t_ptr = SharedMut(tri.as_mut_ptr());
    let len = dist2.len();
    (0..r).into_par_iter().for_each_init(
        || Scratch::new(r),
        |s, y| {
            let mut xs: Span = None;
            let mut zs: Span = None;
            for (zi, &(sx, sy)) in slice_boxes.iter().enumerate() {
                if sy.is_some_and(|(a, b)| (a..=b).contains(&y)) {
                    xs = union(xs, sx);
                    zs = union(zs, Some((zi, zi)));
                }
            }
            let (Some((x_lo, x_hi)), Some((z_lo, z_hi))) = (xs, widen(zs, reach, r)) else {
                return;
            };
            // SAFETY: task y reads and writes only voxels (z, y, x) for its own y, so no two
            // tasks touch the same element, and both buffers outlive the parallel loop.
            let d = unsafe { std::slice::from_raw_parts_mut(d_ptr.get(), len) };
            let t = unsafe { std::slice::from_raw_parts_mut(t_ptr.get(), len) };
            for x0 in (x_lo..=x_hi).step_by(BLOCK_Z) {
                let w = BLOCK_Z.min(x_hi + 1 - x0);
                s.run_block(
                    w,
                    z_lo..z_hi + 1,
                    |line, pos| (pos * r + y) * r + x0 + line,
                    d,
                    t,
                    cutoff2,
                );
            }
        },
    );
}

const BLOCK: usize = 32;
/// The z pass strides r² floats (a page or more) from one position to the next, so it takes
/// wider blocks: each page it visits then yields four cache lines instead of one.
const BLOCK_Z: usize = 128;

#[derive(Clone, Copy)]
struct SharedMut<T>(*mut T);
// SAFETY: used only where tasks write disjoint elements (see distance_transform_3d).
unsafe impl<T> Send for SharedMut<T> {}
unsafe impl<T> Sync for SharedMut<T> {}
impl<T> SharedMut<T> {
    fn get(&self) -> *mut T {
        self.0
    }
}

struct Scratch {
    f: Vec<f32>,
    l: Vec<u32>,
    out: Vec<f32>,
    out_l: Vec<u32>,
    hull: Hull,
}

impl Scratch {
    fn new(r: usize) -> Scratch {
        Scratch {
            f: vec![0.0; r * BLOCK.max(BLOCK_Z)],
            l: vec![0; r * BLOCK.max(BLOCK_Z)],
            out: vec![0.0; r],
            out_l: vec![0; r],
            hull: Hull {
                v: Vec::with_capacity(r),
                z: Vec::with_capacity(r),
            },
        }
    }

    /// Gathers `w` lines over the grid positions `window` (index(line, pos) gives the
    /// element), runs the envelope on each and scatters the results back.
    fn run_block(
        &mut self,
        w: usize,
        window: std::ops::Range<usize>,
        index: impl Fn(usize, usize) -> usize,
        d: &mut [f32],
        t: &mut [u32],
        cutoff2: f32,
    ) {
        let n = window.len();
        let base = window.start;
        for (k, pos) in window.clone().enumerate() {
            for line in 0..w {
                let i = index(line, pos);
                self.f[line * n + k] = d[i];
                self.l[line * n + k] = t[i];
            }
        }
        for line in 0..w {
            let (f, l) = (
                &self.f[line * n..(line + 1) * n],
                &self.l[line * n..(line + 1) * n],
            );
            envelope_1d(
                f,
                l,
                base,
                cutoff2,
                &mut self.out[..n],
                &mut self.out_l[..n],
                &mut self.hull,
            );
            self.f[line * n..(line + 1) * n].copy_from_slice(&self.out[..n]);
            self.l[line * n..(line + 1) * n].copy_from_slice(&self.out_l[..n]);
        }
        for (k, pos) in window.enumerate() {
            for line in 0..w {
                let i = index(line, pos);
                d[i] = self.f[line * n + k];
                t[i] = self.l[line * n + k];
            }
        }
    }
}

/// Squared distance (voxel units²) beyond which the field is stored as 0: 6 Gaussian widths
/// plus 2 voxels of slack between the transform's voxel-to-seed distance and the exact one.
fn gaussian_cutoff2(sigma: f64, h: f64) -> f32 {
    let cutoff_vox = 6.0 * sigma / h + 2.0;
    (cutoff_vox * cutoff_vox) as f32
}

/// Gaussian of the exact distance from each voxel centre to the triangle the transform chose.
/// Beyond 6 Gaussian widths the value (< 1.6e-8) is stored as 0.
fn gaussian_of_exact_distance(
    mesh: &Mesh,
    (origin, h, r): (DVec3, f64, usize),
    sigma: f64,
    cutoff2: f32,
    dist2: &[f32],
    tri: &[u32],
) -> Vec<f32> {
    let inv_two_sigma2 = 1.0 / (2.0 * sigma * sigma);
    let mut values = vec![0f32; dist2.len()];
    values
        .par_chunks_mut(r)
        .enumerate()
        .for_each(|(line, out)| {
            let (y, z) = (line % r, line / r);
            for (x, o) in out.iter_mut().enumerate() {
                let i = line * r + x;
                if tri[i] == NO_TRIANGLE || dist2[i] > cutoff2 {
                    continue;
                }
                let p = origin + DVec3::new(x as f64 + 0.5, y as f64 + 0.5, z as f64 + 0.5) * h;
                let [a, b, c] = mesh.triangle(tri[i] as usize);
                let d2 = (p - closest_point_on_triangle(p, a, b, c)).length_squared();
                *o = (-d2 * inv_two_sigma2).exp() as f32;
            }
        });
    values
}

/// The field computed exactly at every query (nearest triangle by brute force). Far too slow
/// for production; it is the reference that validates the grid and the descriptor's rotation
/// invariance without grid error.
pub struct ExactField<'a> {
    /// The mesh, normalized.
    pub mesh: &'a Mesh,
    /// The Gaussian width, normalized units.
    pub sigma: f64,
}

impl GaussianField for ExactField<'_> {
    fn value(&self, p: DVec3) -> f32 {
        let mut best = f64::INFINITY;
        for t in 0..self.mesh.triangles.len() {
            let [a, b, c] = self.mesh.triangle(t);
            best = best.min((p - closest_point_on_triangle(p, a, b, c)).length_squared());
        }
        (-best / (2.0 * self.sigma * self.sigma)).exp() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn envelope_matches_brute_force() {
        let f = [
            f32::INFINITY,
            2.0,
            f32::INFINITY,
            f32::INFINITY,
            0.5,
            f32::INFINITY,
            9.0,
            f32::INFINITY,
        ];
        let labels: Vec<u32> = (0..8).collect();
        let mut out = vec![0.0; 8];
        let mut out_l = vec![0; 8];
        envelope_1d(
            &f,
            &labels,
            0,
            f32::INFINITY,
            &mut out,
            &mut out_l,
            &mut Hull::default(),
        );
        for q in 0..8 {
            let (best, arg) = (0..8)
                .filter(|&p| f[p].is_finite())
                .map(|p| (((q as f32 - p as f32).powi(2) + f[p]), p))
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .unwrap();
            assert!((out[q] - best).abs() < 1e-6, "q={q}");
            assert_eq!(
                out[q],
                (q as f32 - out_l[q] as f32).powi(2) + f[out_l[q] as usize]
            );
            let _ = arg;
        }
    }

    /// A unit-ish tetrahedron, small enough for the exact field.
    fn tetrahedron() -> Mesh {
        Mesh {
            positions: vec![
                DVec3::new(0.5, 0.1, -0.3),
                DVec3::new(-0.4, 0.3, -0.2),
                DVec3::new(0.0, -0.5, 0.1),
                DVec3::new(0.05, 0.05, 0.6),
            ],
            triangles: vec![[0, 1, 2], [0, 3, 1], [1, 3, 2], [2, 3, 0]],
        }
    }

    #[test]
    fn simd_sphere_reads_match_the_scalar_path_to_the_bit() {
        let mesh = tetrahedron();
        let grid = GridField::build(&mesh, 0.1, GridParams::default()).unwrap();
        let directions: Vec<glam::Vec3> = (0..203)
            .map(|i| {
                let t = i as f32;
                glam::Vec3::new((t * 0.37).sin(), (t * 1.1).cos(), (t * 0.23).sin()).normalize()
            })
            .collect();
        let mut fast = vec![0f32; directions.len()];
        let (mut nonzero, mut zero) = (0, 0);
        // Centres inside, near the edge and outside the grid; radii that leave it.
        for (center, radius) in [
            (DVec3::new(0.1, 0.0, 0.05), 0.05),
            (DVec3::new(0.5, 0.1, -0.3), 0.03),
            (DVec3::new(0.05, 0.05, 0.6), 0.05),
            (DVec3::new(0.3, -0.2, 0.1), 0.4),
            (DVec3::new(2.0, 0.0, 0.0), 1.3),
            (DVec3::new(-0.6, 0.6, -0.6), 0.3),
        ] {
            grid.values_on_sphere(center, radius, &directions, &mut fast);
            let c = ((center - grid.origin) / grid.h - DVec3::splat(0.5)).as_vec3();
            let s = (radius / grid.h) as f32;
            for (k, d) in directions.iter().enumerate() {
                let scalar = grid.trilinear(c + *d * s);
                assert_eq!(fast[k].to_bits(), scalar.to_bits(), "direction {k}");
            }
            nonzero += fast.iter().filter(|&&v| v > 0.0).count();
            zero += fast.iter().filter(|&&v| v == 0.0).count();
        }
        // Both kinds of lanes were exercised: reads of the field and reads outside the grid.
        assert!(
            nonzero > 200 && zero > 100,
            "{nonzero} non-zero, {zero} zero"
        );
    }

    #[test]
    fn grid_field_agrees_with_exact_field() {
        // Compare the grid to the exact field at random points.
        let mesh = tetrahedron();
        let grid = GridField::build(
            &mesh,
            0.1,
            GridParams {
                resolution: 128,
                sigma_voxels: 8f64.sqrt(),
            },
        )
        .unwrap();
        let exact = ExactField {
            mesh: &mesh,
            sigma: grid.sigma,
        };
        let mut worst: f32 = 0.0;
        for i in 0..2000 {
            let t = i as f64;
            let p = DVec3::new(
                (t * 0.731).sin() * 0.7,
                (t * 1.37).cos() * 0.7,
                (t * 0.193).sin() * 0.7,
            );
            worst = worst.max((grid.value(p) - exact.value(p)).abs());
        }
        // Trilinear interpolation of a Gaussian of width 2.8 voxels: a few percent at most.
        assert!(worst < 0.03, "worst absolute difference {worst}");
    }
}

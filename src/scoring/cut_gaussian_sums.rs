//! The scoring blur's sums, exactly, for many maps at once:
//!
//! den(v) = Σ_{u: ‖u−v‖ ≤ R} a_u e^{−‖u−v‖²/2σ²},  num_c(v) = Σ_{u: ‖u−v‖ ≤ R} a_u e^{−‖u−v‖²/2σ²} x_c(u)
//!
//! over every source u (a vertex with area) within the cutoff R, with no approximation of
//! the kernel: the cutoff is what scores have always used (3σ), and a fast transform cannot
//! reproduce its edge (a Gaussian cut at 3σ drops from 1.1% of its peak to zero there).
//!
//! Why it is fast: the work is a product of two small matrices per pair of (block of 16
//! nearby targets, chunk of sources in one grid cell), K (16 × m, one exp per pair) times X
//! (m × channels), so each exp serves every map and each source's row is read once per
//! block rather than once per target. Targets go in Morton order of their cells, so a
//! block is compact and the cells it must visit (those whose box comes within R of the
//! block's box) are few. The pair arithmetic runs in f32, 16 lanes, with an exp made of
//! adds and multiplies (`exp_nonpositive`, relative error under 2·10⁻⁷), and every chunk of
//! at most 64 sources is added into f64 totals, so rounding stays near 10⁻⁶ of a sum however
//! many sources it has (tests check 10⁻⁵ against the f64 definition).
//!
//! Deterministic: each target's sum runs over the cells and sources in a fixed order, and
//! no step is fused or reordered, so AVX-512, AVX2 and plain SSE2 give the same bytes on any
//! number of threads.
use glam::DVec3;
use rayon::prelude::*;

/// Targets per block: one AVX-512 register of f32.
const BLOCK: usize = 16;
/// Channels per pass over a chunk: their accumulators stay in registers.
const GROUP: usize = 8;
/// Sources summed in f32 before the f64 totals take them.
const CHUNK: usize = 128;
/// Cells per cutoff radius: small cells let a block skip most of what lies beyond its reach.
const CELLS_PER_RADIUS: f64 = 6.0;
/// The grid never has more cells than this per axis (a cell is at least the longest
/// extent / this), so its index stays small at tiny σ.
const MAX_CELLS_PER_AXIS: f64 = 128.0;

/// Sources bucketed into cubes, as f32 coordinates relative to the grid's origin.
struct SourceCells {
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    /// `starts[c]..starts[c + 1]` are cell c's sources (linear index x + nx (y + ny z)).
    starts: Vec<u32>,
    xs: Vec<f32>,
    ys: Vec<f32>,
    zs: Vec<f32>,
    areas: Vec<f32>,
    /// `padded` values per source: 1 (the denominator), the k channels, zeros up to the
    /// kernel's row width ([`row_width`]).
    values: Vec<f32>,
    padded: usize,
    /// Each cell's sources' bounding box (lo, hi), tighter than the cell where the surface
    /// crosses it as a sheet.
    bounds: Vec<(DVec3, DVec3)>,
}

impl SourceCells {
    fn coords(&self, p: DVec3) -> [usize; 3] {
        let c = ((p - self.origin) / self.cell).floor();
        [
            (c.x.max(0.0) as usize).min(self.dims[0] - 1),
            (c.y.max(0.0) as usize).min(self.dims[1] - 1),
            (c.z.max(0.0) as usize).min(self.dims[2] - 1),
        ]
    }

    fn linear(&self, [x, y, z]: [usize; 3]) -> usize {
        x + self.dims[0] * (y + self.dims[1] * z)
    }
}

/// For every vertex v: the denominator and the k channels' numerators (row-major), over the
/// sources (vertices with area > 0) within `radius`, with K = e^{−d²/2σ²}. `rows` holds k
/// values per vertex. Positions must be finite.
pub(crate) fn cut_gaussian_sums(
    positions: &[DVec3],
    areas: &[f64],
    rows: &[f64],
    k: usize,
    sigma: f64,
    radius: f64,
) -> (Vec<f64>, Vec<f64>) {
    let sums = cut_gaussian_sums_then(
        positions,
        areas,
        rows,
        k,
        positions,
        sigma,
        radius,
        k + 1,
        |_, totals, out| out.copy_from_slice(totals),
    );
    split_denominator(&sums, k)
}

/// Rows of (den, k numerators) split into the denominators and the numerators' rows.
pub(crate) fn split_denominator(sums: &[f64], k: usize) -> (Vec<f64>, Vec<f64>) {
    let den = sums.iter().step_by(k + 1).copied().collect();
    let mut num = vec![0.0; sums.len() / (k + 1) * k];
    for (row, totals) in num.chunks_exact_mut(k.max(1)).zip(sums.chunks_exact(k + 1)) {
        row[..k].copy_from_slice(&totals[1..]);
    }
    (den, num)
}

/// The sums of [`cut_gaussian_sums`] from one point set (`sources`, with `areas` and k values
/// per point in `rows`) to another (`positions`, the targets), each target's sums (den, then
/// the k numerators) turned at once into `out_width` values by `finish(target, sums, out)`: `out_width` values per target,
/// without holding every target's k + 1 sums (a merged blur's 160 channels per vertex would
/// be 64 MB for a 50k mesh).
#[allow(clippy::too_many_arguments)]
pub(crate) fn cut_gaussian_sums_then<F>(
    sources: &[DVec3],
    areas: &[f64],
    rows: &[f64],
    k: usize,
    positions: &[DVec3],
    sigma: f64,
    radius: f64,
    out_width: usize,
    finish: F,
) -> Vec<f64>
where
    F: Fn(usize, &[f64], &mut [f64]) + Sync,
{
    let n = positions.len();
    let mut out = vec![0.0; n * out_width];
    if n == 0 {
        return out;
    }
    if sources.is_empty() {
        let zeros = vec![0.0; k + 1];
        for (v, row) in out.chunks_exact_mut(out_width.max(1)).enumerate().take(n) {
            finish(v, &zeros, &mut row[..out_width]);
        }
        return out;
    }
    let grid = source_cells(sources, areas, rows, k, radius, row_width(k));
    let targets = morton_order(positions, &grid);
    let inv = (1.0 / (2.0 * sigma * sigma)) as f32;
    let r2 = (radius * radius) as f32;
    let p = grid.padded;
    let blocks: Vec<Vec<f64>> = targets
        .par_chunks(BLOCK)
        .map(|block| {
            let totals = block_sums_dispatch(&grid, positions, block, inv, radius, r2);
            let mut done = vec![0.0; block.len() * out_width];
            for (t, &v) in block.iter().enumerate() {
                finish(
                    v,
                    &totals[t * p..t * p + 1 + k],
                    &mut done[t * out_width..(t + 1) * out_width],
                );
            }
            done
        })
        .collect();
    for (block, done) in targets.chunks(BLOCK).zip(&blocks) {
        for (t, &v) in block.iter().enumerate() {
            out[v * out_width..(v + 1) * out_width]
                .copy_from_slice(&done[t * out_width..(t + 1) * out_width]);
        }
    }
    out
}

/// Values per source row for k channels and the denominator: what the kernel that
/// [`block_sums_dispatch`] picks on this CPU reads. The AVX-512 and portable kernels take
/// whole groups of [`GROUP`]; the AVX2 one any width, so its rows carry no padding (28
/// channels rather than 32 for the seven maps and 20 chance maps of a score).
fn row_width(k: usize) -> usize {
    #[cfg(target_arch = "x86_64")]
    if uses_avx2_kernel() {
        return k + 1;
    }
    (k + 1).div_ceil(GROUP) * GROUP
}

/// Whether [`block_sums_dispatch`] runs the AVX2 kernel here.
#[cfg(target_arch = "x86_64")]
fn uses_avx2_kernel() -> bool {
    !std::arch::is_x86_feature_detected!("avx512f")
        && std::arch::is_x86_feature_detected!("avx2")
        && std::arch::is_x86_feature_detected!("fma")
}

fn source_cells(
    positions: &[DVec3],
    areas: &[f64],
    rows: &[f64],
    k: usize,
    radius: f64,
    padded: usize,
) -> SourceCells {
    let (lo, hi) = positions
        .iter()
        .fold((positions[0], positions[0]), |(lo, hi), p| {
            (lo.min(*p), hi.max(*p))
        });
    let extent = (hi - lo).max_element();
    let cell = (radius / CELLS_PER_RADIUS)
        .max(extent / MAX_CELLS_PER_AXIS)
        .max(f64::MIN_POSITIVE);
    let dims = [0, 1, 2].map(|a| ((hi[a] - lo[a]) / cell).floor() as usize + 1);
    debug_assert!(padded > k);
    let mut grid = SourceCells {
        origin: lo,
        cell,
        dims,
        starts: Vec::new(),
        xs: Vec::new(),
        ys: Vec::new(),
        zs: Vec::new(),
        areas: Vec::new(),
        values: Vec::new(),
        padded,
        bounds: Vec::new(),
    };
    let mut keyed: Vec<(usize, usize)> = (0..positions.len())
        .filter(|&u| areas[u] > 0.0)
        .map(|u| (grid.linear(grid.coords(positions[u])), u))
        .collect();
    keyed.sort_unstable();
    let cells = dims[0] * dims[1] * dims[2];
    let mut starts = vec![0u32; cells + 1];
    for &(c, _) in &keyed {
        starts[c + 1] += 1;
    }
    for c in 0..cells {
        starts[c + 1] += starts[c];
    }
    grid.starts = starts;
    let empty = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    grid.bounds = vec![empty; cells];
    for &(c, u) in &keyed {
        let q = positions[u] - lo;
        grid.bounds[c] = (grid.bounds[c].0.min(q), grid.bounds[c].1.max(q));
    }
    grid.values = vec![0.0; keyed.len() * padded];
    for (i, &(_, u)) in keyed.iter().enumerate() {
        let q = positions[u] - lo;
        grid.xs.push(q.x as f32);
        grid.ys.push(q.y as f32);
        grid.zs.push(q.z as f32);
        grid.areas.push(areas[u] as f32);
        let row = &mut grid.values[i * padded..(i + 1) * padded];
        row[0] = 1.0;
        for c in 0..k {
            row[1 + c] = rows[u * k + c] as f32;
        }
    }
    grid
}

/// Every vertex, ordered by the Morton code of its cell (then by index), so 16 consecutive
/// vertices lie close together.
fn morton_order(positions: &[DVec3], grid: &SourceCells) -> Vec<usize> {
    let spread = |mut x: u64| {
        // Bits of x (up to 21) moved to every third position.
        x &= 0x1f_ffff;
        x = (x | x << 32) & 0x1f_0000_0000_ffff;
        x = (x | x << 16) & 0x1f_0000_ff00_00ff;
        x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
        x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
        x = (x | x << 2) & 0x1249_2492_4924_9249;
        x
    };
    let mut keyed: Vec<(u64, usize)> = positions
        .iter()
        .enumerate()
        .map(|(v, p)| {
            let [x, y, z] = grid.coords(*p);
            let code = spread(x as u64) | spread(y as u64) << 1 | spread(z as u64) << 2;
            (code, v)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, v)| v).collect()
}

fn block_sums_dispatch(
    grid: &SourceCells,
    positions: &[DVec3],
    block: &[usize],
    inv: f32,
    radius: f64,
    r2: f32,
) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU has AVX-512F, checked just above.
            return unsafe { block_sums_avx512(grid, positions, block, inv, radius, r2) };
        }
        if uses_avx2_kernel() {
            // SAFETY: the CPU has AVX2 and FMA, checked by uses_avx2_kernel.
            return unsafe { block_sums_avx2(grid, positions, block, inv, radius, r2) };
        }
    }
    block_sums(
        grid,
        positions,
        block,
        inv,
        radius,
        r2,
        GroupKernel::Portable,
    )
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn block_sums_avx512(
    grid: &SourceCells,
    positions: &[DVec3],
    block: &[usize],
    inv: f32,
    radius: f64,
    r2: f32,
) -> Vec<f64> {
    block_sums(grid, positions, block, inv, radius, r2, GroupKernel::Avx512)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn block_sums_avx2(
    grid: &SourceCells,
    positions: &[DVec3],
    block: &[usize],
    inv: f32,
    radius: f64,
    r2: f32,
) -> Vec<f64> {
    block_sums(grid, positions, block, inv, radius, r2, GroupKernel::Avx2)
}

/// Which code multiplies the weights by the maps: chosen once per block by the caller that
/// knows the instruction set, not asked again in the inner loop.
#[derive(Clone, Copy)]
enum GroupKernel {
    /// Portable code (`mul_add`).
    Portable,
    /// AVX-512 registers; only `block_sums_avx512` passes it.
    #[cfg(target_arch = "x86_64")]
    Avx512,
    /// AVX2 registers, whole unpadded rows six channels a pass (`add_chunk_sums_avx2`);
    /// only `block_sums_avx2` passes it.
    #[cfg(target_arch = "x86_64")]
    Avx2,
}

/// One block's totals: `padded` values per target (denominator first), over every cell
/// whose box comes within `radius` of the block's box.
#[inline(always)]
fn block_sums(
    grid: &SourceCells,
    positions: &[DVec3],
    block: &[usize],
    inv: f32,
    radius: f64,
    r2: f32,
    kernel: GroupKernel,
) -> Vec<f64> {
    let p = grid.padded;
    let mut totals = vec![0.0f64; BLOCK * p];
    // Lanes past the block's end repeat its last target; their totals are never read.
    let at = |t: usize| positions[block[t.min(block.len() - 1)]] - grid.origin;
    let mut tx = [0.0f32; BLOCK];
    let mut ty = [0.0f32; BLOCK];
    let mut tz = [0.0f32; BLOCK];
    let (mut lo, mut hi) = (at(0), at(0));
    for t in 0..BLOCK {
        let q = at(t);
        (tx[t], ty[t], tz[t]) = (q.x as f32, q.y as f32, q.z as f32);
        (lo, hi) = (lo.min(q), hi.max(q));
    }
    // The block's box as the f32 lanes hold it: a source farther than the cutoff from this
    // box (with a margin far above f32's rounding of d²) has a zero weight in every lane, so
    // it is left out rather than multiplied by every map. A cell within reach of the box
    // reaches a cell size beyond the cutoff, so about a quarter of its sources are such.
    let lane = |t: usize| DVec3::new(tx[t] as f64, ty[t] as f64, tz[t] as f64);
    let (lane_lo, lane_hi) = (1..BLOCK).fold((lane(0), lane(0)), |(l, h), t| {
        (l.min(lane(t)), h.max(lane(t)))
    });
    let cull2 = r2 as f64 * (1.0 + 1e-4);
    let first = grid.coords(grid.origin + lo - DVec3::splat(radius));
    let last = grid.coords(grid.origin + hi + DVec3::splat(radius));
    let mut pending = Pending {
        weights: [[0.0; BLOCK]; CHUNK],
        sources: [0; CHUNK],
        len: 0,
    };
    for z in first[2]..=last[2] {
        for y in first[1]..=last[1] {
            for x in first[0]..=last[0] {
                let c = grid.linear([x, y, z]);
                let (s, e) = (grid.starts[c] as usize, grid.starts[c + 1] as usize);
                if s == e || box_gap2(grid.bounds[c], lo, hi) > radius * radius {
                    continue;
                }
                for v in s..e {
                    let (sx, sy, sz, a) = (grid.xs[v], grid.ys[v], grid.zs[v], grid.areas[v]);
                    let source = DVec3::new(sx as f64, sy as f64, sz as f64);
                    if box_gap2((source, source), lane_lo, lane_hi) > cull2 {
                        continue;
                    }
                    let w = &mut pending.weights[pending.len];
                    for t in 0..BLOCK {
                        let (dx, dy, dz) = (tx[t] - sx, ty[t] - sy, tz[t] - sz);
                        let d2 = dx.mul_add(dx, dy.mul_add(dy, dz * dz));
                        let kernel = a * exp_of_nonpositive(-d2 * inv);
                        w[t] = if d2 <= r2 { kernel } else { 0.0 };
                    }
                    pending.sources[pending.len] = v as u32;
                    pending.len += 1;
                    if pending.len == CHUNK {
                        pending.flush(grid, &mut totals, kernel);
                    }
                }
            }
        }
    }
    pending.flush(grid, &mut totals, kernel);
    totals
}

/// e^x for x ≤ 0 (x ≥ −87 is kept exact to 2·10⁻⁷; below, e^−87): 2^n · e^r with
/// |r| ≤ ln2/2 and a degree-6 polynomial, in fused multiply-adds (exactly rounded wherever
/// they run, so every instruction set gives the same bits).
#[inline(always)]
fn exp_of_nonpositive(x: f32) -> f32 {
    const MAGIC: f32 = 12_582_912.0; // 1.5 · 2^23: adding it rounds to an integer
    let x = x.max(-87.0);
    let t = x.mul_add(std::f32::consts::LOG2_E, MAGIC);
    let n_bits = t.to_bits() as i32 - MAGIC.to_bits() as i32;
    let n = t - MAGIC;
    let r = (-n).mul_add(1.428_606_8e-6, (-n).mul_add(0.693_145_75, x));
    let mut p: f32 = 1.0 / 720.0;
    for c in [1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = p.mul_add(r, c);
    }
    f32::from_bits(((n_bits + 127) << 23) as u32) * p
}

/// Sources with their 16 kernel weights, waiting to be multiplied by their values.
struct Pending {
    weights: [[f32; BLOCK]; CHUNK],
    sources: [u32; CHUNK],
    len: usize,
}

impl Pending {
    /// Adds the pending sources' weighted values to the f64 totals and empties the buffer.
    #[inline(always)]
    fn flush(&mut self, grid: &SourceCells, totals: &mut [f64], kernel: GroupKernel) {
        let p = grid.padded;
        let (weights, sources) = (&self.weights[..self.len], &self.sources[..self.len]);
        #[cfg(target_arch = "x86_64")]
        if let GroupKernel::Avx2 = kernel {
            // SAFETY: only block_sums_avx2 passes Avx2, and it is called only where the CPU
            // has AVX2 and FMA (block_sums_dispatch checks).
            unsafe { add_chunk_sums_avx2(weights, sources, &grid.values, p, totals) };
            self.len = 0;
            return;
        }
        for g in (0..p).step_by(GROUP) {
            let acc = group_sums(weights, sources, &grid.values, p, g, kernel);
            for c in 0..GROUP {
                for t in 0..BLOCK {
                    totals[t * p + g + c] += acc[c][t] as f64;
                }
            }
        }
        self.len = 0;
    }
}

/// Σ_j w_j · x_j[g + c] for the group's channels c, lane by lane: each term one fused
/// multiply-add (exactly rounded on every instruction set), in source order.
#[inline(always)]
fn group_sums(
    weights: &[[f32; BLOCK]],
    sources: &[u32],
    values: &[f32],
    p: usize,
    g: usize,
    kernel: GroupKernel,
) -> [[f32; BLOCK]; GROUP] {
    match kernel {
        GroupKernel::Portable => group_sums_plain(weights, sources, values, p, g),
        // SAFETY: only block_sums_avx512 passes Avx512, and it is called only where the CPU
        // has AVX-512F (block_sums_dispatch checks).
        #[cfg(target_arch = "x86_64")]
        GroupKernel::Avx512 => unsafe { group_sums_avx512(weights, sources, values, p, g) },
        // `Pending::flush` sums AVX2 rows whole and never asks for one group of them (their
        // rows are not padded to whole groups).
        #[cfg(target_arch = "x86_64")]
        GroupKernel::Avx2 => unreachable!("AVX2 rows are summed whole by add_chunk_sums_avx2"),
    }
}

/// [`group_sums`] in portable code (`mul_add` is exactly rounded everywhere).
#[inline(always)]
fn group_sums_plain(
    weights: &[[f32; BLOCK]],
    sources: &[u32],
    values: &[f32],
    p: usize,
    g: usize,
) -> [[f32; BLOCK]; GROUP] {
    let mut acc = [[0.0f32; BLOCK]; GROUP];
    for (w, &u) in weights.iter().zip(sources) {
        let row = &values[u as usize * p..];
        for (lanes, &x) in acc.iter_mut().zip(&row[g..g + GROUP]) {
            for t in 0..BLOCK {
                lanes[t] = w[t].mul_add(x, lanes[t]);
            }
        }
    }
    acc
}

/// [`group_sums`] with the eight accumulators held in AVX-512 registers.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
fn group_sums_avx512(
    weights: &[[f32; BLOCK]],
    sources: &[u32],
    values: &[f32],
    p: usize,
    g: usize,
) -> [[f32; BLOCK]; GROUP] {
    use std::arch::x86_64::*;
    let mut acc = [_mm512_setzero_ps(); GROUP];
    for (w, &u) in weights.iter().zip(sources) {
        let row = &values[u as usize * p..];
        // SAFETY: `w` holds exactly 16 f32, what one unaligned 512-bit load reads.
        let lanes = unsafe { _mm512_loadu_ps(w.as_ptr()) };
        let x = &row[g..g + GROUP];
        for c in 0..GROUP {
            acc[c] = _mm512_fmadd_ps(lanes, _mm512_set1_ps(x[c]), acc[c]);
        }
    }
    let mut out = [[0.0f32; BLOCK]; GROUP];
    for c in 0..GROUP {
        // SAFETY: out[c] holds exactly 16 f32, what one unaligned 512-bit store writes.
        unsafe { _mm512_storeu_ps(out[c].as_mut_ptr(), acc[c]) };
    }
    out
}

/// Adds each of a chunk's `p` channel sums (Σ_j w_j · x_j[c], lane by lane, one fused
/// multiply-add per term in source order, as [`group_sums`]) to the f64 totals, in AVX2
/// registers. A group's eight channels x 16 lanes would need all sixteen ymm registers, and the
/// compiler kept half of them on the stack; passes of six channels (twelve accumulators, two
/// weight registers and a broadcast) stay in registers. Six measured 2-4% faster than four on
/// one clustered blur level. A row of p channels is passes of six and one of the rest, so rows
/// need no padding ([`row_width`]). Each accumulator sees the same operations in the same order
/// as the portable code, and each chunk's f32 sum is added to the totals once: the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn add_chunk_sums_avx2(
    weights: &[[f32; BLOCK]],
    sources: &[u32],
    values: &[f32],
    p: usize,
    totals: &mut [f64],
) {
    let mut first = 0;
    while first < p {
        match p - first {
            1 => channel_pass_avx2::<1>(weights, sources, values, p, first, totals),
            2 => channel_pass_avx2::<2>(weights, sources, values, p, first, totals),
            3 => channel_pass_avx2::<3>(weights, sources, values, p, first, totals),
            4 => channel_pass_avx2::<4>(weights, sources, values, p, first, totals),
            5 => channel_pass_avx2::<5>(weights, sources, values, p, first, totals),
            _ => channel_pass_avx2::<6>(weights, sources, values, p, first, totals),
        }
        first += (p - first).min(6);
    }
}

/// One pass of [`add_chunk_sums_avx2`]: channels `first..first + W`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn channel_pass_avx2<const W: usize>(
    weights: &[[f32; BLOCK]],
    sources: &[u32],
    values: &[f32],
    p: usize,
    first: usize,
    totals: &mut [f64],
) {
    use std::arch::x86_64::*;
    let mut low = [_mm256_setzero_ps(); W];
    let mut high = [_mm256_setzero_ps(); W];
    for (w, &u) in weights.iter().zip(sources) {
        let start = u as usize * p + first;
        let x: &[f32; W] = values[start..start + W]
            .try_into()
            .expect("a source's row holds p channels");
        // SAFETY: `w` holds exactly 16 f32: two unaligned 256-bit loads of 8.
        let (w_low, w_high) = unsafe {
            (
                _mm256_loadu_ps(w.as_ptr()),
                _mm256_loadu_ps(w.as_ptr().add(8)),
            )
        };
        for c in 0..W {
            let xc = _mm256_set1_ps(x[c]);
            low[c] = _mm256_fmadd_ps(w_low, xc, low[c]);
            high[c] = _mm256_fmadd_ps(w_high, xc, high[c]);
        }
    }
    for c in 0..W {
        let mut lanes = [0.0f32; BLOCK];
        // SAFETY: `lanes` holds 16 f32: two unaligned 256-bit stores of 8.
        unsafe {
            _mm256_storeu_ps(lanes.as_mut_ptr(), low[c]);
            _mm256_storeu_ps(lanes.as_mut_ptr().add(8), high[c]);
        }
        for (t, &sum) in lanes.iter().enumerate() {
            totals[t * p + first + c] += sum as f64;
        }
    }
}

/// Squared distance between two boxes (lo, hi).
fn box_gap2((a_lo, a_hi): (DVec3, DVec3), b_lo: DVec3, b_hi: DVec3) -> f64 {
    let gap = (a_lo - b_hi).max(b_lo - a_hi).max(DVec3::ZERO);
    gap.length_squared()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_meshes::icosphere;
    use crate::mesh::vertex_areas::vertex_areas;

    fn reference(
        positions: &[DVec3],
        areas: &[f64],
        rows: &[f64],
        k: usize,
        sigma: f64,
        radius: f64,
    ) -> (Vec<f64>, Vec<f64>) {
        let n = positions.len();
        let mut den = vec![0.0; n];
        let mut num = vec![0.0; n * k];
        for v in 0..n {
            for u in 0..n {
                let d2 = positions[u].distance_squared(positions[v]);
                if areas[u] <= 0.0 || d2 > radius * radius {
                    continue;
                }
                let w = areas[u] * (-d2 / (2.0 * sigma * sigma)).exp();
                den[v] += w;
                for c in 0..k {
                    num[v * k + c] += w * rows[u * k + c];
                }
            }
        }
        (den, num)
    }

    #[test]
    fn sums_match_the_f64_definition() {
        let mesh = icosphere(1.0, 3);
        let n = mesh.positions.len();
        let mut areas = vertex_areas(&mesh);
        areas[5] = 0.0; // a vertex without area is a target, never a source
        let k = 11; // two channel groups, the second partly padding
        let rows: Vec<f64> = (0..n * k)
            .map(|i| ((i * 7919) % 1000) as f64 / 1000.0 - 0.3)
            .collect();
        for sigma in [0.02, 0.1, 0.3, 1.0] {
            let radius = 3.0 * sigma;
            let (den, num) = cut_gaussian_sums(&mesh.positions, &areas, &rows, k, sigma, radius);
            let (want_den, want_num) = reference(&mesh.positions, &areas, &rows, k, sigma, radius);
            for v in 0..n {
                let scale = want_den[v].max(1e-300);
                assert!(
                    (den[v] - want_den[v]).abs() <= 1e-5 * scale,
                    "σ {sigma} vertex {v}: {} vs {}",
                    den[v],
                    want_den[v]
                );
                for c in 0..k {
                    let (got, want) = (num[v * k + c], want_num[v * k + c]);
                    assert!(
                        (got - want).abs() <= 1e-5 * scale,
                        "σ {sigma} vertex {v} channel {c}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// Each register kernel this CPU can run against the portable code, bit for bit. On a CPU
    /// with neither (not x86-64, or x86-64 without AVX2) it says so on stderr and compares
    /// nothing: those kernels are then never called either.
    #[test]
    fn the_register_kernels_give_the_portable_bytes() {
        let weights: Vec<[f32; BLOCK]> = (0..CHUNK)
            .map(|j| std::array::from_fn(|t| ((j * 31 + t * 7) % 101) as f32 / 37.0))
            .collect();
        let sources: Vec<u32> = (0..CHUNK as u32).map(|j| (j * 5) % 200).collect();
        let p = 2 * GROUP;
        let values: Vec<f32> = (0..200 * p)
            .map(|i| ((i * 7919) % 1000) as f32 / 300.0 - 1.0)
            .collect();
        let mut compared = Vec::new();
        for g in [0, GROUP] {
            let plain =
                group_sums_plain(&weights, &sources, &values, p, g).map(|a| a.map(f32::to_bits));
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the CPU has AVX-512F, checked just above.
                    let fast = unsafe { group_sums_avx512(&weights, &sources, &values, p, g) };
                    assert_eq!(
                        plain,
                        fast.map(|a| a.map(f32::to_bits)),
                        "AVX-512, group {g}"
                    );
                    compared.push("AVX-512");
                }
            }
        }
        // The AVX2 kernel sums whole rows into f64 totals, rows of any width (passes of 6 and
        // one of 1 to 5), into totals that already hold values, each channel as the portable
        // code sums it: one fused multiply-add per source, in order, from zero.
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            for p in [1, 5, 8, 16, 28, 109, 112] {
                let values: Vec<f32> = (0..200 * p)
                    .map(|i| ((i * 7919) % 1000) as f32 / 300.0 - 1.0)
                    .collect();
                let start: Vec<f64> = (0..BLOCK * p).map(|i| (i % 13) as f64 * 0.37).collect();
                let mut plain = start.clone();
                for c in 0..p {
                    for t in 0..BLOCK {
                        let sum = weights.iter().zip(&sources).fold(0.0f32, |acc, (w, &u)| {
                            w[t].mul_add(values[u as usize * p + c], acc)
                        });
                        plain[t * p + c] += sum as f64;
                    }
                }
                let mut fast = start.clone();
                // SAFETY: the CPU has AVX2 and FMA, checked just above.
                unsafe { add_chunk_sums_avx2(&weights, &sources, &values, p, &mut fast) };
                assert_eq!(
                    plain.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    fast.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    "AVX2, {p} channels"
                );
            }
            compared.push("AVX2");
        }
        if compared.is_empty() {
            eprintln!("this CPU runs no register kernel: only the portable code is used here");
        }
    }

    #[test]
    fn every_instruction_set_gives_the_same_bytes() {
        let mesh = icosphere(1.0, 2);
        let areas = vertex_areas(&mesh);
        // 3 channels fill half a group; 27 (a score's seven maps and twenty chance maps)
        // leave the AVX2 kernel's unpadded rows a last pass of four.
        for k in [3, 27] {
            let rows: Vec<f64> = (0..mesh.positions.len() * k)
                .map(|i| (i % 17) as f64)
                .collect();
            let padded = (k + 1).div_ceil(GROUP) * GROUP;
            let portable = source_cells(&mesh.positions, &areas, &rows, k, 0.6, padded);
            let here = source_cells(&mesh.positions, &areas, &rows, k, 0.6, row_width(k));
            let targets = morton_order(&mesh.positions, &portable);
            for block in targets.chunks(BLOCK) {
                let plain = block_sums(
                    &portable,
                    &mesh.positions,
                    block,
                    12.5,
                    0.6,
                    0.36,
                    GroupKernel::Portable,
                );
                let fast = block_sums_dispatch(&here, &mesh.positions, block, 12.5, 0.6, 0.36);
                for t in 0..BLOCK {
                    let want = &plain[t * padded..t * padded + k + 1];
                    let got = &fast[t * here.padded..t * here.padded + k + 1];
                    assert_eq!(
                        want.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        got.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                        "{k} channels, lane {t}"
                    );
                }
            }
        }
    }
}

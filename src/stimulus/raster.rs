//! A CPU triangle rasterizer for stimulus frames: z-buffered, two-sided Lambert + ambient
//! shading with a headlight, supersampled anti-aliasing, and a triangle-id buffer for the
//! projector self-check. Deterministic: the same mesh, camera and settings give the same bytes.
//!
//! Rasterization samples pixel centres with the top-left fill rule, so two triangles sharing
//! an edge never both cover (or both miss) a sample on it: the id buffer is watertight.
use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::camera::CameraState;
use crate::mesh::Mesh;
use crate::protocol::Rendering;
use std::marker::PhantomData;

/// The triangle id of a background pixel in an id image.
pub const BACKGROUND_ID: u32 = u32::MAX;

/// A mesh prepared for rendering: positions and area-weighted vertex normals, with its
/// triangles in Morton order of their centroids and its vertices in order of first use, so
/// the triangles a band of screen rows meets, and their corners, sit close in memory (in the
/// file's order, looking them up cost a cache miss per triangle). Triangle ids given out are
/// the mesh's own.
pub struct Rasterizer<'a> {
    mesh: PhantomData<&'a Mesh>,
    /// Reordered triangles, over reordered vertices.
    triangles: Vec<[u32; 3]>,
    /// The mesh's index of each reordered triangle and vertex.
    original_triangle: Vec<u32>,
    original_vertex: Vec<u32>,
    positions: Vec<DVec3>,
    normals: Vec<DVec3>,
    /// Per-vertex albedo (0–255) replacing the material colour, for rendering maps.
    colors: Option<Vec<[f64; 3]>>,
    /// For a closed, consistently wound mesh, the sign of the screen-space area of a
    /// triangle facing the eye: the others are hidden behind the front of the mesh when the
    /// eye is outside it (as the turntable keeps it), so they are not drawn. None: draw all.
    front_sign: Option<f64>,
}

/// The sign a front-facing triangle's screen-space area has (y down), if every edge of the
/// mesh joins exactly two triangles that run it in opposite directions and the mesh
/// encloses a volume; None otherwise (open scans, non-manifold or inconsistent winding).
fn closed_front_sign(mesh: &Mesh) -> Option<f64> {
    let mut directed: Vec<(u32, u32)> = Vec::with_capacity(mesh.triangles.len() * 3);
    for t in &mesh.triangles {
        if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] {
            return None;
        }
        directed.extend([(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]);
    }
    directed.par_sort_unstable();
    if directed.windows(2).any(|w| w[0] == w[1]) {
        return None; // an edge run twice the same way: inconsistent winding or non-manifold
    }
    if !directed
        .par_iter()
        .all(|&(a, b)| directed.binary_search(&(b, a)).is_ok())
    {
        return None; // a border edge
    }
    let volume: f64 = mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            a.dot(b.cross(c))
        })
        .sum();
    // Outward winding (positive volume) is counter-clockwise seen from outside, which is
    // clockwise, negative area, on a y-down screen.
    if volume.abs() > 0.0 && volume.is_finite() {
        Some(-volume.signum())
    } else {
        None
    }
}

#[derive(Clone, Copy)]
struct ScreenVertex {
    x: f64,
    y: f64,
    z: f64,
    inv_w: f64,
}

/// Pixel rows drawn by one task: its depth and triangle samples (at 2x supersampling, 16
/// rows of 3360 samples, 430 kB) stay in cache from clearing through shading, and no
/// full-frame sample buffer is ever written.
const BAND_PIXEL_ROWS: usize = 8;

/// The frame's corners on screen (sample units) and its triangles binned by the bands of
/// `band_rows` sample rows their bounding boxes touch.
struct Binned {
    /// Per band, the triangles its rows may cover: their index in the mesh and their
    /// corners, copied in so a band reads its triangles in one pass (looked up vertex by
    /// vertex, each triangle cost a cache miss: a fifth of the render time).
    bins: Vec<Vec<(u32, [ScreenVertex; 3])>>,
}

impl<'a> Rasterizer<'a> {
    /// A rasterizer of `mesh`.
    pub fn new(mesh: &'a Mesh) -> Rasterizer<'a> {
        let normals = mesh.vertex_normals();
        let (lo, hi) = mesh
            .referenced_bounds()
            .unwrap_or((DVec3::ZERO, DVec3::ONE));
        let extent = (hi - lo).max(DVec3::splat(1e-300));
        let mut keyed: Vec<(u32, u32)> = mesh
            .triangles
            .par_iter()
            .enumerate()
            .map(|(t, tri)| {
                let c = tri
                    .iter()
                    .map(|&i| mesh.positions[i as usize])
                    .sum::<DVec3>()
                    / 3.0;
                let cell = ((c - lo) / extent * 1023.0).clamp(DVec3::ZERO, DVec3::splat(1023.0));
                (
                    morton3(cell.x as u32, cell.y as u32, cell.z as u32),
                    t as u32,
                )
            })
            .collect();
        keyed.par_sort_unstable();
        let mut new_index = vec![u32::MAX; mesh.positions.len()];
        let mut original_vertex = Vec::new();
        let triangles: Vec<[u32; 3]> = keyed
            .iter()
            .map(|&(_, t)| {
                mesh.triangles[t as usize].map(|i| {
                    if new_index[i as usize] == u32::MAX {
                        new_index[i as usize] = original_vertex.len() as u32;
                        original_vertex.push(i);
                    }
                    new_index[i as usize]
                })
            })
            .collect();
        Rasterizer {
            mesh: PhantomData,
            triangles,
            original_triangle: keyed.iter().map(|&(_, t)| t).collect(),
            positions: original_vertex
                .iter()
                .map(|&i| mesh.positions[i as usize])
                .collect(),
            normals: original_vertex
                .iter()
                .map(|&i| normals[i as usize])
                .collect(),
            original_vertex,
            colors: None,
            front_sign: closed_front_sign(mesh),
        }
    }

    /// Whether back faces are skipped (a closed mesh).
    pub fn culls_back_faces(&self) -> bool {
        self.front_sign.is_some()
    }

    /// Paints the mesh with per-vertex colours (interpolated across triangles) instead of
    /// the protocol's material; None restores the material.
    pub fn set_vertex_colors(&mut self, colors: Option<Vec<[u8; 3]>>) {
        self.colors = colors.map(|c| {
            self.original_vertex
                .iter()
                .map(|&i| c[i as usize].map(|x| x as f64))
                .collect()
        });
    }

    fn bin(&self, cam: &CameraState, width: usize, height: usize, band_rows: usize) -> Binned {
        let vp = cam.view_projection();
        let (sx, sy) = (width as f64 * 0.5, height as f64 * 0.5);
        let screen: Vec<Option<ScreenVertex>> = self
            .positions
            .par_iter()
            .map(|p| {
                let c = vp * p.extend(1.0);
                (c.w > 1e-12).then(|| ScreenVertex {
                    x: (c.x / c.w + 1.0) * sx,
                    y: (1.0 - c.y / c.w) * sy,
                    z: c.z / c.w,
                    inv_w: 1.0 / c.w,
                })
            })
            .collect();
        let bands = height.div_ceil(band_rows);
        let mut bins: Vec<Vec<(u32, [ScreenVertex; 3])>> = vec![Vec::new(); bands];
        for (t, tri) in self.triangles.iter().enumerate() {
            let (Some(a), Some(b), Some(c)) = (
                screen[tri[0] as usize],
                screen[tri[1] as usize],
                screen[tri[2] as usize],
            ) else {
                continue; // a corner behind the eye: the protocol's framing never does this
            };
            if let Some(front) = self.front_sign {
                if edge((a.x, a.y), (b.x, b.y), (c.x, c.y)) * front <= 0.0 {
                    continue; // facing away: hidden behind the front of the closed mesh
                }
            }
            let ymin = a.y.min(b.y).min(c.y);
            let ymax = a.y.max(b.y).max(c.y);
            let xmin = a.x.min(b.x).min(c.x);
            let xmax = a.x.max(b.x).max(c.x);
            if ymax < 0.0 || ymin >= height as f64 || xmax < 0.0 || xmin >= width as f64 {
                continue;
            }
            let b0 = (ymin.max(0.0) as usize) / band_rows;
            let b1 = ((ymax.min(height as f64 - 1.0)) as usize) / band_rows;
            for bin in bins.iter_mut().take(b1 + 1).skip(b0) {
                bin.push((t as u32, [a, b, c]));
            }
        }
        Binned { bins }
    }

    /// Triangle index under each pixel centre (no anti-aliasing), BACKGROUND_ID where none.
    pub fn triangle_ids(&self, cam: &CameraState) -> Vec<u32> {
        let (width, height) = (cam.width_px as usize, cam.height_px as usize);
        let band_rows = BAND_PIXEL_ROWS;
        let binned = self.bin(cam, width, height, band_rows);
        let mut ids = vec![BACKGROUND_ID; width * height];
        ids.par_chunks_mut(band_rows * width)
            .enumerate()
            .for_each_init(Vec::new, |depth, (b, tri)| {
                depth.clear();
                depth.resize(tri.len(), f32::INFINITY);
                let rows = tri.len() / width;
                for (t, v) in &binned.bins[b] {
                    rasterize_triangle(v, *t, width, b * band_rows, rows, depth, tri);
                }
                for id in tri.iter_mut().filter(|id| **id != BACKGROUND_ID) {
                    *id = self.original_triangle[*id as usize];
                }
            });
        ids
    }

    /// An anti-aliased RGB frame (width × height × 3 bytes, rows top to bottom): each pixel
    /// covered by one triangle is shaded once at its centre; on a pixel whose samples see
    /// several triangles, each is shaded once at the centroid of its samples and weighted by
    /// their count (`edge_pixel`).
    pub fn render(&self, cam: &CameraState, style: &Rendering) -> Vec<u8> {
        let s = style.supersampling.max(1) as usize;
        let (w, h) = (cam.width_px as usize, cam.height_px as usize);
        let (width, height) = (w * s, h * s);
        let band_rows = BAND_PIXEL_ROWS * s;
        let binned = self.bin(cam, width, height, band_rows);
        let light = (cam.orientation * DVec3::from_array(style.light_direction))
            .normalize()
            .as_vec3();
        let material = style.material.map(|c| c as f64);
        let background = style.background.map(|c| c as f64);
        let mut rgb = vec![0u8; w * h * 3];
        rgb.par_chunks_mut(BAND_PIXEL_ROWS * w * 3)
            .enumerate()
            .for_each_init(
                || (Vec::new(), Vec::new(), Vec::new()),
                |(depth, tri, setups): &mut (Vec<f32>, Vec<u32>, Vec<Option<ShadingSetup>>),
                 (b, out)| {
                    let pixel_rows = out.len() / (w * 3);
                    let sample_rows = pixel_rows * s;
                    depth.clear();
                    depth.resize(sample_rows * width, f32::INFINITY);
                    tri.clear();
                    tri.resize(sample_rows * width, BACKGROUND_ID);
                    // Samples hold the triangle's place in this band's list, whose shading
                    // setup sits at the same place.
                    // Set up on first use: half the triangles of a closed mesh face away and
                    // many others are hidden, so most never shade a pixel.
                    setups.clear();
                    let band = &binned.bins[b];
                    for (local, (_, v)) in band.iter().enumerate() {
                        rasterize_triangle(
                            v,
                            local as u32,
                            width,
                            b * band_rows,
                            sample_rows,
                            depth,
                            tri,
                        );
                        setups.push(None);
                    }
                    let mut shade = |local: u32, x: f64, y: f64| -> [f64; 3] {
                        let st = setups[local as usize].get_or_insert_with(|| {
                            let (t, v) = &band[local as usize];
                            self.shading_setup(*t, v, cam.eye)
                        });
                        st.shade(x, y, light, style, material)
                    };
                    let put = |out: &mut [u8], o: usize, c: [f64; 3]| {
                        for k in 0..3 {
                            // Round half up (values are never negative): libm's round
                            // is a call per channel.
                            out[o + k] = (c[k].clamp(0.0, 255.0) + 0.5) as u8;
                        }
                    };
                    let mut background_rgb = [0u8; 3];
                    put(&mut background_rgb, 0, background);
                    for py in 0..pixel_rows {
                        let y = b * BAND_PIXEL_ROWS + py; // pixel row in the frame
                        let out_row = &mut out[py * w * 3..(py + 1) * w * 3];
                        if s == 2 {
                            // The protocol's setting, unrolled: the pixel's four samples are
                            // two pairs in two rows.
                            let top = &tri[2 * py * width..(2 * py + 1) * width];
                            let bottom = &tri[(2 * py + 1) * width..(2 * py + 2) * width];
                            for x in 0..w {
                                let o = x * 3;
                                let q =
                                    [top[2 * x], top[2 * x + 1], bottom[2 * x], bottom[2 * x + 1]];
                                let t0 = q[0];
                                if q[1] == t0 && q[2] == t0 && q[3] == t0 {
                                    if t0 == BACKGROUND_ID {
                                        out_row[o..o + 3].copy_from_slice(&background_rgb);
                                    } else {
                                        let c = shade(
                                            t0,
                                            (x as f64 + 0.5) * 2.0,
                                            (y as f64 + 0.5) * 2.0,
                                        );
                                        put(out_row, o, c);
                                    }
                                    continue;
                                }
                                put(out_row, o, edge_pixel(&q, 2, x, y, &mut shade, background));
                            }
                            continue;
                        }
                        for x in 0..w {
                            let sample =
                                |dy: usize, dx: usize| tri[(py * s + dy) * width + x * s + dx];
                            let t0 = sample(0, 0);
                            let uniform = (0..s).all(|dy| (0..s).all(|dx| sample(dy, dx) == t0));
                            let c = if uniform && t0 == BACKGROUND_ID {
                                background
                            } else if uniform {
                                shade(t0, (x as f64 + 0.5) * s as f64, (y as f64 + 0.5) * s as f64)
                            } else {
                                let mut q = [BACKGROUND_ID; 16];
                                for dy in 0..s {
                                    for dx in 0..s {
                                        q[dy * s + dx] = sample(dy, dx);
                                    }
                                }
                                edge_pixel(&q[..s * s], s, x, y, &mut shade, background)
                            };
                            put(out_row, x * 3, c);
                        }
                    }
                },
            );
        rgb
    }
}

/// The colour of a pixel whose samples (`q`, row by row, `s` × `s`) do not all see one
/// triangle: each distinct triangle is shaded once, at the centroid of the samples it covers,
/// and weighted by their count, as multisampling does. The centroid of points inside a
/// triangle is inside it, so no shade is extrapolated past an edge; where a surface merely
/// continues across an edge between two triangles (most edge pixels of a dense mesh), two
/// shades stand for four.
#[inline]
fn edge_pixel(
    q: &[u32],
    s: usize,
    x: usize,
    y: usize,
    shade: &mut impl FnMut(u32, f64, f64) -> [f64; 3],
    background: [f64; 3],
) -> [f64; 3] {
    let mut acc = [0.0f64; 3];
    for (i, &t) in q.iter().enumerate() {
        if q[..i].contains(&t) {
            continue; // shaded with its first sample
        }
        let (mut n, mut sum_dx, mut sum_dy) = (0usize, 0usize, 0usize);
        for (j, _) in q.iter().enumerate().skip(i).filter(|(_, &u)| u == t) {
            n += 1;
            sum_dx += j % s;
            sum_dy += j / s;
        }
        let c = if t == BACKGROUND_ID {
            background
        } else {
            shade(
                t,
                (x * s) as f64 + 0.5 + sum_dx as f64 / n as f64,
                (y * s) as f64 + 0.5 + sum_dy as f64 / n as f64,
            )
        };
        for k in 0..3 {
            acc[k] += c[k] * n as f64;
        }
    }
    acc.map(|a| a / q.len() as f64)
}

/// A triangle's shading inputs as planes in screen space, set up once per band. With
/// q_k = (edge function opposite corner k / area) · (1/w_k), which is affine in screen
/// space, the perspective-correct barycentrics are q_k / Σq, so any attribute F is
/// Σ q_k F_k / Σq: numerator and denominator are planes. The normal needs no division (it is
/// normalized), nor does the sign of n·(eye − p) (Σq > 0 inside). Planes are f32 about the
/// triangle's first corner, so a pixel costs a few multiply-adds and no vertex lookups.
struct ShadingSetup {
    origin: [f64; 2],
    /// Σq, the normal N (3), eye·Σq − P (3), the vertex colour (3): value at the origin and
    /// slopes along x and y.
    planes: [[f32; 3]; 10],
}

impl ShadingSetup {
    #[inline]
    fn shade(
        &self,
        x: f64,
        y: f64,
        light: Vec3,
        style: &Rendering,
        material: [f64; 3],
    ) -> [f64; 3] {
        let (dx, dy) = ((x - self.origin[0]) as f32, (y - self.origin[1]) as f32);
        let at32 = |k: usize| {
            let p = self.planes[k];
            p[0] + p[1] * dx + p[2] * dy
        };
        let at = |k: usize| at32(k) as f64;
        // In f32, as the planes are: the shade is rounded to 8 bits. The normal is normalized
        // only where the light reaches it (a square root and a division per pixel were a
        // quarter of the shading time).
        let n = Vec3::new(at32(1), at32(2), at32(3));
        let to_eye = Vec3::new(at32(4), at32(5), at32(6));
        let mut toward_light = n.dot(light);
        if n.dot(to_eye) < 0.0 {
            toward_light = -toward_light; // two-sided: scans with holes show their insides
        }
        let length2 = n.length_squared();
        let lit = if toward_light > 0.0 && length2 > 0.0 && length2.is_finite() {
            toward_light / length2.sqrt()
        } else {
            0.0
        };
        let intensity = style.ambient + style.diffuse * lit as f64;
        let albedo = if self.planes[7][0].is_nan() {
            material
        } else {
            let sum = at(0);
            [at(7) / sum, at(8) / sum, at(9) / sum]
        };
        albedo.map(|m| m * intensity)
    }
}

impl Rasterizer<'_> {
    fn shading_setup(&self, t: u32, v: &[ScreenVertex; 3], eye: DVec3) -> ShadingSetup {
        let p = v.map(|s| (s.x, s.y));
        let origin = [p[0].0 as f32 as f64, p[0].1 as f32 as f64];
        let area = edge(p[0], p[1], p[2]);
        let idx = self.triangles[t as usize].map(|k| k as usize);
        // q_k = α_k + β_k (x − ox) + γ_k (y − oy).
        let q: [[f64; 3]; 3] = std::array::from_fn(|k| {
            let (a, b) = (p[(k + 1) % 3], p[(k + 2) % 3]);
            let scale = if area != 0.0 { v[k].inv_w / area } else { 0.0 };
            [
                edge(a, b, (origin[0], origin[1])) * scale,
                -(b.1 - a.1) * scale,
                (b.0 - a.0) * scale,
            ]
        });
        let plane = |f: [f64; 3]| -> [f32; 3] {
            std::array::from_fn(|c| (0..3).map(|k| q[k][c] * f[k]).sum::<f64>() as f32)
        };
        let normals = idx.map(|i| self.normals[i]);
        let to_eye = idx.map(|i| eye - self.positions[i]);
        let mut planes = [[f32::NAN; 3]; 10];
        planes[0] = plane([1.0; 3]);
        for c in 0..3 {
            planes[1 + c] = plane(normals.map(|n| n[c]));
            planes[4 + c] = plane(to_eye.map(|e| e[c]));
        }
        if let Some(colors) = &self.colors {
            for c in 0..3 {
                planes[7 + c] = plane(idx.map(|i| colors[i][c]));
            }
        }
        ShadingSetup { origin, planes }
    }
}

/// Interleaves the low 10 bits of x, y and z.
fn morton3(x: u32, y: u32, z: u32) -> u32 {
    fn spread(v: u32) -> u32 {
        let mut v = v & 0x3ff;
        v = (v | (v << 16)) & 0x0300_00ff;
        v = (v | (v << 8)) & 0x0300_f00f;
        v = (v | (v << 4)) & 0x030c_30c3;
        (v | (v << 2)) & 0x0924_9249
    }
    spread(x) | (spread(y) << 1) | (spread(z) << 2)
}

/// floor and ceil without a libm call per use (x86-64 without SSE4.1 has no rounding
/// instruction); exact for |x| < 2^52, which screen coordinates are.
trait FastRound {
    fn floor_fast(self) -> f64;
    fn ceil_fast(self) -> f64;
}

impl FastRound for f64 {
    #[inline]
    fn floor_fast(self) -> f64 {
        if self.is_nan() || self.abs() >= 4.5e15 {
            return self.floor(); // huge, infinite or NaN: leave it to libm
        }
        let t = self as i64 as f64;
        if t > self {
            t - 1.0
        } else {
            t
        }
    }

    #[inline]
    fn ceil_fast(self) -> f64 {
        -(-self).floor_fast()
    }
}

#[inline]
fn edge(a: (f64, f64), b: (f64, f64), p: (f64, f64)) -> f64 {
    (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
}

/// Top-left rule for a counter-clockwise (in screen space, y down) edge a → b.
#[inline]
fn is_top_left(a: (f64, f64), b: (f64, f64)) -> bool {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    (dy == 0.0 && dx < 0.0) || dy > 0.0
}

fn rasterize_triangle(
    v: &[ScreenVertex; 3],
    t: u32,
    width: usize,
    row0: usize,
    rows: usize,
    depth: &mut [f32],
    tri: &mut [u32],
) {
    let p = v.map(|s| (s.x, s.y));
    let area = edge(p[0], p[1], p[2]);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    // Visit corners in an order with positive area; keep track of the original corner numbers.
    let order = if area > 0.0 { [0, 1, 2] } else { [0, 2, 1] };
    let q = order.map(|k| p[k]);
    let area = area.abs();
    let xmin = q
        .iter()
        .map(|a| a.0)
        .fold(f64::INFINITY, f64::min)
        .floor_fast()
        .max(0.0) as usize;
    let xmax = (q
        .iter()
        .map(|a| a.0)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil_fast() as usize)
        .min(width);
    let ymin = (q
        .iter()
        .map(|a| a.1)
        .fold(f64::INFINITY, f64::min)
        .floor_fast()
        .max(row0 as f64) as usize)
        .max(row0);
    let ymax = (q
        .iter()
        .map(|a| a.1)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil_fast() as usize)
        .min(row0 + rows);
    let tl = [
        is_top_left(q[1], q[2]),
        is_top_left(q[2], q[0]),
        is_top_left(q[0], q[1]),
    ];
    // Edge k runs between the two corners other than k; its function grows by dx[k] per
    // sample to the right, so a row costs three additions per sample.
    let ends = [(q[1], q[2]), (q[2], q[0]), (q[0], q[1])];
    let dx = ends.map(|(a, b)| -(b.1 - a.1));
    // Depth of the reordered corners, scaled by 1/area.
    let zs = order.map(|k| v[k].z / area);
    let x_start = xmin as f64 + 0.5;
    for y in ymin..ymax {
        let c = (x_start, y as f64 + 0.5);
        let w0 = ends.map(|(a, b)| edge(a, b, c));
        // The row's samples inside form one run. A narrow box is scanned whole (the exact
        // test decides every sample, so the bytes are the same); a wide one is first bounded
        // from the edge equations, whose divisions would cost more than they save on the
        // few samples of a small triangle.
        let (mut lo, mut hi) = (xmin as f64, xmax as f64);
        if xmax - xmin > NARROW_BOX {
            for k in 0..3 {
                if dx[k] > 0.0 {
                    lo = lo.max(xmin as f64 + (-w0[k] / dx[k]).floor_fast() - 1.0);
                } else if dx[k] < 0.0 {
                    hi = hi.min(xmin as f64 + (-w0[k] / dx[k]).ceil_fast() + 2.0);
                } else if w0[k] < 0.0 || (w0[k] == 0.0 && !tl[k]) {
                    hi = lo; // parallel to the row and outside: no sample
                }
            }
        } else if (0..3).any(|k| dx[k] == 0.0 && (w0[k] < 0.0 || (w0[k] == 0.0 && !tl[k]))) {
            continue; // parallel to the row and outside: no sample
        }
        if lo >= hi || lo.is_nan() || hi.is_nan() {
            continue;
        }
        let (lo, hi) = (lo as usize, (hi as usize).min(xmax));
        let row = (y - row0) * width;
        let edges = RowEdges {
            w0,
            dx,
            top_left: tl,
            zs,
            x0: xmin,
        };
        edges.cover(
            t,
            lo,
            hi,
            &mut depth[row..row + width],
            &mut tri[row..row + width],
        );
    }
}

/// Bounding boxes up to this many samples wide are scanned whole, without bounding each row.
const NARROW_BOX: usize = 16;

/// One row of one triangle: its three edge functions at sample `x0` and their step per
/// sample, the top-left rule per edge, and the corners' depths over the area.
struct RowEdges {
    w0: [f64; 3],
    dx: [f64; 3],
    top_left: [bool; 3],
    zs: [f64; 3],
    x0: usize,
}

impl RowEdges {
    /// Depth-tests the samples lo..hi of the row that lie inside the triangle and writes
    /// `t` where it is nearest. The AVX2 path does the same operations in the same order
    /// (no fused multiply-add), so its bytes are the scalar path's (unit test).
    #[inline]
    fn cover(&self, t: u32, lo: usize, hi: usize, depth: &mut [f32], tri: &mut [u32]) {
        #[cfg(target_arch = "x86_64")]
        {
            if hi - lo >= 4 && std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: AVX2 is present (checked above); lo..hi lies within the row.
                let done = unsafe { self.cover_avx2(t, lo, hi, depth, tri) };
                self.cover_scalar(t, done, hi, depth, tri);
                return;
            }
        }
        self.cover_scalar(t, lo, hi, depth, tri);
    }

    #[inline]
    fn cover_scalar(&self, t: u32, lo: usize, hi: usize, depth: &mut [f32], tri: &mut [u32]) {
        for x in lo..hi {
            let off = (x - self.x0) as f64;
            let w: [f64; 3] = std::array::from_fn(|k| self.w0[k] + self.dx[k] * off);
            if (0..3).all(|k| w[k] > 0.0 || (w[k] == 0.0 && self.top_left[k])) {
                let z = w[0] * self.zs[0] + w[1] * self.zs[1] + w[2] * self.zs[2];
                if (z as f32) < depth[x] {
                    depth[x] = z as f32;
                    tri[x] = t;
                }
            }
        }
    }

    /// Four samples at a time; returns where it stopped (the last < 4 are left to the
    /// scalar loop).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn cover_avx2(
        &self,
        t: u32,
        lo: usize,
        hi: usize,
        depth: &mut [f32],
        tri: &mut [u32],
    ) -> usize {
        use std::arch::x86_64::*;
        assert!(hi <= depth.len() && hi <= tri.len());
        let zero = _mm256_setzero_pd();
        let w0 = self.w0.map(|v| _mm256_set1_pd(v));
        let dx = self.dx.map(|v| _mm256_set1_pd(v));
        let zs = self.zs.map(|v| _mm256_set1_pd(v));
        let tl = self
            .top_left
            .map(|b| _mm256_castsi256_pd(_mm256_set1_epi64x(if b { -1 } else { 0 })));
        let lanes = _mm256_set_pd(3.0, 2.0, 1.0, 0.0);
        let id = _mm_set1_epi32(t as i32);
        // The low half of each 64-bit mask lane, as four 32-bit lanes.
        let narrow = _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6);
        let mut x = lo;
        while x + 4 <= hi {
            // (x - x0) + lane is exact in f64, as the scalar (x - x0) as f64 is.
            let off = _mm256_add_pd(_mm256_set1_pd((x - self.x0) as f64), lanes);
            let mut inside = _mm256_castsi256_pd(_mm256_set1_epi64x(-1));
            let mut w = [zero; 3];
            for k in 0..3 {
                w[k] = _mm256_add_pd(w0[k], _mm256_mul_pd(dx[k], off));
                let positive = _mm256_cmp_pd::<_CMP_GT_OQ>(w[k], zero);
                let on_edge = _mm256_and_pd(_mm256_cmp_pd::<_CMP_EQ_OQ>(w[k], zero), tl[k]);
                inside = _mm256_and_pd(inside, _mm256_or_pd(positive, on_edge));
            }
            if _mm256_movemask_pd(inside) != 0 {
                let z = _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(w[0], zs[0]), _mm256_mul_pd(w[1], zs[1])),
                    _mm256_mul_pd(w[2], zs[2]),
                );
                let z32 = _mm256_cvtpd_ps(z);
                let dp = depth.as_mut_ptr().add(x);
                let tp = tri.as_mut_ptr().add(x) as *mut __m128i;
                let old = _mm_loadu_ps(dp);
                let inside32 = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
                    _mm256_castpd_si256(inside),
                    narrow,
                ));
                let nearer = _mm_and_ps(_mm_cmplt_ps(z32, old), _mm_castsi128_ps(inside32));
                _mm_storeu_ps(dp, _mm_blendv_ps(old, z32, nearer));
                let ids = _mm_loadu_si128(tp);
                _mm_storeu_si128(
                    tp,
                    _mm_castps_si128(_mm_blendv_ps(
                        _mm_castsi128_ps(ids),
                        _mm_castsi128_ps(id),
                        nearer,
                    )),
                );
            }
            x += 4;
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::test_meshes::icosphere;
    use crate::protocol::Protocol;
    use crate::stimulus::camera::CameraPlan;

    fn ids_and_frame(mesh: &Mesh, cull: bool, view: usize) -> (Vec<u32>, Vec<u8>) {
        let (protocol, _) = Protocol::builtin();
        let plan = CameraPlan::new(mesh, &protocol).unwrap();
        let cam = plan.at(view as f64 * (protocol.timing.hold_s + protocol.timing.move_s));
        let mut raster = Rasterizer::new(mesh);
        if !cull {
            raster.front_sign = None;
        }
        (
            raster.triangle_ids(&cam),
            raster.render(&cam, &protocol.rendering),
        )
    }

    /// On a closed mesh seen from outside, skipping the triangles that face away changes no
    /// pixel and no triangle id, whichever way the mesh is wound.
    #[test]
    fn culling_back_faces_of_a_closed_mesh_changes_nothing() {
        let mut sphere = icosphere(1.0, 3);
        // Dents make parts of the front hide others, so depth order matters too.
        for (i, p) in sphere.positions.iter_mut().enumerate() {
            *p *= 1.0 + 0.15 * ((i * 7919) % 5) as f64 / 5.0;
        }
        let mut inverted = sphere.clone();
        inverted.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        for mesh in [&sphere, &inverted] {
            assert!(Rasterizer::new(mesh).culls_back_faces());
            for view in [0, 5] {
                let (ids_all, frame_all) = ids_and_frame(mesh, false, view);
                let (ids_culled, frame_culled) = ids_and_frame(mesh, true, view);
                assert!(ids_all.iter().any(|&t| t != BACKGROUND_ID));
                assert!(ids_all == ids_culled, "triangle ids differ (view {view})");
                assert!(frame_all == frame_culled, "pixels differ (view {view})");
            }
        }
    }

    /// The AVX2 row kernel writes the scalar loop's depths and ids, bit for bit, including
    /// samples exactly on an edge (top-left rule), NaN edges and every tail length.
    #[test]
    fn row_kernel_matches_the_scalar_loop() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let unit = |n: u64| (n % 20_001) as f64 / 10_000.0 - 1.0;
        for case in 0..4000 {
            // Integer-valued steps land samples exactly on edges; others do not.
            let w0: [f64; 3] = std::array::from_fn(|_| (unit(next()) * 8.0).round() / 2.0);
            let dx: [f64; 3] = std::array::from_fn(|k| {
                if case % 3 == 0 {
                    [1.0, -0.5, 0.0][k]
                } else {
                    unit(next())
                }
            });
            let mut w0 = w0;
            if case % 97 == 0 {
                w0[1] = f64::NAN;
            }
            let edges = RowEdges {
                w0,
                dx,
                top_left: std::array::from_fn(|k| (next() >> k) & 1 == 1),
                zs: std::array::from_fn(|_| unit(next())),
                x0: 3,
            };
            let len = 3 + (next() % 40) as usize;
            let lo = 3 + (next() % 4) as usize;
            let hi = (lo + (next() % 30) as usize).min(len);
            let depth: Vec<f32> = (0..len).map(|_| unit(next()) as f32 * 3.0).collect();
            let tri: Vec<u32> = (0..len).map(|i| i as u32).collect();
            let (mut d1, mut t1) = (depth.clone(), tri.clone());
            let (mut d2, mut t2) = (depth, tri);
            edges.cover(77, lo, hi.max(lo), &mut d1, &mut t1);
            edges.cover_scalar(77, lo, hi.max(lo), &mut d2, &mut t2);
            assert_eq!(t1, t2, "ids, case {case}");
            assert!(
                d1.iter().zip(&d2).all(|(a, b)| a.to_bits() == b.to_bits()),
                "depths, case {case}"
            );
        }
    }

    /// An edge pixel shades each triangle once, at the centroid of the samples it covers, and
    /// weights it by their count; background samples count as the background colour.
    #[test]
    fn edge_pixels_shade_each_triangle_once_at_its_samples_centroid() {
        let mut calls = Vec::new();
        let mut shade = |t: u32, x: f64, y: f64| {
            calls.push((t, x, y));
            [t as f64, x, y]
        };
        let background = [100.0, 0.0, 0.0];
        // Pixel (3, 4) at 2x2: samples at x 6.5 / 7.5 and y 8.5 / 9.5, row by row.
        let c = edge_pixel(&[5, 5, 7, BACKGROUND_ID], 2, 3, 4, &mut shade, background);
        assert_eq!(calls, vec![(5, 7.0, 8.5), (7, 6.5, 9.5)]);
        let expected = [
            (2.0 * 5.0 + 7.0 + 100.0) / 4.0,
            (2.0 * 7.0 + 6.5) / 4.0,
            (2.0 * 8.5 + 9.5) / 4.0,
        ];
        assert_eq!(c, expected);
    }

    #[test]
    fn open_or_inconsistent_meshes_draw_every_triangle() {
        let mut open = icosphere(1.0, 2);
        open.triangles.pop();
        assert!(!Rasterizer::new(&open).culls_back_faces());
        let mut flipped_one = icosphere(1.0, 2);
        flipped_one.triangles[0].swap(1, 2);
        assert!(!Rasterizer::new(&flipped_one).culls_back_faces());
    }
}

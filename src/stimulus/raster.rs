//! A CPU triangle rasterizer for stimulus frames: z-buffered, two-sided Lambert + ambient
//! shading with a headlight, supersampled anti-aliasing, and a triangle-id buffer for the
//! projector self-check. Deterministic: the same mesh, camera and settings give the same bytes.
//!
//! Rasterization samples pixel centres with the top-left fill rule, so two triangles sharing
//! an edge never both cover (or both miss) a sample on it: the id buffer is watertight.
use glam::DVec3;
use rayon::prelude::*;

use super::camera::CameraState;
use super::protocol::Rendering;
use crate::mesh::Mesh;

pub const BACKGROUND_ID: u32 = u32::MAX;

/// A mesh prepared for rendering: positions, area-weighted vertex normals, and sample
/// buffers reused from frame to frame (a 2x-supersampled 1680x1050 frame needs ~110 MB).
pub struct Rasterizer<'a> {
    mesh: &'a Mesh,
    normals: Vec<DVec3>,
    buffers: Visibility,
    /// Per-vertex albedo (0–255) replacing the material colour, for rendering maps.
    colors: Option<Vec<[f64; 3]>>,
}

/// Per-sample results of the visibility pass.
struct Visibility {
    width: usize,
    height: usize,
    depth: Vec<f32>,
    triangle: Vec<u32>,
    /// Perspective-correct barycentrics of corners 1 and 2.
    bary: Vec<[f32; 2]>,
}

#[derive(Clone, Copy)]
struct ScreenVertex {
    x: f64,
    y: f64,
    z: f64,
    inv_w: f64,
}

const BAND_ROWS: usize = 16;

impl<'a> Rasterizer<'a> {
    pub fn new(mesh: &'a Mesh) -> Rasterizer<'a> {
        Rasterizer {
            mesh,
            normals: mesh.vertex_normals(),
            buffers: Visibility {
                width: 0,
                height: 0,
                depth: Vec::new(),
                triangle: Vec::new(),
                bary: Vec::new(),
            },
            colors: None,
        }
    }

    /// Paints the mesh with per-vertex colours (interpolated across triangles) instead of
    /// the protocol's material; None restores the material.
    pub fn set_vertex_colors(&mut self, colors: Option<Vec<[u8; 3]>>) {
        self.colors = colors.map(|c| c.iter().map(|v| v.map(|x| x as f64)).collect());
    }

    fn visibility(&mut self, cam: &CameraState, scale: usize) {
        let width = cam.width_px as usize * scale;
        let height = cam.height_px as usize * scale;
        let vp = cam.view_projection();
        let (sx, sy) = (width as f64 * 0.5, height as f64 * 0.5);
        let screen: Vec<Option<ScreenVertex>> = self
            .mesh
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
        // Bin triangles by the row bands their bounding box touches.
        let bands = height.div_ceil(BAND_ROWS);
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); bands];
        for (t, tri) in self.mesh.triangles.iter().enumerate() {
            let Some(v) = tri
                .iter()
                .map(|&i| screen[i as usize])
                .collect::<Option<Vec<_>>>()
            else {
                continue; // a corner behind the eye: the protocol's framing never does this
            };
            let ymin = v.iter().map(|s| s.y).fold(f64::INFINITY, f64::min);
            let ymax = v.iter().map(|s| s.y).fold(f64::NEG_INFINITY, f64::max);
            let xmin = v.iter().map(|s| s.x).fold(f64::INFINITY, f64::min);
            let xmax = v.iter().map(|s| s.x).fold(f64::NEG_INFINITY, f64::max);
            if ymax < 0.0 || ymin >= height as f64 || xmax < 0.0 || xmin >= width as f64 {
                continue;
            }
            let b0 = (ymin.max(0.0) as usize) / BAND_ROWS;
            let b1 = ((ymax.min(height as f64 - 1.0)) as usize) / BAND_ROWS;
            for bin in bins.iter_mut().take(b1 + 1).skip(b0) {
                bin.push(t as u32);
            }
        }
        let vis = &mut self.buffers;
        vis.width = width;
        vis.height = height;
        vis.depth.clear();
        vis.depth.resize(width * height, f32::INFINITY);
        vis.triangle.clear();
        vis.triangle.resize(width * height, BACKGROUND_ID);
        vis.bary.resize(width * height, [0.0; 2]);
        let band_len = BAND_ROWS * width;
        let mesh = self.mesh;
        vis.depth
            .par_chunks_mut(band_len)
            .zip(vis.triangle.par_chunks_mut(band_len))
            .zip(vis.bary.par_chunks_mut(band_len))
            .enumerate()
            .for_each(|(b, ((dep, tri), bar))| {
                let row0 = b * BAND_ROWS;
                let rows = dep.len() / width;
                for &t in &bins[b] {
                    let idx = mesh.triangles[t as usize];
                    let v = idx.map(|i| screen[i as usize].expect("binned triangles are in front"));
                    rasterize_triangle(&v, t, width, row0, rows, dep, tri, bar);
                }
            });
    }

    /// Triangle index under each pixel centre (no anti-aliasing), BACKGROUND_ID where none.
    pub fn triangle_ids(&mut self, cam: &CameraState) -> Vec<u32> {
        self.visibility(cam, 1);
        self.buffers.triangle.clone()
    }

    /// An anti-aliased RGB frame (width × height × 3 bytes, rows top to bottom).
    pub fn render(&mut self, cam: &CameraState, style: &Rendering) -> Vec<u8> {
        let s = style.supersampling.max(1) as usize;
        self.visibility(cam, s);
        let vis = &self.buffers;
        let light = (cam.orientation * DVec3::from_array(style.light_direction)).normalize();
        let material = style.material.map(|c| c as f64);
        let background = style.background.map(|c| c as f64);
        let (w, h) = (cam.width_px as usize, cam.height_px as usize);
        let shade = |t: u32, b1: f64, b2: f64| -> [f64; 3] {
            let b0 = 1.0 - b1 - b2;
            let idx = self.mesh.triangles[t as usize].map(|k| k as usize);
            let p = self.mesh.positions[idx[0]] * b0
                + self.mesh.positions[idx[1]] * b1
                + self.mesh.positions[idx[2]] * b2;
            let mut n =
                (self.normals[idx[0]] * b0 + self.normals[idx[1]] * b1 + self.normals[idx[2]] * b2)
                    .normalize_or_zero();
            if n.dot(cam.eye - p) < 0.0 {
                n = -n; // two-sided: scans with holes show their insides
            }
            let intensity = style.ambient + style.diffuse * n.dot(light).max(0.0);
            let albedo = match &self.colors {
                Some(c) => {
                    let (c0, c1, c2) = (c[idx[0]], c[idx[1]], c[idx[2]]);
                    [0, 1, 2].map(|k| c0[k] * b0 + c1[k] * b1 + c2[k] * b2)
                }
                None => material,
            };
            albedo.map(|m| m * intensity)
        };
        let mut rgb = vec![0u8; w * h * 3];
        rgb.par_chunks_mut(w * 3).enumerate().for_each(|(y, row)| {
            for x in 0..w {
                let first = (y * s) * vis.width + x * s;
                let t0 = vis.triangle[first];
                let uniform = (0..s).all(|dy| {
                    (0..s).all(|dx| vis.triangle[(y * s + dy) * vis.width + x * s + dx] == t0)
                });
                let c = if uniform && t0 == BACKGROUND_ID {
                    background
                } else if uniform {
                    // One triangle under every sample: shade once at the mean barycentrics.
                    let (mut b1, mut b2) = (0.0, 0.0);
                    for dy in 0..s {
                        for dx in 0..s {
                            let b = vis.bary[(y * s + dy) * vis.width + x * s + dx];
                            b1 += b[0] as f64;
                            b2 += b[1] as f64;
                        }
                    }
                    let n = (s * s) as f64;
                    shade(t0, b1 / n, b2 / n)
                } else {
                    let mut acc = [0.0f64; 3];
                    for dy in 0..s {
                        for dx in 0..s {
                            let i = (y * s + dy) * vis.width + x * s + dx;
                            let t = vis.triangle[i];
                            let c = if t == BACKGROUND_ID {
                                background
                            } else {
                                let b = vis.bary[i];
                                shade(t, b[0] as f64, b[1] as f64)
                            };
                            for k in 0..3 {
                                acc[k] += c[k];
                            }
                        }
                    }
                    acc.map(|a| a / (s * s) as f64)
                };
                for k in 0..3 {
                    row[x * 3 + k] = c[k].round().clamp(0.0, 255.0) as u8;
                }
            }
        });
        rgb
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

#[allow(clippy::too_many_arguments)]
fn rasterize_triangle(
    v: &[ScreenVertex; 3],
    t: u32,
    width: usize,
    row0: usize,
    rows: usize,
    depth: &mut [f32],
    tri: &mut [u32],
    bary: &mut [[f32; 2]],
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
        .floor()
        .max(0.0) as usize;
    let xmax = (q
        .iter()
        .map(|a| a.0)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil() as usize)
        .min(width);
    let ymin = (q
        .iter()
        .map(|a| a.1)
        .fold(f64::INFINITY, f64::min)
        .floor()
        .max(row0 as f64) as usize)
        .max(row0);
    let ymax = (q
        .iter()
        .map(|a| a.1)
        .fold(f64::NEG_INFINITY, f64::max)
        .ceil() as usize)
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
    // Depth and perspective weights of the reordered corners, scaled by 1/area.
    let zs = order.map(|k| v[k].z / area);
    let iw = order.map(|k| v[k].inv_w / area);
    let x_start = xmin as f64 + 0.5;
    for y in ymin..ymax {
        let c = (x_start, y as f64 + 0.5);
        let mut w = ends.map(|(a, b)| edge(a, b, c));
        let row = (y - row0) * width;
        for x in xmin..xmax {
            let inside = (0..3).all(|k| w[k] > 0.0 || (w[k] == 0.0 && tl[k]));
            if inside {
                let z = w[0] * zs[0] + w[1] * zs[1] + w[2] * zs[2];
                let i = row + x;
                if (z as f32) < depth[i] {
                    depth[i] = z as f32;
                    tri[i] = t;
                    // Perspective-correct weights, back in the original corner order.
                    let mut pc = [0.0; 3];
                    for k in 0..3 {
                        pc[order[k]] = w[k] * iw[k];
                    }
                    let sum = pc[0] + pc[1] + pc[2];
                    bary[i] = [(pc[1] / sum) as f32, (pc[2] / sum) as f32];
                }
            }
            for k in 0..3 {
                w[k] += dx[k];
            }
        }
    }
}

use std::io::Write;
use std::path::Path;

use super::Mesh;

/// Maps a value in [0, 1] to an RGB colour, blue (low) through cyan, green, yellow to red
/// (high), the ramp of the saliency figures in the paper.
#[derive(Debug, Clone, Copy, Default)]
pub struct ColorRamp;

impl ColorRamp {
    /// The colour at ramp position `t` (0 blue, through cyan, green and yellow, to 1 red).
    pub fn rgb(&self, t: f64) -> [u8; 3] {
        const STOPS: [[f64; 3]; 5] = [
            [0.0, 0.0, 1.0],
            [0.0, 1.0, 1.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
        ];
        let t = if t.is_finite() {
            t.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let x = t * 4.0;
        let i = (x.floor() as usize).min(3);
        let f = x - i as f64;
        let c = |k: usize| ((STOPS[i][k] * (1.0 - f) + STOPS[i + 1][k] * f) * 255.0).round() as u8;
        [c(0), c(1), c(2)]
    }
}

/// How a map's values become ramp positions: linear between the 1st and 99th percentiles of
/// its finite values, clamped outside. Curvature-like maps are heavy-tailed; a min–max scale
/// lets a few extreme vertices push every other one into the bottom colour.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ColorScale {
    /// The value shown blue (the 1st percentile).
    pub lo: f64,
    /// The value shown red (the 99th percentile).
    pub hi: f64,
}

impl ColorScale {
    /// Percentiles used for the ends of the scale.
    pub const CLIP: (f64, f64) = (0.01, 0.99);
    /// The words every picture states under it.
    pub const RULE: &'static str = "colour: blue (1st percentile of the map) to red (99th)";

    /// The scale of `values`.
    pub fn of(values: &[f64]) -> ColorScale {
        let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        if v.is_empty() {
            return ColorScale { lo: 0.0, hi: 1.0 };
        }
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((v.len() - 1) as f64 * q).round() as usize];
        let (mut lo, mut hi) = (at(Self::CLIP.0), at(Self::CLIP.1));
        if hi <= lo {
            // A map that is constant over 98% of the vertices: fall back to its full range.
            lo = v[0];
            hi = v[v.len() - 1];
        }
        ColorScale { lo, hi }
    }

    /// The ramp position of `x`, in [0, 1].
    pub fn position(&self, x: f64) -> f64 {
        if self.hi > self.lo {
            ((x - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Colours of every value.
    pub fn colors(&self, values: &[f64]) -> Vec<[u8; 3]> {
        values
            .iter()
            .map(|&x| ColorRamp.rgb(self.position(x)))
            .collect()
    }
}

/// Writes a binary little-endian PLY with a per-vertex float `quality` (MeshLab shows it
/// with Render > Color > Per Vertex Quality; it keeps the raw values) and the ramp colour of the
/// quality under [`ColorScale`].
pub fn write_ply_with_quality(
    path: &Path,
    mesh: &Mesh,
    quality: &[f64],
    comments: &[String],
) -> std::io::Result<()> {
    assert_eq!(
        quality.len(),
        mesh.positions.len(),
        "one quality value per vertex"
    );
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(out, "ply")?;
    writeln!(out, "format binary_little_endian 1.0")?;
    for c in comments {
        // A newline inside a comment would end the header early.
        writeln!(out, "comment {}", c.replace(['\n', '\r'], " "))?;
    }
    writeln!(out, "element vertex {}", mesh.positions.len())?;
    for p in ["x", "y", "z", "quality"] {
        writeln!(out, "property float {p}")?;
    }
    for p in ["red", "green", "blue"] {
        writeln!(out, "property uchar {p}")?;
    }
    writeln!(out, "element face {}", mesh.triangles.len())?;
    writeln!(out, "property list uchar int vertex_indices")?;
    writeln!(out, "end_header")?;
    let colors = ColorScale::of(quality).colors(quality);
    for ((p, &q), c) in mesh.positions.iter().zip(quality).zip(&colors) {
        for v in [p.x as f32, p.y as f32, p.z as f32, q as f32] {
            out.write_all(&v.to_le_bytes())?;
        }
        out.write_all(c)?;
    }
    for t in &mesh.triangles {
        out.write_all(&[3u8])?;
        for &i in t {
            out.write_all(&(i as i32).to_le_bytes())?;
        }
    }
    out.flush()
}

//! Wavefront OBJ output that keeps every coordinate exactly.
//!
//! Used where a mesh made in memory (from Python arrays, say) must become a file that the
//! stimulus manifest can hash and that `project` can read back: Rust prints an `f64` with the
//! fewest digits that parse back to the same value, so the file round-trips bit for bit,
//! which the float32 PLY writer does not.
use std::io::Write;
use std::path::Path;

use super::Mesh;

/// Writes `mesh` as OBJ text: `v x y z` per vertex, `f a b c` (1-based) per triangle, in the
/// mesh's order, after `#` comment lines.
pub fn write_obj(path: &Path, mesh: &Mesh, comments: &[String]) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    for c in comments {
        writeln!(out, "# {}", c.replace(['\n', '\r'], " "))?;
    }
    for p in &mesh.positions {
        writeln!(out, "v {} {} {}", p.x, p.y, p.z)?;
    }
    for t in &mesh.triangles {
        writeln!(out, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
    }
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::load_mesh;
    use glam::DVec3;

    #[test]
    fn an_obj_written_here_reads_back_bit_for_bit() {
        let mesh = Mesh {
            positions: vec![
                DVec3::new(0.1, -2.0e-17, 1.0 / 3.0),
                DVec3::new(std::f64::consts::PI, 1e300, -0.0),
                DVec3::new(-7.25, 0.2 + 0.1, 12345.678901234567),
                DVec3::new(1.0, 1.0, 1.0),
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        };
        let dir = std::env::temp_dir().join(format!("meshgaze-write-obj-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("m.obj");
        write_obj(&path, &mesh, &["two\nlines".to_string()]).unwrap();
        let (back, _) = load_mesh(&path).unwrap();
        std::fs::remove_dir_all(&dir).ok();
        assert_eq!(back.triangles, mesh.triangles);
        for (a, b) in back.positions.iter().zip(&mesh.positions) {
            assert_eq!(
                a.to_array().map(f64::to_bits),
                b.to_array().map(f64::to_bits)
            );
        }
    }
}

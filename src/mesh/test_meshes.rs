//! Small synthetic meshes with known geometry (sphere, height field, cylinder), for tests
//! and examples across the crate: their curvature, area and visibility are known in closed form.
use glam::DVec3;

use super::Mesh;

/// Icosphere of radius r with `levels` midpoint subdivisions, projected to the sphere.
pub fn icosphere(r: f64, levels: usize) -> Mesh {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut positions: Vec<DVec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| DVec3::new(x, y, z).normalize() * r)
    .collect();
    let triangles = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut mesh = Mesh {
        positions: std::mem::take(&mut positions),
        triangles,
    };
    for _ in 0..levels {
        mesh = crate::mesh::subdivide_midpoint(&mesh);
        for p in &mut mesh.positions {
            *p = p.normalize() * r;
        }
    }
    mesh
}

/// A unit square height field z = height(x, y) of n × n vertices, x and y from `origin` to
/// `origin + 1`.
pub fn height_field(n: usize, origin: f64, height: impl Fn(f64, f64) -> f64) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let x = origin + i as f64 / (n - 1) as f64;
            let y = origin + j as f64 / (n - 1) as f64;
            positions.push(DVec3::new(x, y, height(x, y)));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let a = (j * n + i) as u32;
            let (b, c, d) = (a + 1, a + n as u32, a + n as u32 + 1);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    Mesh {
        positions,
        triangles,
    }
}

/// Open cylinder of radius r around z, `around` × `along` vertices.
pub fn cylinder(r: f64, height: f64, around: usize, along: usize) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..along {
        for i in 0..around {
            let a = 2.0 * std::f64::consts::PI * i as f64 / around as f64;
            positions.push(DVec3::new(
                r * a.cos(),
                r * a.sin(),
                height * j as f64 / (along - 1) as f64,
            ));
        }
    }
    let mut triangles = Vec::new();
    for j in 0..along - 1 {
        for i in 0..around {
            let a = (j * around + i) as u32;
            let b = (j * around + (i + 1) % around) as u32;
            let c = a + around as u32;
            let d = b + around as u32;
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    Mesh {
        positions,
        triangles,
    }
}

//! Helpers shared by the integration tests.
#![allow(dead_code)]
use std::path::{Path, PathBuf};

use glam::{DMat3, DVec3};
use meshgaze::mesh::{load_mesh, Mesh};

pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// The hu2020 protocol's text shrunk to a quick stimulus: 320x200, a 3-view turntable, holds
/// and moves of 0.3 s (54 frames at 30 fps).
pub fn short_protocol_text() -> String {
    std::fs::read_to_string(repo_root().join("protocols/hu2020.toml"))
        .expect("hu2020 protocol")
        .replace("width_px = 1680", "width_px = 320")
        .replace("height_px = 1050", "height_px = 200")
        .replace("generator = \"icosahedron\"", "generator = \"turntable\"")
        .replace("count = 12", "count = 3")
        .replace("hold_s = 3.0", "hold_s = 0.3")
        .replace("move_s = 1.0", "move_s = 0.3")
}

/// The bundled 8,171-vertex Stanford bunny.
pub fn bunny() -> Mesh {
    load_mesh(&repo_root().join("stimuli/meshes/bun_zipper_res2.ply"))
        .expect("bundled bunny loads")
        .0
}

/// The bundled 1,889-vertex bunny (Stanford's own decimation of the same scan).
pub fn bunny_res3() -> Mesh {
    load_mesh(&repo_root().join("stimuli/meshes/bun_zipper_res3.ply"))
        .expect("bundled bunny res3 loads")
        .0
}

/// `../shared/data` beside the repo. The tests that call this carry
/// `#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]`: build.rs sets the cfg when
/// the folder is missing (and CI is not set), so they are reported as ignored, never as passed.
/// Run anyway (`--ignored`), or under CI without the folder, they fail here, saying why.
pub fn shared_data() -> PathBuf {
    let p = repo_root().join("../shared/data");
    assert!(
        p.join("meshes").is_dir(),
        "{} is missing: this test needs the shared real data (see SOURCES.md there); \
         without it the test is compiled as ignored, unless CI is set",
        p.display()
    );
    p
}

/// A trial-1 sample with the same gaze for both eyes and nothing else exported.
pub fn both_eyes_sample(time_us: i64, e: meshgaze::gaze::EyeSample) -> meshgaze::gaze::Sample {
    meshgaze::gaze::Sample {
        time_us,
        trial: 1,
        left: Some(e),
        right: Some(e),
        binocular: None,
        binocular_event: None,
        left_event: None,
        right_event: None,
        stimulus: None,
    }
}

/// A rotation from three angles (deterministic, no RNG needed).
pub fn rotation(a: f64, b: f64, c: f64) -> DMat3 {
    DMat3::from_rotation_z(a) * DMat3::from_rotation_y(b) * DMat3::from_rotation_x(c)
}

pub fn transformed(mesh: &Mesh, f: impl Fn(DVec3) -> DVec3) -> Mesh {
    Mesh {
        positions: mesh.positions.iter().map(|&p| f(p)).collect(),
        triangles: mesh.triangles.clone(),
    }
}

/// The mesh rotated, translated and scaled ×37: the copies an invariant map must not notice.
pub fn rigid_and_scaled_copies(mesh: &Mesh) -> [(&'static str, Mesh); 3] {
    let rot = rotation(0.4, 1.2, -0.8);
    [
        ("rotated", transformed(mesh, |p| rot * p)),
        (
            "translated",
            transformed(mesh, |p| p + DVec3::new(12.0, -3.0, 7.5)),
        ),
        ("scaled x37", transformed(mesh, |p| p * 37.0)),
    ]
}

pub fn read_file(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

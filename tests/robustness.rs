//! The paper's robustness experiment: each corruption does what it says, and maps travel
//! back to the original vertices faithfully.
mod common;

use meshgaze::experiments::corruption::{
    add_normal_noise, boundary_loops, cut_holes, transfer_by_nearest_surface_point,
};
use meshgaze::mesh::simplification::simplify_to_vertex_count;
use meshgaze::mesh::test_meshes::icosphere;

#[test]
fn holes_are_separate_boundary_loops_in_a_closed_mesh() {
    let sphere = icosphere(1.0, 4);
    assert_eq!(boundary_loops(&sphere), 0, "an icosphere is closed");
    for holes in [1, 3, 5] {
        let (holed, origin) = cut_holes(&sphere, holes, 0.2, 7);
        assert_eq!(boundary_loops(&holed), holes, "{holes} holes");
        assert!(holed.triangles.len() < sphere.triangles.len());
        assert_eq!(origin.len(), holed.positions.len());
        for (v, &o) in origin.iter().enumerate() {
            assert_eq!(
                holed.positions[v], sphere.positions[o],
                "vertices keep their place"
            );
        }
        // Every vertex left is used by a triangle.
        let mut used = vec![false; holed.positions.len()];
        for t in &holed.triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        assert!(used.iter().all(|u| *u));
    }
}

#[test]
fn noise_moves_vertices_along_their_normals_by_the_asked_amount() {
    let mesh = common::bunny();
    let noisy = add_normal_noise(&mesh, 0.2, 3);
    assert_eq!(noisy.positions.len(), mesh.positions.len());
    assert_eq!(noisy.triangles, mesh.triangles);
    let normals = mesh.vertex_normals();
    let mut sq = 0.0;
    for ((p, q), n) in mesh.positions.iter().zip(&noisy.positions).zip(&normals) {
        let d = *q - *p;
        assert!(
            d.cross(*n).length() <= 1e-9 * (1.0 + d.length()),
            "off the normal"
        );
        sq += d.length_squared();
    }
    let sd = (sq / mesh.positions.len() as f64).sqrt();
    let want = 0.2 * mesh.mean_edge_length();
    assert!((sd / want - 1.0).abs() < 0.05, "σ {sd} vs {want}");
}

#[test]
fn simplification_reaches_the_asked_vertex_count() {
    let mesh = common::bunny();
    let (simple, origin) = simplify_to_vertex_count(&mesh, 2000);
    let n = simple.positions.len();
    assert!((1800..=2200).contains(&n), "{n} vertices");
    assert_eq!(origin.len(), n);
    for (v, &o) in origin.iter().enumerate() {
        assert_eq!(simple.positions[v], mesh.positions[o]);
    }
}

#[test]
fn a_map_transfers_back_exactly_at_shared_vertices_and_smoothly_between() {
    let mesh = common::bunny();
    let values: Vec<f64> = mesh.positions.iter().map(|p| p.x + 2.0 * p.y).collect();
    let same = transfer_by_nearest_surface_point(&mesh, &values, &mesh.positions);
    let mut referenced = vec![false; mesh.positions.len()];
    for t in &mesh.triangles {
        for &i in t {
            referenced[i as usize] = true;
        }
    }
    for v in (0..values.len()).filter(|&v| referenced[v]) {
        assert!((values[v] - same[v]).abs() < 1e-9, "vertex {v}");
    }
    // A linear field carried from a simplified copy stays close (barycentric interpolation
    // of a linear function is exact on the copy's surface).
    let (simple, _) = simplify_to_vertex_count(&mesh, 2000);
    let sv: Vec<f64> = simple.positions.iter().map(|p| p.x + 2.0 * p.y).collect();
    let back = transfer_by_nearest_surface_point(&simple, &sv, &mesh.positions);
    let scale = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - values.iter().cloned().fold(f64::INFINITY, f64::min);
    let worst = values
        .iter()
        .zip(&back)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 0.02 * scale, "worst {worst} of range {scale}");
}

/// Damage that leaves nothing to compare is refused with the flag to change, never a panic:
/// holes that remove every triangle, a "simplification" to the mesh's own vertex count, and a
/// saliency method asked to run on a mesh without triangles.
#[test]
fn impossible_corruptions_and_empty_meshes_are_refused_by_name() {
    use meshgaze::experiments::robustness::{robustness, RobustnessParams};
    use meshgaze::saliency::{compute_saliency, Method, SmsParams};
    let sphere = icosphere(1.0, 3);
    let n = sphere.positions.len();
    let run = |p: RobustnessParams| {
        robustness(
            &sphere,
            &[Method::Ms, Method::Mc],
            &SmsParams::default(),
            &p,
            &meshgaze::progress::Silent,
        )
        .err()
        .expect("refused")
        .to_string()
    };
    let e = run(RobustnessParams {
        hole_radius: 5.0,
        simplify_to: 100,
        ..RobustnessParams::default()
    });
    assert!(
        e.contains("--hole-radius") && e.contains("every triangle"),
        "{e}"
    );
    let e = run(RobustnessParams {
        simplify_to: n,
        ..RobustnessParams::default()
    });
    assert!(
        e.contains("--simplify-to") && e.contains(&n.to_string()),
        "{e}"
    );
    let mut empty = sphere.clone();
    empty.triangles.clear();
    for m in [Method::Sms, Method::Ms, Method::Mc, Method::Si] {
        let e = compute_saliency(
            m,
            &empty,
            &SmsParams::default(),
            &meshgaze::progress::Silent,
        )
        .err()
        .expect("refused")
        .to_string();
        assert!(e.contains("no triangles"), "{e}");
    }
}

/// `bench --case NAME --method NAME` times one cell in its own process and reports its peak
/// memory; an unknown case is named with the list of cases.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn bench_times_one_cell_alone() {
    let data = common::shared_data();
    let bench = |args: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .arg("bench")
            .args(args)
            .arg("--data")
            .arg(&data)
            .output()
            .unwrap()
    };
    let out = bench(&["--case", "bunny-35k", "--method", "mc"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let row = text
        .lines()
        .find(|l| l.starts_with("| bunny-35k | 35947 |"))
        .expect("the cell's row");
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    // | mesh | vertices | SMS | MC | MS | SI |: only MC was measured.
    assert_eq!(cells[3], "–", "{row}");
    assert!(cells[4].contains("(0.5, "), "{row}");
    assert_eq!((cells[5], cells[6]), ("–", "–"), "{row}");
    assert!(
        text.contains("Peak memory of the cell bunny-35k / mc:"),
        "{text}"
    );
    assert!(
        !text.contains("SMI format A parse"),
        "one cell, nothing else"
    );
    let out = bench(&["--case", "nope"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("bunny-35k, horse-48k"),
        "{err}"
    );
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn the_stimulus_bench_cell_reports_its_frames_and_its_own_peak_memory() {
    let data = common::shared_data();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["bench", "--child", "--data"])
        .arg(&data)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cell: serde_json::Value = serde_json::from_str(text.trim()).expect("one JSON line");
    assert_eq!(cell["frames"], 1440, "{cell}");
    assert_eq!(cell["triangles"], 99976, "{cell}");
    assert_eq!(
        cell["rendered"].as_u64().unwrap() + cell["reused"].as_u64().unwrap(),
        1440,
        "{cell}"
    );
    // Measured in its own process (the parent also holds the SMI parse bench's 284 MB).
    let peak = cell["peak_rss_mb"].as_f64().unwrap();
    assert!(peak > 20.0 && peak < 1000.0, "{cell}");
}

//! Feature points (paper §5.5) and the Dutagaci et al. 2012 evaluation, on meshes and point
//! sets built so the answer is known.
mod common;

use glam::DVec3;
use meshgaze::experiments::features::{
    evaluate, feature_points, voted_ground_truth, GeodesicGraph,
};
use meshgaze::mesh::test_meshes::icosphere;
use meshgaze::mesh::Mesh;

fn great_circle(p: DVec3, q: DVec3) -> f64 {
    p.normalize().dot(q.normalize()).clamp(-1.0, 1.0).acos()
}

/// Error against the exact great-circle distance on a unit sphere, per Steiner count.
#[test]
fn geodesics_on_a_sphere_are_close_to_great_circles() {
    let sphere = icosphere(1.0, 4); // 2,562 vertices
    let mut mean_errors = Vec::new();
    for steiner in [0, 1, 3] {
        let g = GeodesicGraph::new(&sphere, steiner);
        let d = g.all_distances_from(0);
        let (mut sum, mut worst, mut n) = (0.0, 0.0f64, 0);
        for (v, &dv) in d.iter().enumerate() {
            let exact = great_circle(sphere.positions[0], sphere.positions[v]);
            if !(0.2..=2.5).contains(&exact) {
                continue; // relative error is ill-defined near the source and the antipode
            }
            let rel = (dv - exact).abs() / exact;
            sum += rel;
            worst = worst.max(rel);
            n += 1;
        }
        let mean = sum / n as f64;
        eprintln!(
            "steiner {steiner}: mean relative error {mean:.4}, worst {worst:.4} over {n} vertices"
        );
        mean_errors.push((mean, worst));
    }
    // Plain edge Dijkstra overestimates by several percent; Steiner points fix most of it.
    assert!(mean_errors[0].0 > 0.03, "{mean_errors:?}");
    assert!(
        mean_errors[2].0 < 0.015 && mean_errors[2].1 < 0.04,
        "{mean_errors:?}"
    );
    assert!(mean_errors[2].0 < mean_errors[1].0 && mean_errors[1].0 < mean_errors[0].0);
    // Bounded queries give the same distances as unbounded ones, within the bound.
    let g = GeodesicGraph::new(&sphere, 3);
    let all = g.all_distances_from(17);
    for (v, d) in g.distances_from(17, 0.5) {
        assert!(d <= 0.5 && (d - all[v]).abs() < 1e-12);
    }
    assert_eq!(
        g.distances_from(17, 0.5).len(),
        all.iter().filter(|d| **d <= 0.5).count()
    );
    // Double sweep on a sphere: the antipodal distance, π up to the discretization.
    let dm = g.diameter_double_sweep();
    assert!(
        (dm - std::f64::consts::PI).abs() < 0.03 * std::f64::consts::PI,
        "{dm}"
    );
}

/// Saliency made of Gaussian bumps at chosen vertices.
fn bumps(mesh: &Mesh, centres: &[(usize, f64)], width: f64) -> Vec<f64> {
    mesh.positions
        .iter()
        .map(|p| {
            centres
                .iter()
                .map(|&(c, a)| {
                    let d = great_circle(*p, mesh.positions[c]);
                    a * (-d * d / (2.0 * width * width)).exp()
                })
                .sum()
        })
        .collect()
}

fn nearest_vertex(mesh: &Mesh, dir: DVec3) -> usize {
    let dir = dir.normalize();
    (0..mesh.positions.len())
        .max_by(|&a, &b| {
            mesh.positions[a]
                .normalize()
                .dot(dir)
                .total_cmp(&mesh.positions[b].normalize().dot(dir))
        })
        .unwrap()
}

#[test]
fn feature_points_are_the_separated_peaks_in_saliency_order() {
    let sphere = icosphere(1.0, 4);
    let a = nearest_vertex(&sphere, DVec3::X);
    let b = nearest_vertex(&sphere, DVec3::Y);
    let c = nearest_vertex(&sphere, -DVec3::Z);
    // A fourth strong peak 0.3 rad from `a`: inside a separation of 0.5, so rejected.
    let near_a = nearest_vertex(&sphere, DVec3::new(1.0, 0.0, 0.31));
    // Two weak peaks: below the mean of the local maxima, so never candidates.
    let weak1 = nearest_vertex(&sphere, -DVec3::X);
    let weak2 = nearest_vertex(&sphere, -DVec3::Y);
    let values = bumps(
        &sphere,
        &[
            (a, 1.0),
            (b, 0.95),
            (c, 0.9),
            (near_a, 0.85),
            (weak1, 0.1),
            (weak2, 0.1),
        ],
        0.08,
    );
    let g = GeodesicGraph::new(&sphere, 3);
    let maxima = meshgaze::experiments::features::local_maxima(&sphere, &values);
    for v in [a, b, c, near_a, weak1, weak2] {
        assert!(maxima.contains(&v), "{v} is a local maximum");
    }
    let with_sep = feature_points(&sphere, &values, &g, 0.5);
    let got: Vec<usize> = with_sep.iter().map(|p| p.vertex).collect();
    assert_eq!(got, vec![a, b, c]);
    // With a small separation the fourth strong peak comes back, last; the weak never do.
    let small = feature_points(&sphere, &values, &g, 0.1);
    let got: Vec<usize> = small.iter().map(|p| p.vertex).collect();
    assert_eq!(got, vec![a, b, c, near_a]);
}

#[test]
fn the_dutagaci_measures_on_a_constructed_case() {
    let sphere = icosphere(1.0, 4);
    let g = GeodesicGraph::new(&sphere, 3);
    let d_m = std::f64::consts::PI;
    let a = nearest_vertex(&sphere, DVec3::X);
    let b = nearest_vertex(&sphere, DVec3::Y);
    let b2 = nearest_vertex(&sphere, DVec3::new(0.03, 1.0, 0.0));
    let c = nearest_vertex(&sphere, -DVec3::Z);
    let far = nearest_vertex(&sphere, DVec3::Z);
    // A: all four subjects; B: two subjects (slightly apart); C: one subject only.
    let marks = vec![vec![a, b], vec![a, b2], vec![a, c], vec![a]];
    let truth = voted_ground_truth(&g, &marks, 0.03, 2, d_m);
    assert_eq!(truth.len(), 2, "{truth:?}");
    assert_eq!((truth[0].vertex, truth[0].subjects), (a, 4));
    assert!(truth[1].vertex == b || truth[1].vertex == b2);
    assert_eq!(truth[1].subjects, 2);
    // With n = 1, C becomes ground truth too.
    assert_eq!(voted_ground_truth(&g, &marks, 0.03, 1, d_m).len(), 3);
    // Detections: on A, next to A (one-to-one: cannot match A again), at C (not truth), far.
    let next_to_a = nearest_vertex(&sphere, DVec3::new(1.0, 0.05, 0.0));
    assert_ne!(next_to_a, a);
    let detected = vec![a, next_to_a, c, far];
    let e = evaluate(&g, &truth, &detected, 0.05, d_m);
    assert_eq!(e.matched, 1);
    assert!((e.recall - 0.5).abs() < 1e-12);
    assert!((e.precision - 0.25).abs() < 1e-12);
    assert!((e.false_negative_error - 0.5).abs() < 1e-12);
    assert!((e.false_positive_error - 0.75).abs() < 1e-12);
    assert!((e.weighted_miss_error - (1.0 - 4.0 / 6.0)).abs() < 1e-12);
    assert!((e.f_measure - 2.0 * 0.25 * 0.5 / 0.75).abs() < 1e-12);
    // A detection at B's place matches B once the tolerance reaches it.
    let detected = vec![a, b];
    let at_zero = evaluate(&g, &truth, &detected, 0.0, d_m);
    let wide = evaluate(&g, &truth, &detected, 0.05, d_m);
    assert!(
        at_zero.matched >= 1 && wide.matched == 2,
        "{at_zero:?} {wide:?}"
    );
    assert!((wide.weighted_miss_error).abs() < 1e-12);
}

#[test]
fn the_features_command_evaluates_against_mark_files() {
    let dir = std::env::temp_dir().join(format!("meshgaze-features-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    std::fs::write(dir.join("s1.txt"), "# subject 1\nvertex\n10\n200\n").unwrap();
    std::fs::write(dir.join("s2.txt"), "10\n201\n").unwrap();
    std::fs::write(dir.join("bad.txt"), "10\nten\n").unwrap();
    let run = |marks: &[&str]| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"));
        c.args(["features", "--method", "mc", "--quiet", "-o"])
            .arg(dir.join("out/bunny"))
            .arg(&mesh)
            .arg("--marks");
        for m in marks {
            c.arg(dir.join(m));
        }
        c.output().unwrap()
    };
    let ok = run(&["s1.txt", "s2.txt"]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    let eval = std::fs::read_to_string(dir.join("out/bunny.eval.csv")).unwrap();
    assert_eq!(eval.lines().count(), 1 + 13, "α = 0, 0.01, …, 0.12");
    assert!(dir.join("out/bunny.eval.png").exists() && dir.join("out/bunny.json").exists());
    let bad = run(&["s1.txt", "bad.txt"]);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("bad.txt:2:1: expected a vertex index, found `ten`"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

//! Sparse metric-based saliency: the properties the method must have, on the bundled bunny.
mod common;

use std::process::Command;
use std::sync::OnceLock;

use glam::DVec3;
use meshgaze::experiments::corruption::add_normal_noise;
use meshgaze::mesh::geometry::{pearson, BoundingBox, Normalization};
use meshgaze::mesh::transfer_by_nearest_vertex;
use meshgaze::mesh::Mesh;
use meshgaze::progress::Silent;
use meshgaze::saliency::sms::descriptor_metric::{
    DenseSymmetric, DescriptorMetric, SymmetricOperator,
};
use meshgaze::saliency::sms::descriptors::Descriptors;
use meshgaze::saliency::sms::descriptors::{
    compute_descriptors, DescriptorParams, ExactField, GridField, GridParams,
};
use meshgaze::saliency::sms::truncated_power::{
    principal_eigenpair, top_k_indices, truncated_power, PowerParams,
};
use meshgaze::saliency::{sparse_metric_saliency, SmsExtras, SmsParams};
use proptest::prelude::*;

fn sms(mesh: &Mesh) -> Vec<f64> {
    let r = sparse_metric_saliency(mesh, &SmsParams::default(), SmsExtras::default(), &Silent)
        .expect("SMS runs");
    assert!(
        r.report.truncated_power.converged,
        "TPower did not converge: {:?}",
        r.report.truncated_power
    );
    assert!(r.report.principal_eigenvalue.converged);
    r.vertex_saliency
}

fn bunny_map() -> &'static Vec<f64> {
    static MAP: OnceLock<Vec<f64>> = OnceLock::new();
    MAP.get_or_init(|| sms(&common::bunny()))
}

/// The triangles of `mesh` within `reach` of `p`: the exact field beyond them is < 1e-14.
fn crop(mesh: &Mesh, p: DVec3, reach: f64) -> Mesh {
    let triangles = mesh
        .triangles
        .iter()
        .copied()
        .filter(|t| {
            let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
            (p - meshgaze::mesh::geometry::closest_point_on_triangle(p, a, b, c)).length() <= reach
        })
        .collect();
    Mesh {
        positions: mesh.positions.clone(),
        triangles,
    }
}

fn relative_difference(a: &[f64], b: &[f64]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt();
    let den: f64 = a.iter().map(|x| x * x).sum::<f64>().sqrt();
    num / den
}

#[test]
fn band_norm_descriptors_are_rotation_invariant() {
    let bunny = common::bunny();
    let norm = Normalization::of_mesh(&bunny, BoundingBox::Oriented);
    let mesh = norm.normalized_mesh(&bunny);
    let params = DescriptorParams::default();
    let sigma = 0.017; // about the grid's Gaussian width at 256³ for this mesh
    let rot = common::rotation(0.7, -1.1, 2.3);
    let rotated = common::transformed(&mesh, |p| rot * p);
    let none = |_: usize| {};
    let mut worst_exact: f64 = 0.0;
    for v in [100usize, 2500, 5000, 7777] {
        let p = mesh.positions[v];
        let reach = params.max_radius() + 8.0 * sigma;
        let local = crop(&mesh, p, reach);
        let local_rot = crop(&rotated, rot * p, reach);
        let f = compute_descriptors(
            &ExactField {
                mesh: &local,
                sigma,
            },
            &[p],
            &params,
            &none,
        );
        let g = compute_descriptors(
            &ExactField {
                mesh: &local_rot,
                sigma,
            },
            &[rot * p],
            &params,
            &none,
        );
        let d = relative_difference(&f.data, &g.data);
        worst_exact = worst_exact.max(d);
        assert!(
            d <= 1e-3,
            "vertex {v}: exact-field descriptors differ by {d:.2e} relative after rotation"
        );
    }
    // The production grid adds interpolation error that depends on orientation; measured, not
    // hidden. Its bound is looser because trilinear sampling is not rotation invariant.
    let grid = GridField::build(&mesh, params.max_radius(), GridParams::default()).unwrap();
    let grid_rot = GridField::build(&rotated, params.max_radius(), GridParams::default()).unwrap();
    let pts: Vec<DVec3> = (0..200).map(|i| mesh.positions[i * 40]).collect();
    let pts_rot: Vec<DVec3> = pts.iter().map(|p| rot * *p).collect();
    let f = compute_descriptors(&grid, &pts, &params, &none);
    let g = compute_descriptors(&grid_rot, &pts_rot, &params, &none);
    let d = relative_difference(&f.data, &g.data);
    eprintln!("descriptor change under rotation: exact field {worst_exact:.2e}, 256³ grid {d:.2e} (relative L2)");
    // Measured 2.36e-3 at this rotation (docs/sms.md); the bound leaves 2x for other machines'
    // float summation orders, not for a different interpolation.
    assert!(
        d < 5e-3,
        "grid descriptors differ by {d} relative after rotation"
    );
}

/// The adaptive quadrature (fewer rings on small shells) against 24 rings on every shell, on
/// the production grid: descriptors within 1e-3 relative (the rotation-aliasing budget of the
/// exact field) and the map within 1e-3 of the fixed rule's everywhere.
#[test]
fn adaptive_quadrature_stays_within_its_error_bound() {
    use meshgaze::saliency::sms::descriptors::QuadratureRule;
    let bunny = common::bunny();
    let norm = Normalization::of_mesh(&bunny, BoundingBox::Oriented);
    let mesh = norm.normalized_mesh(&bunny);
    let fixed = DescriptorParams {
        quadrature: QuadratureRule::Fixed,
        ..DescriptorParams::default()
    };
    let adaptive = DescriptorParams::default();
    assert_eq!(adaptive.quadrature, QuadratureRule::Adaptive);
    let grid = GridField::build(&mesh, fixed.max_radius(), GridParams::default()).unwrap();
    // Fewer rings where they cannot matter, never more than the fixed rule's.
    let rings: Vec<usize> = [0.02, 0.1]
        .iter()
        .map(|&s| adaptive.rings_for(adaptive.shell_radius(s, 0), Some(grid.h)))
        .collect();
    assert!(rings[0] < 24 && rings[1] <= 24, "{rings:?}");
    let pts: Vec<DVec3> = (0..400).map(|i| mesh.positions[i * 20]).collect();
    let none = |_: usize| {};
    let f = compute_descriptors(&grid, &pts, &fixed, &none);
    let a = compute_descriptors(&grid, &pts, &adaptive, &none);
    let worst = (0..pts.len())
        .map(|i| relative_difference(f.row(i), a.row(i)))
        .fold(0.0, f64::max);
    eprintln!("adaptive vs fixed quadrature: worst descriptor {worst:.2e} relative");
    assert!(worst <= 1e-3, "descriptor differs by {worst:.2e}");

    let run = |q| {
        let mut p = SmsParams::default();
        p.descriptor.quadrature = q;
        sparse_metric_saliency(&bunny, &p, SmsExtras::default(), &Silent)
            .unwrap()
            .vertex_saliency
    };
    let (mf, ma) = (run(QuadratureRule::Fixed), run(QuadratureRule::Adaptive));
    let max_abs = mf
        .iter()
        .zip(&ma)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    eprintln!("adaptive vs fixed quadrature: map max |Δ| {max_abs:.2e}");
    assert!(max_abs <= 1e-3, "maps differ by {max_abs:.2e}");
}

fn random_descriptors(n: usize, d: usize, seed: u64) -> Descriptors {
    let mut s = seed | 1;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s % 10_000) as f64 / 10_000.0
    };
    Descriptors {
        n,
        dim: d,
        data: (0..n * d).map(|_| next()).collect(),
    }
}

fn explicit_metric(f: &Descriptors) -> DenseSymmetric {
    let metric = DescriptorMetric::new(f);
    let mut data = vec![0.0; f.n * f.n];
    for i in 0..f.n {
        for j in 0..f.n {
            data[i * f.n + j] = metric.entry(i, j);
        }
    }
    DenseSymmetric { n: f.n, data }
}

#[test]
fn matrix_free_product_equals_explicit_matrix() {
    let f = random_descriptors(700, 37, 3);
    let x: Vec<f64> = (0..700)
        .map(|i| ((i * 37 % 101) as f64 - 50.0) / 50.0)
        .collect();
    let mut y_free = vec![0.0; 700];
    let mut y_dense = vec![0.0; 700];
    DescriptorMetric::new(&f).apply(&x, &mut y_free);
    explicit_metric(&f).apply(&x, &mut y_dense);
    let scale = y_dense.iter().map(|v| v.abs()).fold(0.0, f64::max);
    for (a, b) in y_free.iter().zip(&y_dense) {
        assert!((a - b).abs() <= 1e-10 * scale, "{a} vs {b}");
    }
}

/// Largest eigenvalue of a small PSD matrix by power iteration.
fn top_eigenvalue(m: &[f64], n: usize) -> f64 {
    let mut x = vec![1.0 / (n as f64).sqrt(); n];
    let mut lambda = 0.0;
    for _ in 0..5000 {
        let y: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|j| m[i * n + j] * x[j]).sum())
            .collect();
        let norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        let l: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
        x = y.iter().map(|v| v / norm).collect();
        if (l - lambda).abs() < 1e-14 * l {
            break;
        }
        lambda = l;
    }
    lambda
}

/// Brute force: the best support of size k and its objective xᵀ(M + shift)x.
fn brute_force(m: &DenseSymmetric, shift: f64, k: usize) -> (Vec<usize>, f64) {
    let n = m.n;
    let mut best = (Vec::new(), f64::NEG_INFINITY);
    for mask in 0u32..(1 << n) {
        if mask.count_ones() as usize != k {
            continue;
        }
        let s: Vec<usize> = (0..n).filter(|i| mask & (1 << i) != 0).collect();
        let mut sub = vec![0.0; k * k];
        for (a, &i) in s.iter().enumerate() {
            for (b, &j) in s.iter().enumerate() {
                sub[a * k + b] = m.data[i * n + j] + if i == j { shift } else { 0.0 };
            }
        }
        let v = top_eigenvalue(&sub, k);
        if v > best.1 {
            best = (s, v);
        }
    }
    best
}

#[test]
fn truncated_power_recovers_brute_force_optimum_on_planted_instances() {
    for (trial, (n, k)) in [(10usize, 3usize), (12, 4), (14, 5), (14, 3), (13, 6)]
        .into_iter()
        .enumerate()
    {
        // Background points near one descriptor; k planted points far away and far apart.
        let noise = random_descriptors(n, 6, 11 + trial as u64);
        let mut f = noise.clone();
        for v in f.data.iter_mut() {
            *v *= 0.05;
        }
        let planted: Vec<usize> = (0..k).map(|i| (i * 3 + trial) % n).collect();
        let mut distinct = planted.clone();
        distinct.sort();
        distinct.dedup();
        assert_eq!(distinct.len(), k, "planted indices must be distinct");
        for (c, &i) in planted.iter().enumerate() {
            f.data[i * 6 + c % 6] += 3.0 + c as f64;
        }
        let dense = explicit_metric(&f);
        let (eig, v1) = principal_eigenpair(&dense, PowerParams::default());
        let (report, x) = truncated_power(&dense, eig.value, &v1, k, PowerParams::default());
        let (best_support, best_value) = brute_force(&dense, eig.value, k);
        let found: Vec<usize> = (0..n).filter(|&i| x[i] != 0.0).collect();
        let mut planted_sorted = planted.clone();
        planted_sorted.sort();
        assert_eq!(
            best_support, planted_sorted,
            "the planted support is the brute-force optimum"
        );
        assert_eq!(found, best_support, "trial {trial}: TPower support");
        let value = report.objective + eig.value;
        assert!(
            (value - best_value).abs() <= 1e-9 * best_value,
            "{value} vs {best_value}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn truncated_power_ends_at_a_fixed_point(n in 3usize..60, d in 1usize..9, kf in 0.0f64..1.0, seed in any::<u64>()) {
        let f = random_descriptors(n, d, seed);
        let k = 1 + ((n - 1) as f64 * kf) as usize;
        let metric = DescriptorMetric::new(&f);
        let (eig, v1) = principal_eigenpair(&metric, PowerParams::default());
        let (report, x) = truncated_power(&metric, eig.value, &v1, k, PowerParams::default());
        // Convergence is not asserted: two nearly equal descriptors make the shifted block
        // almost degenerate and the values inside a fixed support creep for thousands of
        // iterations (reported as converged = false). The support must still be a fixed point.
        prop_assert!(x.iter().all(|v| *v >= 0.0), "negative entry");
        prop_assert!(x.iter().filter(|v| **v != 0.0).count() <= k);
        prop_assert!(report.objective >= report.start_objective - 1e-9 * report.start_objective.abs().max(1.0));
        // Fixed point: the support is the k largest entries of (M + λ1 I) x, up to ties.
        let mut s = vec![0.0; n];
        metric.apply(&x, &mut s);
        for (si, xi) in s.iter_mut().zip(&x) { *si += eig.value * xi; }
        let support: Vec<usize> = (0..n).filter(|&i| x[i] != 0.0).collect();
        let top = top_k_indices(&s, k);
        if support.len() == k && support != top {
            let kth = support.iter().map(|&i| s[i]).fold(f64::INFINITY, f64::min);
            let best_out = (0..n).filter(|i| !support.contains(i)).map(|i| s[i]).fold(f64::NEG_INFINITY, f64::max);
            prop_assert!(best_out - kth <= 1e-9 * kth.abs().max(1.0), "not a fixed point: {best_out} > {kth}");
        }
    }
}

fn report_pearson(what: &str, r: f64, floor: f64) {
    eprintln!("SMS map agreement, {what}: Pearson {r:.4} (required >= {floor})");
    assert!(r >= floor, "{what}: Pearson {r:.4} < {floor}");
}

#[test]
fn map_is_invariant_to_rotation_translation_and_scale() {
    let bunny = common::bunny();
    let base = bunny_map();
    for (what, mesh) in common::rigid_and_scaled_copies(&bunny) {
        report_pearson(what, pearson(base, &sms(&mesh)), 0.98);
    }
}

#[test]
fn map_survives_noise_and_decimation() {
    let bunny = common::bunny();
    let base = bunny_map();
    let noisy = add_normal_noise(&bunny, 0.2, 42);
    report_pearson("20% normal noise", pearson(base, &sms(&noisy)), 0.8);
    // Stanford's own decimation of the same scan (8,171 -> 1,889 vertices).
    let coarse = common::bunny_res3();
    let coarse_map = sms(&coarse);
    let transferred = transfer_by_nearest_vertex(&coarse.positions, &coarse_map, &bunny.positions);
    report_pearson(
        "decimated to 1,889 vertices",
        pearson(base, &transferred),
        0.8,
    );
}

#[test]
fn same_seed_gives_byte_identical_csv_on_any_thread_count() {
    let dir = std::env::temp_dir().join(format!("meshgaze-det-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    let run = |name: &str, threads: &str, seed: &str| {
        let out = dir.join(name);
        let status = Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .args(["saliency", "--quiet", "--seed", seed, "-o"])
            .arg(&out)
            .arg(&mesh)
            .env("RAYON_NUM_THREADS", threads)
            .status()
            .unwrap();
        assert!(status.success());
        (
            common::read_file(&out.with_extension("csv")),
            common::read_file(&out.with_extension("ply")),
        )
    };
    let a = run("a", "2", "5");
    let b = run("b", "2", "5");
    let c = run("c", "1", "5");
    let d = run("d", "2", "6");
    assert!(a == b, "two runs with the same seed differ");
    assert!(a == c, "1 thread and 2 threads differ");
    assert!(a.0 != d.0, "a different seed should give a different map");
    let text = String::from_utf8(a.0).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("vertex,saliency"));
    let values: Vec<f64> = lines
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(values.len(), 1889);
    assert!(values.iter().all(|v| (0.0..=1.0).contains(v)));
    assert!(values.contains(&1.0) && values.contains(&0.0));
}

/// The baselines sum kd-tree neighbourhoods in traversal order, and SI's eigendecomposition
/// always splits its work in two: still the same bytes on any thread count.
#[test]
fn baselines_are_byte_identical_on_any_thread_count() {
    let dir = std::env::temp_dir().join(format!("meshgaze-det-ms-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = common::repo_root().join("stimuli/meshes/bun_zipper_res2.ply");
    for method in ["ms", "mc", "si"] {
        let run = |threads: &str| {
            let out = dir.join(format!("{method}_{threads}"));
            let status = Command::new(env!("CARGO_BIN_EXE_meshgaze"))
                .args(["saliency", "--quiet", "--method", method, "-o"])
                .arg(&out)
                .arg(&mesh)
                .env("RAYON_NUM_THREADS", threads)
                .status()
                .unwrap();
            assert!(status.success());
            common::read_file(&out.with_extension("csv"))
        };
        let two = run("2");
        assert!(run("1") == two, "{method}: 1 and 2 threads differ");
        assert!(run("4") == two, "{method}: 2 and 4 threads differ");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

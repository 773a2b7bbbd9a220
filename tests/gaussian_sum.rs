//! The clustered Gaussian sums that MS and SI use against the exact sums they approximate.
mod common;

use std::time::Instant;

use meshgaze::mesh::clustered_gaussian_average::GaussianSum;
use meshgaze::mesh::geometry::pearson;
use meshgaze::mesh::{load_mesh, Mesh};
use meshgaze::saliency::lee_mesh_saliency::{lee_mesh_saliency, LeeParams};

/// Pearson, largest and mean absolute difference of two maps.
fn differences(exact: &[f64], fast: &[f64]) -> (f64, f64, f64) {
    let abs: Vec<f64> = exact.iter().zip(fast).map(|(a, b)| (a - b).abs()).collect();
    let max = abs.iter().copied().fold(0.0, f64::max);
    let mean = abs.iter().sum::<f64>() / abs.len() as f64;
    (pearson(exact, fast), max, mean)
}

/// MS with the exact and the clustered sums: (Pearson, max |Δ|, mean |Δ|) of the two maps.
fn compare_ms(name: &str, mesh: &Mesh) -> (f64, f64, f64) {
    let cells = match LeeParams::default().gaussian_sum {
        GaussianSum::Clustered { cells_per_sigma } => cells_per_sigma,
        GaussianSum::Exact => panic!("MS defaults to the clustered sum"),
    };
    let exact_params = LeeParams {
        gaussian_sum: GaussianSum::Exact,
        ..LeeParams::default()
    };
    let t = Instant::now();
    let (exact, _) = lee_mesh_saliency(mesh, &exact_params);
    let te = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let (fast, _) = lee_mesh_saliency(mesh, &LeeParams::default());
    let tf = t.elapsed().as_secs_f64();
    let (r, max, mean) = differences(&exact, &fast);
    eprintln!("MS {name}, {cells} cells per σ: Pearson {r:.6}, max |Δ| {max:.2e}, mean |Δ| {mean:.2e} (exact {te:.2} s, clustered {tf:.2} s)");
    (r, max, mean)
}

/// SI with the exact and the clustered smoothing: (max |Δ|, mean |Δ|).
fn compare_si(name: &str, mesh: &Mesh) -> (f64, f64) {
    use meshgaze::saliency::spectral_irregularity::{spectral_irregularity, SpectralParams};
    let exact = spectral_irregularity(
        mesh,
        &SpectralParams {
            smoothing_sum: GaussianSum::Exact,
            ..SpectralParams::default()
        },
    )
    .unwrap()
    .0;
    let fast = spectral_irregularity(mesh, &SpectralParams::default())
        .unwrap()
        .0;
    let (r, max, mean) = differences(&exact, &fast);
    eprintln!("SI {name}: Pearson {r:.8}, max |Δ| {max:.2e}, mean |Δ| {mean:.2e}");
    (max, mean)
}

/// SI with the f64 eigensolver and the default refined f32 one: (Pearson, max |Δ|, mean |Δ|).
fn compare_si_eigensolver(name: &str, mesh: &Mesh) -> (f64, f64, f64) {
    use meshgaze::saliency::laplacian_spectrum::Eigensolver;
    use meshgaze::saliency::spectral_irregularity::{spectral_irregularity, SpectralParams};
    let t = Instant::now();
    let double = spectral_irregularity(
        mesh,
        &SpectralParams {
            eigensolver: Eigensolver::Double,
            ..SpectralParams::default()
        },
    )
    .unwrap()
    .0;
    let td = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let refined = spectral_irregularity(mesh, &SpectralParams::default())
        .unwrap()
        .0;
    let tr = t.elapsed().as_secs_f64();
    let (r, max, mean) = differences(&double, &refined);
    eprintln!("SI {name}, f64 vs refined f32 eigenpairs: Pearson {r:.8}, max |Δ| {max:.2e}, mean |Δ| {mean:.2e} (f64 {td:.2} s, refined {tr:.2} s)");
    (r, max, mean)
}

/// The error bounds docs/baselines.md states, on the bundled bunny.
#[test]
fn ms_and_si_stay_within_their_stated_error_of_the_exact_sums() {
    let bunny = load_mesh(&common::repo_root().join("stimuli/meshes/bun_zipper_res2.ply"))
        .unwrap()
        .0;
    assert_within_stated_error("bundled bunny", &bunny);
}

/// The same bounds on the full bunny and the 50k armadillo of the shared data.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn ms_and_si_stay_within_their_stated_error_on_the_shared_meshes() {
    let data = common::shared_data();
    for (name, path) in [
        ("bunny", "meshes/classic/stanford_bunny/bun_zipper.ply"),
        (
            "armadillo",
            "meshes/classic/decimated_profactor_50k/armadillo.obj",
        ),
    ] {
        assert_within_stated_error(name, &load_mesh(&data.join(path)).unwrap().0);
    }
}

fn assert_within_stated_error(name: &str, mesh: &meshgaze::mesh::Mesh) {
    let (r, max, mean) = compare_ms(name, mesh);
    assert!(
        r >= 0.9999 && mean <= 1e-3 && max <= 2e-2,
        "MS on {name}: Pearson {r}, max {max}, mean {mean}"
    );
    let (max, mean) = compare_si(name, mesh);
    assert!(
        max <= 1e-3 && mean <= 2e-4,
        "SI on {name}: max {max}, mean {mean}"
    );
    let (r, max, mean) = compare_si_eigensolver(name, mesh);
    assert!(
        r >= 0.99999 && max <= 1.5e-2 && mean <= 1e-3,
        "SI's eigensolvers on {name}: Pearson {r}, max {max}, mean {mean}"
    );
}

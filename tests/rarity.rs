//! Known answers for the global-rarity competitors (SRI, GR, MR): a field of identical bumps
//! with one odd one out, a featureless sphere, invariance to pose and scale, determinism, and
//! broken meshes.
mod common;

use glam::DVec3;
use meshgaze::mesh::geometry::pearson;
use meshgaze::mesh::test_meshes::icosphere;
use meshgaze::mesh::Mesh;
use meshgaze::progress::Silent;
use meshgaze::saliency::{compute_saliency, Method, MethodOutput, SmsParams};

const RARITY: [Method; 3] = [Method::Sri, Method::Gr, Method::Mr];

fn run(method: Method, mesh: &Mesh) -> MethodOutput {
    compute_saliency(method, mesh, &SmsParams::default(), &Silent)
        .unwrap_or_else(|e| panic!("{}: {e}", method.name()))
}

/// A 99 × 99 height field on the unit square carrying twelve Gaussian features (σ 0.04,
/// 0.25 apart): eleven bumps of height 0.05 and, at `odd`, a dent of the same depth. A bump
/// and a dent are mirror images, so their curvature magnitudes are the same; only their
/// shape (which way they point) tells them apart.
fn bump_field(odd: usize) -> (Mesh, Vec<DVec3>) {
    let k = 98;
    let centres: Vec<DVec3> = (0..12)
        .map(|i| {
            DVec3::new(
                0.125 + 0.25 * (i % 4) as f64,
                0.2 + 0.3 * (i / 4) as f64,
                0.0,
            )
        })
        .collect();
    let height = |x: f64, y: f64| {
        centres
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let sign = if i == odd { -1.0 } else { 1.0 };
                let d2 = (x - c.x).powi(2) + (y - c.y).powi(2);
                sign * 0.05 * (-d2 / (2.0 * 0.04 * 0.04)).exp()
            })
            .sum::<f64>()
    };
    let mut positions = Vec::new();
    for j in 0..=k {
        for i in 0..=k {
            let (x, y) = (i as f64 / k as f64, j as f64 / k as f64);
            positions.push(DVec3::new(x, y, height(x, y)));
        }
    }
    let id = |i: usize, j: usize| (j * (k + 1) + i) as u32;
    let mut triangles = Vec::new();
    for j in 0..k {
        for i in 0..k {
            triangles.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            triangles.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    (
        Mesh {
            positions,
            triangles,
        },
        centres,
    )
}

/// Mean value over the vertices within 0.05 (in the plane) of each feature centre.
fn feature_means(mesh: &Mesh, values: &[f64], centres: &[DVec3]) -> Vec<f64> {
    centres
        .iter()
        .map(|c| {
            let near: Vec<f64> = mesh
                .positions
                .iter()
                .zip(values)
                .filter(|(p, _)| (p.x - c.x).hypot(p.y - c.y) < 0.05)
                .map(|(_, v)| *v)
                .collect();
            near.iter().sum::<f64>() / near.len() as f64
        })
        .collect()
}

/// Mean value over the vertices at least 0.15 (in the plane) from every feature centre.
fn ground_mean(mesh: &Mesh, values: &[f64], centres: &[DVec3]) -> f64 {
    let far: Vec<f64> = mesh
        .positions
        .iter()
        .zip(values)
        .filter(|(p, _)| centres.iter().all(|c| (p.x - c.x).hypot(p.y - c.y) >= 0.15))
        .map(|(_, v)| *v)
        .collect();
    far.iter().sum::<f64>() / far.len() as f64
}

#[test]
fn global_rarity_methods_single_out_the_odd_feature_and_curvature_does_not() {
    let odd = 5;
    let (mesh, centres) = bump_field(odd);
    for method in RARITY.into_iter().chain([Method::Mc]) {
        let map = run(method, &mesh).values;
        let means = feature_means(&mesh, &map, &centres);
        let bumps: Vec<f64> = (0..12).filter(|&i| i != odd).map(|i| means[i]).collect();
        let highest_bump = bumps.iter().cloned().fold(f64::MIN, f64::max);
        let lowest_bump = bumps.iter().cloned().fold(f64::MAX, f64::min);
        eprintln!(
            "{}: dent {:.3}, bumps {:.3}..{:.3}",
            method.name(),
            means[odd],
            lowest_bump,
            highest_bump
        );
        if method == Method::Mr {
            // MR ranks patches by how unlike the background (the least distinct patches) they
            // are, and in a k-nearest-neighbour graph many alike bumps reinforce each other
            // while a lone dent links to the flat ground: measured dent 0.967 against bumps
            // 0.991..0.992, so MR does not single out the odd feature (docs/baselines.md). What
            // it must do is lift every feature far above the flat ground.
            let ground = ground_mean(&mesh, &map, &centres);
            eprintln!("mr: flat ground {ground:.3}");
            assert!(
                means.iter().all(|&m| m > ground + 0.5),
                "mr: features {means:?} vs ground {ground:.3}"
            );
        } else if method == Method::Mc {
            // Mean-curvature magnitude is the same on a bump and its mirror image.
            assert!(
                means[odd] <= highest_bump * 1.05 && means[odd] >= lowest_bump * 0.95,
                "mc should rate the dent like the bumps: {means:?}"
            );
        } else {
            assert!(
                means[odd] > highest_bump,
                "{} should rate the odd feature above every bump: {means:?}",
                method.name()
            );
        }
    }
}

#[test]
/// Before the final rescale to [0, 1] (which stretches any variation to the full range), a
/// sphere's map must vary by under a fifth of what the same method's map varies on the bump
/// field, in the method's own units. Measured: SRI 0.0130 vs 0.0824 (what varies are the few
/// spots where simplifying 10,242 to 10,000 vertices left irregular triangles), GR 0.0075 vs
/// 0.1024. MR is not flat on a sphere (0.218 vs 0.199: ranking from the least distinct tenth
/// of near-identical patches marks the queries and their graph neighbours as background),
/// which docs/baselines.md reports; it is not asserted here.
fn a_sphere_gives_a_flat_map_before_rescaling() {
    // 10,242 vertices: about the working copy's density, so the smallest radius sees rings.
    let sphere = icosphere(1.0, 5);
    let (field, _) = bump_field(5);
    for method in [Method::Sri, Method::Gr] {
        let spread = |m: &Mesh| {
            run(method, m).report[1]["raw"]["std"]
                .as_f64()
                .expect("raw spread in the report")
        };
        let (flat, featured) = (spread(&sphere), spread(&field));
        eprintln!(
            "{}: raw standard deviation sphere {flat:.5}, bump field {featured:.5}",
            method.name()
        );
        assert!(
            flat < 0.2 * featured,
            "{}: sphere varies by {flat:.4} (bump field {featured:.4})",
            method.name()
        );
    }
}

#[test]
fn maps_are_invariant_to_rotation_translation_and_scale() {
    let bunny = common::bunny();
    for method in RARITY {
        let base = run(method, &bunny).values;
        for (what, mesh) in common::rigid_and_scaled_copies(&bunny) {
            let r = pearson(&base, &run(method, &mesh).values);
            eprintln!("{} {what}: Pearson {r:.4}", method.name());
            assert!(r >= 0.95, "{} {what}: Pearson {r:.4} < 0.95", method.name());
        }
    }
}

#[test]
fn broken_meshes_give_a_map_or_a_clear_error() {
    let (mut mesh, _) = bump_field(5);
    // A second component, a loose vertex, and a non-manifold fin on an interior edge.
    let shift = mesh.positions.len() as u32;
    let small = icosphere(0.1, 1);
    mesh.positions.extend(
        small
            .positions
            .iter()
            .map(|p| *p + DVec3::new(2.0, 0.5, 0.0)),
    );
    mesh.triangles
        .extend(small.triangles.iter().map(|t| t.map(|i| i + shift)));
    mesh.positions.push(DVec3::new(-1.0, -1.0, 3.0));
    let fin = mesh.positions.len() as u32;
    mesh.positions.push(DVec3::new(0.5, 0.5, 0.3));
    mesh.triangles.push([0, 1, fin]);
    for method in RARITY {
        let out = run(method, &mesh);
        assert_eq!(out.values.len(), mesh.positions.len());
        assert!(out
            .values
            .iter()
            .all(|v| v.is_finite() && (0.0..=1.0).contains(v)));
    }
    let empty = Mesh {
        positions: vec![DVec3::ZERO; 3],
        triangles: vec![],
    };
    for method in RARITY {
        let err = compute_saliency(method, &empty, &SmsParams::default(), &Silent)
            .err()
            .expect("no triangles: an error")
            .to_string();
        assert!(err.contains("no triangles"), "{err}");
    }
}

#[test]
fn same_seed_same_bytes_on_one_and_two_threads() {
    let mesh = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    let dir = std::env::temp_dir().join(format!("meshgaze-rarity-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for method in ["sri", "gr", "mr"] {
        let csv = |threads: &str, seed: &str| {
            let out = dir.join(format!("{method}-{threads}-{seed}"));
            let status = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
                .args(["saliency", "--quiet", "--method", method, "--set"])
                .arg(format!("{method}.seed={seed}"))
                .arg("-o")
                .arg(&out)
                .arg(&mesh)
                .env("RAYON_NUM_THREADS", threads)
                .status()
                .unwrap();
            assert!(status.success());
            common::read_file(&out.with_extension("csv"))
        };
        let a = csv("2", "1");
        assert!(a == csv("1", "1"), "{method}: 1 and 2 threads differ");
        assert!(a == csv("2", "1"), "{method}: two runs differ");
        assert!(a != csv("2", "9"), "{method}: the seed changes nothing");
    }
}

/// `--set METHOD.NAME=VALUE` is user input: whatever the text, it gives parameters or an
/// error that quotes the setting, never a panic; a valid setting changes only its own slot.
mod settings {
    use meshgaze::saliency::RarityParams;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn any_text_gives_parameters_or_an_error_naming_it(text in "\\PC{0,40}") {
            match RarityParams::default().with_settings(std::slice::from_ref(&text)) {
                Ok(_) => prop_assert!(text.contains('=') && text.contains('.')),
                Err(e) => prop_assert!(e.to_string().starts_with("--set"), "{e}"),
            }
        }

        #[test]
        fn a_valid_number_lands_in_its_slot(k in 1usize..500, method in 0usize..3) {
            let name = ["sri", "gr", "mr"][method];
            let p = RarityParams::default()
                .with_settings(&[format!("{name}.patches={k}")])
                .unwrap();
            let d = RarityParams::default();
            let got = [p.sri.patches, p.gr.patches, p.mr.patches];
            let want = [d.sri.patches, d.gr.patches, d.mr.patches];
            for (i, (g, w)) in got.iter().zip(want).enumerate() {
                prop_assert_eq!(*g, if i == method { k } else { w });
            }
        }
    }

    #[test]
    fn wrong_names_and_values_say_what_is_wrong() {
        let err = |s: &str| {
            RarityParams::default()
                .with_settings(&[s.to_string()])
                .unwrap_err()
                .to_string()
        };
        assert!(err("sri.most_similar").contains("expected METHOD.NAME=VALUE"));
        assert!(err("most_similar=3").contains("needs its method"));
        assert!(err("sms.samples=3").contains("not one of sri, gr, mr"));
        assert!(err("gr.bogus=1").contains("it has "));
        assert!(err("gr.patches=many").starts_with("--set gr.patches=many: invalid type"));
        let two = RarityParams::default()
            .with_settings(&["sri.seed=2".into(), "mr.alpha=high".into()])
            .unwrap_err()
            .to_string();
        assert!(two.starts_with("--set mr.alpha=high:"), "{two}");
    }
}

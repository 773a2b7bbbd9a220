//! The gaze model, the `up` and `centre` priors and the visibility-aware AUC.
mod common;

use std::path::Path;

use glam::DVec3;
use proptest::prelude::*;
use rand::seq::SliceRandom;
use rand::SeedableRng;

use meshgaze::gaze_model::surface_points::{parse_gaze_points, SurfacePoints};
use meshgaze::gaze_model::{train_model, training_object, TrainOptions, TrainingObject};
use meshgaze::mesh::{load_mesh, Mesh};
use meshgaze::protocol::Protocol;
use meshgaze::saliency::view_priors::{centre_prior, up_prior};
use meshgaze::scoring::auc::auc_judd;
use meshgaze::scoring::mesh_score::auc_judd_seen;
use meshgaze::stimulus::hold_views::hold_view_exposure;
use meshgaze::truth::{load_ground_truth, GroundTruth};

fn objects(points: &Path, names: &[&str], protocol: &Protocol) -> Vec<TrainingObject> {
    names
        .iter()
        .map(|n| {
            training_object(
                &points.join(format!("{n}.txt.gz")),
                "fixations-vr",
                protocol,
            )
            .unwrap()
        })
        .collect()
}

fn vr_mesh(data: &Path, name: &str) -> (Mesh, Vec<bool>) {
    let vr = data.join("fixations-vr");
    let (mesh, _) = load_mesh(&vr.join(format!("meshes/{name}.obj.gz"))).unwrap();
    let truth = load_ground_truth(
        &vr.join(format!("truth/{name}_objorder_time_bin.txt.gz")),
        mesh.positions.len(),
        0.05,
    )
    .unwrap();
    let GroundTruth::VertexMap(m) = truth else {
        panic!("per-vertex truth expected")
    };
    (mesh, m.positive)
}

/// Trained on ten other objects, the model predicts the held-out bunny far above chance;
/// trained on the same points with each object's flags shuffled, it is at chance. (A model
/// that could read the answer from somewhere other than the shape would pass the first
/// check and fail the second.)
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn held_out_bunny_is_predicted_and_shuffled_labels_teach_nothing() {
    let data = common::shared_data();
    let (protocol, _) = Protocol::builtin();
    let names = [
        "cow", "dinosaur", "horse", "hand", "igea", "cat", "dog", "wolf", "lion", "gorilla",
    ];
    let train = objects(&data.join("fixations-vr/points"), &names, &protocol);
    let options = TrainOptions {
        rows_per_object: 2000,
        params: meshgaze::gaze_model::boosted_trees::BoostParams {
            rounds: 80,
            ..Default::default()
        },
        ..TrainOptions::default()
    };
    let refs: Vec<&TrainingObject> = train.iter().collect();
    let model = train_model(&refs, &options, "hu2020").unwrap();
    let (bunny, positive) = vr_mesh(&data, "bunny");
    let predicted = model
        .predict(&SurfacePoints::of_mesh(&bunny), &protocol)
        .unwrap();
    let auc = auc_judd(&predicted, &positive, None);
    assert!(auc > 0.75, "held-out bunny AUC-Judd {auc:.3}");

    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
    let shuffled: Vec<TrainingObject> = train
        .iter()
        .map(|o| {
            let mut o = o.clone();
            o.labels.shuffle(&mut rng);
            o
        })
        .collect();
    let refs: Vec<&TrainingObject> = shuffled.iter().collect();
    let noise = train_model(&refs, &options, "hu2020").unwrap();
    let predicted = noise
        .predict(&SurfacePoints::of_mesh(&bunny), &protocol)
        .unwrap();
    let auc_noise = auc_judd(&predicted, &positive, None);
    assert!(
        (auc_noise - 0.5).abs() < 0.08,
        "shuffled-label model AUC-Judd {auc_noise:.3}"
    );
}

/// The committed built-in model is exactly what README's command trains (same bytes), so it
/// can be rebuilt from ../shared/data alone.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn the_builtin_model_is_what_the_documented_command_trains() {
    let data = common::shared_data();
    let out = std::env::temp_dir().join(format!("meshgaze-builtin-{}.json", std::process::id()));
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["train", "--quiet", "--dataset"])
        .arg(data.join("fixations-vr"))
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let retrained = std::fs::read_to_string(&out).unwrap();
    let committed =
        std::fs::read_to_string(common::repo_root().join("models/gaze-vr.json")).unwrap();
    let _ = std::fs::remove_file(&out);
    assert!(
        retrained == committed,
        "models/gaze-vr.json differs from a fresh `meshgaze train --dataset ../shared/data/fixations-vr`; retrain and commit it"
    );
}

/// `meshgaze score --quiet --method gaze` of `mesh` against `truth`, written to `out`.
fn score_gaze(mesh: &Path, truth: &Path, out: &Path) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["score", "--quiet", "--method", "gaze", "--mesh"])
        .arg(mesh)
        .arg("--truth")
        .arg(truth)
        .arg("-o")
        .arg(out)
        .output()
        .unwrap()
}

/// `score --method gaze` on an object the model was trained on is refused, naming why.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn scoring_the_model_on_its_own_training_object_is_refused() {
    let data = common::shared_data();
    let vr = data.join("fixations-vr");
    let out = std::env::temp_dir().join(format!("meshgaze-refuse-{}", std::process::id()));
    let o = score_gaze(
        &vr.join("meshes/bunny.obj.gz"),
        &vr.join("truth/bunny_objorder_time_bin.txt.gz"),
        &out,
    );
    assert!(!o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("training-set figure"), "{err}");
}

/// A renamed copy of a training mesh is refused by score and flagged by saliency: the model
/// recognises the object by the points it keeps of it, not by the file's name.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn a_renamed_training_mesh_is_refused_by_score_and_flagged_by_saliency() {
    let data = common::shared_data();
    let vr = data.join("fixations-vr");
    let dir = std::env::temp_dir().join(format!("meshgaze-renamed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // sofa: a quarter of its gaze points lie inside triangles, not on vertices.
    for object in ["bunny", "sofa"] {
        let copy = dir.join(format!("my-{object}-scan.obj.gz"));
        std::fs::copy(vr.join(format!("meshes/{object}.obj.gz")), &copy).unwrap();
        let o = score_gaze(
            &copy,
            &vr.join(format!("truth/{object}_objorder_time_bin.txt.gz")),
            &dir.join(format!("out-{object}")),
        );
        assert!(!o.status.success(), "{object}: a renamed copy was scored");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!("training object `{object}`"))
                && err.contains("training-set figure"),
            "{err}"
        );
        // Its map is written, with a warning and the object named in the sidecar.
        let prefix = dir.join(format!("map-{object}"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .args(["saliency", "--quiet", "--method", "gaze"])
            .arg(&copy)
            .arg("-o")
            .arg(&prefix)
            .output()
            .unwrap();
        assert!(o.status.success());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(
            err.contains(&format!("training object `{object}`")),
            "{err}"
        );
        let sidecar = std::fs::read_to_string(prefix.with_extension("json")).unwrap();
        assert!(
            sidecar.contains(&format!("\"mesh_is_training_object\": \"{object}\"")),
            "{sidecar}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// No mesh of ../shared/data that is not a training object is mistaken for one: the classic
/// meshes (among them other scans of a bunny, a cow, a horse and igea) and every tenth
/// SHREC'07 mesh hold none of the built-in model's fingerprints, while each of the 15
/// fixations-vr meshes holds its own.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn only_training_meshes_hold_the_builtin_model_fingerprints() {
    use meshgaze::gaze_model::object_fingerprint::SurfaceLookup;
    use meshgaze::gaze_model::GazeModel;
    let data = common::shared_data();
    let model = GazeModel::builtin();
    assert_eq!(model.training.objects.len(), 44);
    assert!(model
        .training
        .objects
        .iter()
        .all(|o| o.fingerprint.len() == 8));
    let holders = |mesh: &Mesh| -> Vec<String> {
        let surface = SurfaceLookup::new(mesh);
        model
            .training
            .objects
            .iter()
            .filter(|o| surface.holds(&o.fingerprint))
            .map(|o| o.name.clone())
            .collect()
    };
    let mut others: Vec<std::path::PathBuf> = Vec::new();
    for folder in ["meshes/classic", "meshes/shrec07"] {
        let mut stack = vec![data.join(folder)];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() {
                    stack.push(path);
                } else {
                    others.push(path);
                }
            }
        }
    }
    others.sort();
    let shrec_every_tenth = |p: &std::path::PathBuf| {
        !p.to_string_lossy().contains("shrec07")
            || p.file_name()
                .and_then(|f| f.to_str()?.split('.').next()?.parse::<u32>().ok())
                .is_some_and(|id| id % 10 == 0)
    };
    let mut checked = 0;
    let is_mesh = |p: &std::path::PathBuf| {
        let name = p.to_string_lossy();
        [".ply", ".obj", ".off", ".off.gz", ".obj.gz", ".ply.gz"]
            .iter()
            .any(|e| name.ends_with(e))
    };
    for path in others.iter().filter(|p| is_mesh(p) && shrec_every_tenth(p)) {
        let (mesh, _) = load_mesh(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        checked += 1;
        assert_eq!(holders(&mesh), Vec::<String>::new(), "{}", path.display());
    }
    assert!(checked >= 50, "only {checked} meshes checked");
    for entry in std::fs::read_dir(data.join("fixations-vr/meshes")).unwrap() {
        let path = entry.unwrap().path();
        let name = meshgaze::gaze_model::object_name(&path);
        let (mesh, _) = load_mesh(&path).unwrap();
        assert_eq!(holders(&mesh), vec![name], "{}", path.display());
    }
}

/// A closed box with a smaller box hidden inside it: no hold view shows the inner one.
fn box_in_box() -> Mesh {
    let mut mesh = Mesh {
        positions: Vec::new(),
        triangles: Vec::new(),
    };
    for scale in [1.0, 0.3] {
        let base = mesh.positions.len() as u32;
        for i in 0..8 {
            mesh.positions.push(DVec3::new(
                if i & 1 == 0 { -scale } else { scale },
                if i & 2 == 0 { -scale } else { scale },
                if i & 4 == 0 { -scale } else { scale },
            ));
        }
        for q in [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ] {
            mesh.triangles.push([base + q[0], base + q[1], base + q[2]]);
            mesh.triangles.push([base + q[0], base + q[2], base + q[3]]);
        }
    }
    mesh
}

#[test]
fn hidden_vertices_are_never_shown_and_leave_the_negatives() {
    let (protocol, _) = Protocol::builtin();
    let mesh = box_in_box();
    let exposure = hold_view_exposure(&mesh, &protocol).unwrap();
    let seen = exposure.seen();
    assert!(seen[..8].iter().all(|&s| s), "{:?}", exposure.seen_views);
    assert!(seen[8..].iter().all(|&s| !s), "{:?}", exposure.seen_views);
    // The centre prior is 0 where nothing is shown, positive elsewhere.
    let centre = centre_prior(&mesh, &protocol).unwrap();
    assert!(centre[8..].iter().all(|&c| c == 0.0));
    assert!(centre[..8].iter().all(|&c| c > 0.0));
    // A map that ranks the hidden vertices highest: plain AUC counts them as misses, the
    // visibility-aware AUC does not.
    let positive: Vec<bool> = (0..16).map(|i| i == 0).collect();
    let map: Vec<f64> = (0..16)
        .map(|i| {
            if i >= 8 {
                1.0
            } else if i == 0 {
                0.9
            } else {
                0.1
            }
        })
        .collect();
    let plain = auc_judd(&map, &positive, None);
    let visible = auc_judd_seen(&map, &positive, &seen, None);
    assert!(plain < 0.7 && visible > 0.99, "{plain} {visible}");
}

#[test]
fn the_up_prior_follows_the_protocol_up_axis() {
    let (mut protocol, _) = Protocol::builtin();
    let mesh = box_in_box();
    let up = up_prior(&mesh, &protocol);
    for (i, &u) in up.iter().enumerate().take(8) {
        let expected = if i & 2 == 0 { 0.0 } else { 1.0 };
        assert_eq!(u, expected, "vertex {i}");
    }
    protocol.viewpoints.up = [0.0, 0.0, 1.0];
    protocol.viewpoints.first = [1.0, 0.0, 0.0];
    let up = up_prior(&mesh, &protocol);
    assert_eq!(up[4], 1.0);
    assert_eq!(up[0], 0.0);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Any bytes: a parse or a located error, never a panic; an error's line is in the file.
    #[test]
    fn gaze_point_parser_never_panics(
        lines in proptest::collection::vec(
            prop_oneof![
                Just("0.1 0.2 0.3 0 1 0 0.5 1".to_string()),
                Just("0.1 0.2 0.3 0 1 0 0.5 0".to_string()),
                Just("".to_string()),
                Just("# c".to_string()),
                "[ -~]{0,40}",
                "[0-9. eE+-]{0,40}",
            ],
            0..20
        )
    ) {
        let text = lines.join("\n");
        match parse_gaze_points(text.as_bytes(), "p") {
            Ok(points) => {
                prop_assert!(!points.points.is_empty());
                prop_assert!(points.points.positions.iter().all(|p| p.is_finite()));
            }
            Err(e) => prop_assert!(e.line <= lines.len().max(1), "{e}"),
        }
    }
}

/// Copies fixations-vr's mesh NAME and its truth into DIR/meshes and DIR/truth (the
/// `score --dataset` layout), making the folders.
fn copy_vr_mesh_and_truth(vr: &Path, dir: &Path, name: &str) {
    for f in [
        format!("meshes/{name}.obj.gz"),
        format!("truth/{name}_objorder_time_bin.txt.gz"),
    ] {
        std::fs::create_dir_all(dir.join(&f).parent().unwrap()).unwrap();
        std::fs::copy(vr.join(&f), dir.join(&f)).unwrap();
    }
}

/// A dataset of meshes with per-vertex truth and no points files trains too: each mesh is
/// one object, its top 5% vertices by truth value the positives.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn meshes_with_truth_are_training_objects() {
    let data = common::shared_data();
    let vr = data.join("fixations-vr");
    let dir = std::env::temp_dir().join(format!("meshgaze-meshds-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    for n in ["cow", "hand"] {
        copy_vr_mesh_and_truth(&vr, &dir, n);
    }
    let out = dir.join("model.json");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["train", "--quiet", "--rounds", "10", "--dataset"])
        .arg(&dir)
        .arg("-o")
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let model = meshgaze::gaze_model::GazeModel::from_json(
        &std::fs::read_to_string(&out).unwrap(),
        "model",
    )
    .unwrap();
    let names: Vec<&str> = model
        .training
        .objects
        .iter()
        .map(|o| o.name.as_str())
        .collect();
    assert_eq!(names, ["cow", "hand"]);
    for o in &model.training.objects {
        let share = o.positives as f64 / o.points as f64;
        assert!((share - 0.05).abs() < 0.01, "{}: {share}", o.name);
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// Two datasets: the lab's 2 meshes weigh, together, `--weight` times the other dataset's 5
/// objects; `--cv` holds each dataset out whole and each category out whole, beside each
/// object; a weight naming no folder is refused with the folders' names.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn two_datasets_are_balanced_weighted_and_held_out_whole() {
    let data = common::shared_data();
    let vr = data.join("fixations-vr");
    let root = std::env::temp_dir().join(format!("meshgaze-two-ds-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let (a, b) = (root.join("vr-part"), root.join("lab"));
    std::fs::create_dir_all(a.join("points")).unwrap();
    for n in ["cat", "dog", "wolf", "lion"] {
        let f = format!("points/{n}.txt.gz");
        std::fs::copy(vr.join(&f), a.join(&f)).unwrap();
    }
    for (d, n) in [(&a, "horse"), (&b, "cow"), (&b, "hand")] {
        copy_vr_mesh_and_truth(&vr, d, n);
    }
    let categories = root.join("families.tsv");
    std::fs::write(
        &categories,
        "cat\tanimals\ndog\tanimals\nwolf\tanimals\nlion\tanimals\nhorse\tanimals\ncow\tanimals\nhand\thumans\n",
    )
    .unwrap();
    let out = root.join("model.json");
    let train = |extra: &[&str]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .args([
                "train",
                "--quiet",
                "--rounds",
                "20",
                "--rows-per-object",
                "500",
            ])
            .arg("--dataset")
            .arg(&a)
            .arg(&b)
            .arg("-o")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap()
    };
    let refused = train(&["--weight", "nosuch=2"]);
    assert!(!refused.status.success());
    let message = String::from_utf8_lossy(&refused.stderr);
    assert!(
        message.contains("no --dataset or --study folder named `nosuch`")
            && message.contains("vr-part, lab"),
        "{message}"
    );
    let cat = categories.to_str().unwrap();
    let run = train(&["--weight", "lab=2", "--cv", "--categories", cat]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let model = meshgaze::gaze_model::GazeModel::from_json(
        &std::fs::read_to_string(&out).unwrap(),
        "model",
    )
    .unwrap();
    let d = &model.training.datasets;
    let names: Vec<&str> = d.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(names, ["vr-part", "lab"]);
    assert_eq!((d[0].objects, d[1].objects), (5, 2));
    let total = |i: usize| d[i].rows as f64 * d[i].row_weight;
    assert!((total(1) / total(0) - 2.0).abs() < 1e-9, "{d:?}");
    let held = std::fs::read_to_string(root.join("model.held-out.csv")).unwrap();
    let rows: Vec<Vec<&str>> = held
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    let find = |by: &str, object: &str| {
        rows.iter()
            .find(|r| r[0] == by && r[2] == object && r[3] == "none")
            .unwrap_or_else(|| panic!("no {by} row for {object} in\n{held}"))
    };
    assert_eq!(find("dataset", "cow")[1], "lab");
    assert_eq!(find("dataset", "horse")[1], "vr-part");
    assert_eq!(find("category", "hand")[1], "humans");
    assert_eq!(find("object", "hand")[1], "hand");
    // Held out with its whole dataset, cow is predicted by a model that saw only vr-part:
    // the two folds are different models, so (on real data) different scores.
    let auc = |r: &Vec<&str>| r[4].parse::<f64>().unwrap();
    assert_ne!(auc(find("dataset", "cow")), auc(find("object", "cow")));
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.contains("Leave-one-dataset-out"), "{stdout}");
    assert!(stdout.contains("Leave-one-category-out"), "{stdout}");
    let _ = std::fs::remove_dir_all(&root);
}

/// The shipped categories file gives every object of fixations-vr a family (so
/// `train --cv --categories models/fixations-vr-categories.tsv` runs on it).
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn every_fixations_vr_object_has_a_category() {
    use meshgaze::experiments::gaze_model_cross_validation::Categories;
    let categories =
        Categories::read(&common::repo_root().join("models/fixations-vr-categories.tsv")).unwrap();
    let points = common::shared_data().join("fixations-vr/points");
    let mut missing = Vec::new();
    for entry in std::fs::read_dir(&points).unwrap() {
        let name = meshgaze::gaze_model::object_name(&entry.unwrap().path());
        if name != "INDEX" && categories.category(&name).is_none() {
            missing.push(name);
        }
    }
    assert!(missing.is_empty(), "no category for {missing:?}");
    assert_eq!(categories.of.len(), 44);
}

/// A mesh stored with +z up (the VR bunny turned a quarter turn about x) is predicted as the
/// upright one only when the protocol is told its up axis (`--up z`): the model reads height,
/// front and facing from the protocol. Told, the map ranks the fixated vertices as the
/// upright map does; not told, it falls far below. (The bunny is one of the built-in
/// model's training objects: the figures are training-set ones; what is tested is that
/// turning the mesh and the protocol together leaves the prediction in place.)
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn a_mesh_stored_z_up_is_predicted_as_upright_once_its_up_axis_is_given() {
    use meshgaze::progress::Silent;
    use meshgaze::protocol::UpAxis;
    use meshgaze::saliency::{compute_saliency_viewed, Method, SmsParams, Viewing};
    let data = common::shared_data();
    let (mesh, positive) = vr_mesh(&data, "bunny");
    let mut turned = mesh.clone();
    for p in &mut turned.positions {
        *p = DVec3::new(p.x, -p.z, p.y);
    }
    let gaze = |m: &Mesh, viewing: &Viewing| {
        compute_saliency_viewed(Method::Gaze, m, &SmsParams::default(), viewing, &Silent)
            .unwrap()
            .values
    };
    let told = Viewing {
        protocol: Protocol::builtin().0.with_up_axis(UpAxis::Z),
        ..Viewing::builtin()
    };
    assert_eq!(told.protocol.viewpoints.up, [0.0, 0.0, 1.0]);
    let first = told.protocol.viewpoints.first;
    assert!((first[1] + 1.0).abs() < 1e-12 && first[0].abs() < 1e-12 && first[2].abs() < 1e-12);
    let upright = auc_judd(&gaze(&mesh, &Viewing::builtin()), &positive, None);
    let default_turned = auc_judd(&gaze(&turned, &Viewing::builtin()), &positive, None);
    let told_turned = auc_judd(&gaze(&turned, &told), &positive, None);
    eprintln!(
        "upright {upright:.3}, turned {default_turned:.3}, turned with --up z {told_turned:.3}"
    );
    assert!(upright > 0.8, "{upright}");
    assert!(
        (told_turned - upright).abs() < 0.01,
        "{told_turned} vs {upright}"
    );
    assert!(
        default_turned < upright - 0.15,
        "{default_turned} vs {upright}"
    );
    // Already +y: the protocol is left as it is.
    let (builtin, _) = Protocol::builtin();
    assert_eq!(builtin.clone().with_up_axis(UpAxis::Y), builtin);
}

//! Ground-truth readers and the scoring engine on constructed cases with known answers.
mod common;

use std::path::{Path, PathBuf};

use meshgaze::progress::Silent;
use meshgaze::scoring::{score_mesh, ScoreParams, CHANCE, CHANCE_HIGH, CHANCE_LOW, HUMAN};
use meshgaze::truth::{load_ground_truth, GroundTruth, TruthError};
use proptest::prelude::*;

fn write(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meshgaze-truth-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn at(r: Result<GroundTruth, TruthError>) -> (usize, usize, String) {
    match r {
        Err(TruthError::At {
            line,
            column,
            message,
            ..
        }) => (line, column, message),
        other => panic!("expected a positioned error, got {other:?}"),
    }
}

#[test]
fn vertex_maps_with_and_without_flags_and_headers() {
    let GroundTruth::VertexMap(m) =
        load_ground_truth(&write("a.txt", "0 0\n2.5 1\n1 0\n"), 3, 0.05).unwrap()
    else {
        panic!()
    };
    assert_eq!(m.values, vec![0.0, 2.5, 1.0]);
    assert_eq!(m.positive, vec![false, true, false]);
    let GroundTruth::VertexMap(m) = load_ground_truth(
        &write("b.csv", "vertex,saliency\n2,0.1\n0,0.9\n1,0.5\n"),
        3,
        0.34,
    )
    .unwrap() else {
        panic!()
    };
    assert_eq!(m.values, vec![0.9, 0.5, 0.1]);
    assert_eq!(m.positive, vec![true, false, false]); // top 34% of 3 = 1 vertex
    assert!(m.positive_rule.contains("top"));
    let err = load_ground_truth(&write("c.txt", "1\n2\n"), 3, 0.05).unwrap_err();
    assert!(
        err.to_string()
            .contains("1 of the mesh's 3 vertices have no value"),
        "{err}"
    );
    let (line, col, msg) = at(load_ground_truth(&write("d.txt", "1 0\n2 x\n"), 2, 0.05));
    assert_eq!((line, col), (2, 3), "{msg}");
    let (line, _, msg) = at(load_ground_truth(&write("e.txt", "1\n2\n3\n"), 2, 0.05));
    assert_eq!(line, 3, "{msg}");
}

#[test]
fn fixation_sets_count_what_missed_the_mesh() {
    let text = "subject,fixation,vertex,fate\ns1,0,2,hit\ns1,1,0,background\ns2,0,1,snapped\ns2,1,1,hit\ns3,0,0,off-screen\n";
    let GroundTruth::Fixations(f) = load_ground_truth(&write("f.csv", text), 3, 0.05).unwrap()
    else {
        panic!()
    };
    assert_eq!(f.rows, 5);
    assert_eq!(f.fixations.len(), 3);
    assert_eq!(f.subjects, vec!["s1", "s2"]);
    assert_eq!(f.rows_not_on_mesh.get("background"), Some(&1));
    assert_eq!(f.rows_not_on_mesh.get("off-screen"), Some(&1));
    let (line, col, msg) = at(load_ground_truth(
        &write("g.csv", "subject,vertex\ns1,7\n"),
        3,
        0.05,
    ));
    assert_eq!((line, col), (2, 4), "{msg}");
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn shared_vr_truth_files_read_with_their_flags() {
    let data = common::shared_data();
    let truth = data.join("fixations-vr/truth/bunny_objorder_time_bin.txt.gz");
    let GroundTruth::VertexMap(m) = load_ground_truth(&truth, 20_000, 0.05).unwrap() else {
        panic!()
    };
    let positives = m.positive.iter().filter(|p| **p).count();
    assert!((900..=1100).contains(&positives), "{positives} positives");
    assert!(m.positive_rule.contains("flag"));
}

/// A planted case: fixations on the highest vertices of the bunny (its ears), maps that know it
/// (height) or invert it.
#[test]
fn scoring_ranks_a_perfect_map_above_chance_and_an_inverted_one_below() {
    let mesh = common::bunny_res3();
    let n = mesh.positions.len();
    // "Subjects" look at the vertices highest in y (the ears).
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| mesh.positions[b].y.total_cmp(&mesh.positions[a].y));
    let mut text = String::from("subject,vertex\n");
    for (k, v) in order.iter().take(120).enumerate() {
        text.push_str(&format!("s{},{v}\n", k % 8));
    }
    let truth = load_ground_truth(&write("planted.csv", &text), n, 0.05).unwrap();
    let height: Vec<f64> = mesh.positions.iter().map(|p| p.y).collect();
    let inverted: Vec<f64> = height.iter().map(|v| -v).collect();
    let params = ScoreParams {
        blur_sigmas: vec![0.0, 0.05],
        borji_splits: 20,
        ..ScoreParams::default()
    };
    // Height drowned in per-vertex noise: blurring averages the noise away, so this map's
    // peak is at the blurred level, not at blur 0.
    let noisy: Vec<f64> = height
        .iter()
        .enumerate()
        .map(|(i, h)| h + 3.0 * (((i * 2_654_435_761) % 1000) as f64 / 1000.0 - 0.5))
        .collect();
    let maps = vec![
        ("height".to_string(), height),
        ("inverted".to_string(), inverted),
        ("noisy".to_string(), noisy),
    ];
    let score = score_mesh(&mesh, &truth, &maps, &params, None, &Silent).unwrap();
    let get = |method: &str, metric: &str, blur: f64| {
        score
            .rows
            .iter()
            .find(|r| r.method == method && r.metric == metric && r.blur == blur)
            .unwrap()
            .value
    };
    assert_eq!(score.human_splits, 70);
    assert!(get("height", "auc_judd", 0.0) > 0.99);
    assert!(get("inverted", "auc_judd", 0.0) < 0.01);
    let chance = get(CHANCE, "auc_judd", 0.0);
    assert!((chance - 0.5).abs() < 0.06, "chance {chance}");
    assert!(
        get(HUMAN, "auc_judd", 0.05) > 0.9,
        "human {}",
        get(HUMAN, "auc_judd", 0.05)
    );
    assert!(get("height", "lcc", 0.05) > 0.3);
    assert!(get("height", "nss", 0.0) > 1.5);
    let summary = score
        .summaries
        .iter()
        .find(|s| s.method == "height")
        .unwrap();
    // The summary's peak is the maximum of the curve above, at the blur where it is reached,
    // with the chance map's value at that same blur.
    let curve = [
        (0.0, get("height", "auc_judd", 0.0)),
        (0.05, get("height", "auc_judd", 0.05)),
    ];
    let best = if curve[1].1 > curve[0].1 {
        curve[1]
    } else {
        curve[0]
    };
    assert_eq!((summary.auc_judd_peak_blur, summary.auc_judd_peak), best);
    assert_eq!(
        summary.chance_auc_judd_at_peak,
        get(CHANCE, "auc_judd", best.0)
    );
    assert_eq!(summary.auc_judd_unblurred, curve[0].1);
    // A peak away from blur 0 is found there.
    let noisy = score
        .summaries
        .iter()
        .find(|s| s.method == "noisy")
        .unwrap();
    let (n0, n5) = (
        get("noisy", "auc_judd", 0.0),
        get("noisy", "auc_judd", 0.05),
    );
    assert!(n5 > n0 + 0.05, "noisy: {n0} unblurred, {n5} blurred");
    assert_eq!((noisy.auc_judd_peak_blur, noisy.auc_judd_peak), (0.05, n5));
    assert_eq!(noisy.chance_auc_judd_at_peak, get(CHANCE, "auc_judd", 0.05));
    // The band holds its mean, and the summary quotes it at the peak's blur.
    for blur in [0.0, 0.05] {
        let (lo, mid, hi) = (
            get(CHANCE_LOW, "auc_judd", blur),
            get(CHANCE, "auc_judd", blur),
            get(CHANCE_HIGH, "auc_judd", blur),
        );
        assert!(lo < mid && mid < hi, "{lo} {mid} {hi}");
    }
    assert_eq!(
        noisy.chance_auc_judd_low_at_peak,
        get(CHANCE_LOW, "auc_judd", 0.05)
    );
    assert_eq!(
        noisy.chance_auc_judd_high_at_peak,
        get(CHANCE_HIGH, "auc_judd", 0.05)
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn arbitrary_truth_files_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300), n in 1usize..6) {
        let p = write(&format!("fuzz-{n}.txt"), "");
        std::fs::write(&p, &bytes).unwrap();
        let _ = load_ground_truth(Path::new(&p), n, 0.5);
    }

    #[test]
    fn mutated_fixation_files_never_panic(pos in any::<usize>(), byte in any::<u8>(), cut in any::<usize>()) {
        let mut b = b"subject,fixation,vertex,fate\ns1,0,2,hit\ns2,1,0,background\n".to_vec();
        let i = pos % b.len();
        b[i] = byte;
        b.truncate(cut % (b.len() + 1));
        let p = write("fuzz-fix.csv", "");
        std::fs::write(&p, &b).unwrap();
        let _ = load_ground_truth(&p, 3, 0.5);
    }
}

/// A smooth per-face value: the height of each face's centroid.
fn face_centroid_heights(mesh: &meshgaze::mesh::Mesh) -> Vec<f64> {
    mesh.triangles
        .iter()
        .map(|t| t.iter().map(|&v| mesh.positions[v as usize].y).sum::<f64>() / 3.0)
        .collect()
}

/// A per-face truth map (one value per triangle, as published 3D gaze datasets give them) is
/// told by its row count and scores exactly as the per-vertex map it is carried to
/// (area-weighted mean of each vertex's faces); named per vertex, it is refused.
#[test]
fn score_reads_a_per_face_truth_as_its_area_weighted_vertex_map() {
    use meshgaze::truth::face_values_to_vertices;
    let mesh = common::bunny_res3();
    let mesh_path = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    let faces = face_centroid_heights(&mesh);
    let carried = face_values_to_vertices(&mesh, &faces);
    let face_csv = write(
        "per_face.csv",
        &(String::from("face,value\n")
            + &faces
                .iter()
                .enumerate()
                .map(|(i, v)| format!("{i},{v}\n"))
                .collect::<String>()),
    );
    let vertex_csv = write(
        "carried.csv",
        &(String::from("vertex,value\n")
            + &carried
                .iter()
                .enumerate()
                .map(|(i, v)| format!("{i},{v}\n"))
                .collect::<String>()),
    );
    let score = |truth: &Path, out: &str, layout: &str| {
        std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .args(["score", "--quiet", "--method", "mc", "--borji-splits", "5"])
            .arg("--mesh")
            .arg(&mesh_path)
            .arg("--truth")
            .arg(truth)
            .args(["--truth-layout", layout, "-o"])
            .arg(std::env::temp_dir().join(format!("meshgaze-face-{}-{out}", std::process::id())))
            .output()
            .unwrap()
    };
    let a = score(&face_csv, "face", "auto");
    assert!(a.status.success(), "{}", String::from_utf8_lossy(&a.stderr));
    let b = score(&vertex_csv, "vertex", "auto");
    assert!(b.status.success(), "{}", String::from_utf8_lossy(&b.stderr));
    let rows = |out: &str| {
        std::fs::read_to_string(
            std::env::temp_dir().join(format!("meshgaze-face-{}-{out}.csv", std::process::id())),
        )
        .unwrap()
    };
    assert_eq!(rows("face"), rows("vertex"));
    assert!(rows("face").contains(",mc,auc_judd,0,"));
    let refused = score(&face_csv, "refused", "vertex");
    assert!(!refused.status.success());
    let e = String::from_utf8_lossy(&refused.stderr);
    assert!(e.contains("per_face.csv") && e.contains("1889"), "{e}");
    let _ = load_ground_truth(&face_csv, mesh.triangles.len(), 0.05).unwrap();
}

/// `train --dataset` reads a per-face truth as `score` does: the model trained on a mesh with
/// a per-face map has the same trees as one trained on the vertex map it is carried to, and
/// `--truth-layout vertex` refuses the per-face file, naming it.
#[test]
fn train_reads_a_per_face_truth_as_its_area_weighted_vertex_map() {
    use meshgaze::truth::face_values_to_vertices;
    let mesh = common::bunny_res3();
    let mesh_path = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    let faces = face_centroid_heights(&mesh);
    let carried = face_values_to_vertices(&mesh, &faces);
    let root = std::env::temp_dir().join(format!("meshgaze-train-face-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&root);
    let dataset = |name: &str, header: &str, values: &[f64]| {
        let d = root.join(name);
        std::fs::create_dir_all(d.join("meshes")).unwrap();
        std::fs::create_dir_all(d.join("truth")).unwrap();
        std::fs::copy(&mesh_path, d.join("meshes/bun_zipper_res3.ply")).unwrap();
        let body: String = values
            .iter()
            .enumerate()
            .map(|(i, v)| format!("{i},{v}\n"))
            .collect();
        std::fs::write(
            d.join("truth/bun_zipper_res3_map.csv"),
            format!("{header}\n{body}"),
        )
        .unwrap();
        d
    };
    let face_ds = dataset("face", "face,value", &faces);
    let vertex_ds = dataset("vertex", "vertex,value", &carried);
    let train = |d: &Path, layout: &str| {
        let out = d.join("model.json");
        let run = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .args([
                "train",
                "--quiet",
                "--rounds",
                "5",
                "--truth-layout",
                layout,
                "--dataset",
            ])
            .arg(d)
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        (run, out)
    };
    let (refused, _) = train(&face_ds, "vertex");
    assert!(!refused.status.success());
    let e = String::from_utf8_lossy(&refused.stderr);
    assert!(e.contains("bun_zipper_res3_map.csv"), "{e}");
    let model = |d: &Path, layout: &str| {
        let (run, out) = train(d, layout);
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        meshgaze::gaze_model::GazeModel::load(&out).unwrap()
    };
    let from_faces = model(&face_ds, "face");
    let from_vertices = model(&vertex_ds, "auto");
    assert_eq!(from_faces.trees, from_vertices.trees);
    assert_eq!(
        from_faces.training.objects[0].positives,
        from_vertices.training.objects[0].positives
    );
    let _ = std::fs::remove_dir_all(&root);
}

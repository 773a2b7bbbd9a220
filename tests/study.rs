//! `meshgaze study` end to end on a small simulated playlist study (3 meshes x 8 subjects, a
//! 14 s protocol): stimuli before recordings, the truth equal to the single-mesh commands,
//! incremental reruns, a resumed run, shards merged, a mesh changed after it was shown.
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

fn meshgaze(dir: &Path, args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "meshgaze {args:?} failed:\n{text}");
    text
}

fn read(p: PathBuf) -> Vec<u8> {
    std::fs::read(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

fn setup(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meshgaze-study-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("meshes")).unwrap();
    let bunny = common::repo_root().join("stimuli/meshes/bun_zipper_res3.ply");
    for m in ["apple", "bunny", "cow"] {
        std::fs::copy(&bunny, dir.join("meshes").join(format!("{m}.ply"))).unwrap();
    }
    let short = meshgaze(&dir, &["protocol", "show"])
        .replace("width_px = 1680", "width_px = 320")
        .replace("height_px = 1050", "height_px = 200")
        .replace("generator = \"icosahedron\"", "generator = \"turntable\"")
        .replace("count = 12", "count = 4")
        .replace("move_s = 1.0", "move_s = 0.5");
    std::fs::write(dir.join("short.toml"), short).unwrap();
    std::fs::write(
        dir.join("study.toml"),
        "protocol = \"short.toml\"\nmeshes = [\"meshes/*.ply\"]\nrecordings = [\"recordings/*.txt\"]\nmethods = [\"mc\"]\n",
    )
    .unwrap();
    dir
}

fn log_lines(dir: &Path, outcome: &str) -> Vec<String> {
    String::from_utf8(read(dir.join("study/run.log")))
        .unwrap()
        .lines()
        .filter(|l| l.split('\t').nth(2) == Some(outcome))
        .map(str::to_string)
        .collect()
}

#[test]
fn a_playlist_study_runs_resumes_shards_and_refuses_a_changed_mesh() {
    let dir = setup("main");
    // Before any recording: the stimuli, and a word that recordings are missing.
    let text = meshgaze(&dir, &["study", "run", "study.toml", "--quiet"]);
    // --quiet: nothing but the encoder library's own warnings.
    assert!(text.lines().all(|l| l.starts_with("[OpenH264]")), "{text}");
    for m in ["apple", "bunny", "cow"] {
        assert!(dir.join(format!("study/stimuli/{m}/stimulus.mp4")).exists());
    }
    let log = String::from_utf8(read(dir.join("study/run.log"))).unwrap();
    assert!(log.contains("no recordings found yet"), "{log}");

    // Playlist recordings: every subject sees every video once, in its own order.
    meshgaze(
        &dir,
        &[
            "simulate",
            "--study",
            "study.toml",
            "--subjects",
            "8",
            "-o",
            "recordings",
            "-q",
        ],
    );
    meshgaze(
        &dir,
        &["study", "run", "study.toml", "--jobs", "2", "--quiet"],
    );
    // 8 subjects x 15 kept fixations per mesh before projection.
    let fix = String::from_utf8(read(dir.join("study/ingest/fixations.csv"))).unwrap();
    for m in ["apple", "bunny", "cow"] {
        let kept = fix
            .lines()
            .filter(|l| {
                l.split(',').nth(1) == Some(&format!("{m}.mp4"))
                    && l.split(',').nth(12) == Some("kept")
            })
            .count();
        assert_eq!(kept, 8 * 15, "{m}");
    }
    // The truth equals what the single-mesh commands give by hand.
    let recordings: Vec<String> = (1..=8)
        .map(|k| format!("recordings/s{k:02}_samples.txt"))
        .collect();
    let mut args = vec![
        "ingest",
        "-q",
        "--protocol",
        "short.toml",
        "-o",
        "hand/ingest",
    ];
    args.extend(recordings.iter().map(String::as_str));
    meshgaze(&dir, &args);
    assert_eq!(
        read(dir.join("hand/ingest/fixations.csv")),
        read(dir.join("study/ingest/fixations.csv"))
    );
    meshgaze(
        &dir,
        &[
            "project",
            "-q",
            "--stimulus",
            "study/stimuli/bunny",
            "--fixations",
            "hand/ingest/fixations.csv",
            "--stimulus-name",
            "bunny.mp4",
            "-o",
            "hand/proj",
        ],
    );
    meshgaze(
        &dir,
        &[
            "truth",
            "-q",
            "--stimulus",
            "study/stimuli/bunny",
            "hand/proj",
            "-o",
            "hand/truth",
        ],
    );
    assert_eq!(
        read(dir.join("hand/truth/truth.csv")),
        read(dir.join("study/truth/bunny/truth.csv"))
    );
    let scores = read(dir.join("study/scores.csv"));
    assert!(String::from_utf8_lossy(&scores).lines().count() > 3 * 21);
    // Every map is also scored with the never-shown vertices left out of the negatives, and
    // the stimulus shows enough of each mesh that this is a number.
    let shown: Vec<String> = String::from_utf8_lossy(&scores)
        .lines()
        .filter(|l| l.contains(",auc_judd_visible,0,"))
        .map(str::to_string)
        .collect();
    assert!(shown.len() >= 3, "{shown:?}");
    for l in &shown {
        let v: f64 = l.rsplit(',').next().unwrap().parse().unwrap();
        assert!((0.0..=1.0).contains(&v), "{l}");
    }

    // The report: every mesh linked to its own page, the mean curve with the chance band,
    // data quality for each of the 8 subjects; study.json hashes every mesh and recording.
    let report = String::from_utf8(read(dir.join("study/report.html"))).unwrap();
    // Every step's seconds: run.log's fourth column, study.json's `seconds`, the report's
    // account of where the time went. Steps that did work took measurable time.
    let log = String::from_utf8(read(dir.join("study/run.log"))).unwrap();
    let mut worked = 0.0;
    for l in log.lines().filter(|l| !l.starts_with("problem\t")) {
        let f: Vec<&str> = l.split('\t').collect();
        let seconds: f64 = f[3]
            .parse()
            .unwrap_or_else(|_| panic!("no seconds in `{l}`"));
        assert!(seconds >= 0.0, "{l}");
        if f[2] == "done" && f[1].starts_with("saliency") {
            worked += seconds;
        }
    }
    assert!(worked > 0.0, "the saliency steps took no time?\n{log}");
    let json: serde_json::Value =
        serde_json::from_slice(&read(dir.join("study/study.json"))).unwrap();
    assert!(json["run"]["steps"]
        .as_array()
        .unwrap()
        .iter()
        .all(|s| s["seconds"].as_f64().is_some()));
    assert!(report.contains("Where the time went"));
    for m in ["apple", "bunny", "cow"] {
        assert!(report.contains(&format!("href=\"report/{m}.html\"")), "{m}");
        let page = String::from_utf8(read(dir.join(format!("study/report/{m}.html")))).unwrap();
        assert!(page.contains("chance there: mean [95%]"), "{m}");
        assert!(page.contains("shown only"), "{m}");
        // The 3D viewer with the mesh's map, density and the subjects' fixations.
        assert!(page.contains("<h2>In 3D</h2>"), "{m}");
        let data_at = page.find("class=\"mgv-data\">").expect("viewer data");
        let data = &page[data_at..];
        assert!(
            data.contains("\"name\":\"mc\"") && data.contains("\"kind\":\"truth\""),
            "{m}"
        );
        assert!(data.contains("\"holds\":[{"), "{m}: the stimulus cameras");
        assert_eq!(
            page.matches("<img alt=").count(),
            2 + 2 * 2,
            "{m}: 2 charts, density and mc in 2 views"
        );
        let chance =
            String::from_utf8(read(dir.join(format!("study/scores/chance/{m}.csv")))).unwrap();
        assert_eq!(
            chance.lines().count(),
            1 + 21 * 20,
            "{m}: 20 draws at 21 blurs"
        );
    }
    assert!(dir.join("study/report/mean_auc.png").exists());
    let quality = report
        .split("Data quality per subject")
        .nth(1)
        .expect("quality table")
        .split("Where the time went")
        .next()
        .unwrap();
    assert_eq!(quality.matches("<tr><td>").count(), 8, "{quality}");
    let study_json: serde_json::Value =
        serde_json::from_slice(&read(dir.join("study/study.json"))).unwrap();
    let inputs = study_json["provenance"]["inputs"].as_array().unwrap();
    assert_eq!(
        inputs.len(),
        2 + 3 + 8,
        "study.toml, protocol, meshes, recordings"
    );
    assert!(inputs
        .iter()
        .all(|i| i["sha256"].as_str().is_some_and(|h| h.len() == 64)));

    // Nothing changed: nothing redone.
    meshgaze(&dir, &["study", "run", "study.toml", "--quiet"]);
    assert!(
        log_lines(&dir, "done").is_empty(),
        "{:?}",
        log_lines(&dir, "done")
    );

    // From another working directory, the study named by its absolute path: the same study,
    // nothing redone (its stimuli name their meshes from their own folders).
    let elsewhere = std::env::temp_dir();
    let toml = dir.join("study.toml");
    meshgaze(
        &elsewhere,
        &["study", "run", toml.to_str().unwrap(), "--quiet"],
    );
    assert!(
        log_lines(&dir, "done").is_empty() && log_lines(&dir, "failed").is_empty(),
        "{}",
        String::from_utf8_lossy(&read(dir.join("study/run.log")))
    );
    // So does a single-mesh command reading a stimulus.
    meshgaze(
        &elsewhere,
        &[
            "truth",
            "-q",
            "--stimulus",
            dir.join("study/stimuli/bunny").to_str().unwrap(),
            dir.join("hand/proj").to_str().unwrap(),
            "-o",
            dir.join("hand/truth-elsewhere").to_str().unwrap(),
        ],
    );
    assert_eq!(
        read(dir.join("hand/truth-elsewhere/truth.csv")),
        read(dir.join("hand/truth/truth.csv"))
    );

    // A run killed after projecting cow but before stamping it: redone, same bytes.
    let truth_before = read(dir.join("study/truth/cow/truth.csv"));
    std::fs::remove_file(dir.join("study/projection/cow/.meshgaze-stamp")).unwrap();
    std::fs::write(
        dir.join("study/projection/cow/projected.csv"),
        b"subject,fix",
    )
    .unwrap();
    meshgaze(&dir, &["study", "run", "study.toml", "--quiet"]);
    let done = log_lines(&dir, "done");
    assert!(done.iter().all(|l| l.starts_with("cow\t")), "{done:?}");
    assert!(
        done.iter().any(|l| l.starts_with("cow\tproject")),
        "{done:?}"
    );
    assert_eq!(read(dir.join("study/truth/cow/truth.csv")), truth_before);
    assert_eq!(read(dir.join("study/scores.csv")), scores);

    // Shards 1/2 and 2/2 into another folder, merged: the same scores and truths.
    let sharded =
        String::from_utf8(read(dir.join("study.toml"))).unwrap() + "output = \"sharded\"\n";
    std::fs::write(dir.join("sharded.toml"), sharded).unwrap();
    meshgaze(
        &dir,
        &["study", "run", "sharded.toml", "--shard", "1/2", "--quiet"],
    );
    meshgaze(
        &dir,
        &["study", "run", "sharded.toml", "--shard", "2/2", "--quiet"],
    );
    meshgaze(&dir, &["study", "merge", "sharded.toml"]);
    assert_eq!(read(dir.join("sharded/scores.csv")), scores);
    let merged_report = String::from_utf8(read(dir.join("sharded/report.html"))).unwrap();
    // Everything but the account of the last run's seconds, the one part that differs by run.
    let tables = |r: &str| {
        let t = r.split("<h2>Mean AUC-Judd").nth(1).unwrap();
        let (before, after) = t.split_once("<h2>Where the time went").unwrap();
        before.to_string() + after.split_once("<h2>Files").unwrap().1
    };
    assert_eq!(tables(&merged_report), tables(&report));
    for m in ["apple", "bunny", "cow"] {
        assert_eq!(
            read(dir.join(format!("sharded/truth/{m}/truth.csv"))),
            read(dir.join(format!("study/truth/{m}/truth.csv")))
        );
    }

    // A mesh changed after its video was shown: refused, the rest of the study completes.
    let mut apple = read(dir.join("meshes/apple.ply"));
    apple.extend_from_slice(b"\n");
    std::fs::write(dir.join("meshes/apple.ply"), apple).unwrap();
    let text = meshgaze(&dir, &["study", "run", "study.toml"]);
    assert!(
        text.contains("apple.ply") && text.contains("changed after its video"),
        "{text}"
    );
    assert!(log_lines(&dir, "failed")
        .iter()
        .all(|l| l.starts_with("apple\t")));
    assert!(!log_lines(&dir, "up-to-date").is_empty());
}

/// Runs `study run` on this study.toml in a fresh folder; it must fail: its stderr.
fn failed_run(name: &str, toml: &str) -> String {
    let dir = setup(name);
    std::fs::write(dir.join("study.toml"), toml).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .current_dir(&dir)
        .args(["study", "run", "study.toml"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_study_toml_typo_names_the_file_line_and_column() {
    let e = failed_run(
        "typo",
        "protocol = \"short.toml\"\nmeshes = [\"meshes/*.ply\"]\nmethod = [\"mc\"]\n",
    );
    assert!(
        e.contains("study.toml") && e.contains("line 3, column 1") && e.contains("method"),
        "{e}"
    );
}

#[test]
fn a_bad_set_line_names_the_file_and_the_setting() {
    let e = failed_run(
        "badset",
        "protocol = \"short.toml\"\nmeshes = [\"meshes/*.ply\"]\nmethods = [\"sri\"]\nset = [\"sri.most_similar=many\"]\n",
    );
    assert!(
        e.contains("study.toml") && e.contains("sri.most_similar=many"),
        "{e}"
    );
}

/// One study, three trackers: subjects recorded with an SMI RED (format A), an EyeLink (ASC)
/// and a Tobii (Pro Lab TSV), all playing every video. Each file is read with its format's
/// defaults and every subject gives the protocol's 15 fixations per mesh.
#[test]
fn a_study_takes_recordings_of_several_trackers_mixed() {
    let dir = setup("mixed");
    std::fs::write(
        dir.join("study.toml"),
        "protocol = \"short.toml\"\nmeshes = [\"meshes/*.ply\"]\nrecordings = [\"recordings/*\"]\nmethods = [\"mc\"]\n",
    )
    .unwrap();
    meshgaze(&dir, &["study", "run", "study.toml", "--quiet"]);
    std::fs::create_dir_all(dir.join("recordings")).unwrap();
    for (format, subjects, ext) in [
        ("smi", 1..=3, "_samples.txt"),
        ("eyelink", 4..=6, ".asc"),
        ("tobii", 7..=8, ".tsv"),
    ] {
        let out = format!("sim-{format}");
        meshgaze(
            &dir,
            &[
                "simulate",
                "--study",
                "study.toml",
                "--subjects",
                "8",
                "--recording-format",
                format,
                "-o",
                &out,
                "-q",
            ],
        );
        for k in subjects {
            let name = format!("s{k:02}{ext}");
            std::fs::copy(
                dir.join(&out).join(&name),
                dir.join("recordings").join(&name),
            )
            .unwrap();
        }
    }
    meshgaze(&dir, &["study", "run", "study.toml", "--quiet"]);
    let fix = String::from_utf8(read(dir.join("study/ingest/fixations.csv"))).unwrap();
    let header: Vec<&str> = fix.lines().next().unwrap().split(',').collect();
    let col = |n: &str| {
        header
            .iter()
            .position(|c| *c == n)
            .unwrap_or_else(|| panic!("{n}: {header:?}"))
    };
    let (subject, stimulus, fate) = (col("subject"), col("stimulus"), col("fate"));
    for m in ["apple", "bunny", "cow"] {
        for k in 1..=8 {
            let kept = fix
                .lines()
                .filter(|l| {
                    let f: Vec<&str> = l.split(',').collect();
                    f[subject] == format!("s{k:02}")
                        && f[stimulus] == format!("{m}.mp4")
                        && f[fate] == "kept"
                })
                .count();
            assert_eq!(kept, 15, "{m}, s{k:02}");
        }
        assert!(
            dir.join(format!("study/truth/{m}/truth.csv")).exists(),
            "{m}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

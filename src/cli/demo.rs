use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use clap::Args;

use meshgaze::mesh::{parse_mesh_bytes, MeshFormat};
use meshgaze::provenance::InputFile;
use meshgaze::saliency::Method;
use meshgaze::scoring::{score_mesh, ScoreParams};
use meshgaze::stimulus::load::load_stimulus;
use meshgaze::stimulus::{render_stimulus, FrameImages, Protocol, StimulusOptions};

use super::progress_bar::Bars;
use meshgaze::report::demo_report::{write_report, ReportInputs, StepTiming};
use meshgaze::report::score_plots::write_score_plots;
use meshgaze::saliency::map_file::{compute_and_write_map, MapOutputs};
use meshgaze::saliency::SmsParams;
use meshgaze::scoring::dataset::{write_score_rows, SCORE_CSV_HEADER};
use meshgaze::truth::{build_truth, read_projections, write_truth, TruthParams};

/// The Stanford bunny (8,171 vertices) compiled into the binary, so the demo needs no files.
const BUNNY: &[u8] = include_bytes!("../../stimuli/meshes/bun_zipper_res2.ply");
/// The paper's protocol, compiled in for the same reason.
const PROTOCOL: &str = include_str!("../../protocols/hu2020.toml");

/// Run the whole pipeline end to end on the bundled Stanford bunny, and write report.html.
///
/// With no input: renders the paper's 48 s stimulus, simulates 8 virtual observers (SMI
/// RED250 recordings in formats A and C1; they favour protruding parts, a model independent
/// of every saliency method), ingests and filters their fixations, projects them onto the
/// mesh, builds the ground truth with the split-half human ceiling, computes SMS, MS and MC,
/// scores them, and writes OUT/report.html, a single file that opens offline. Every stage's
/// own outputs (the same files the individual commands write) are kept in OUT's subfolders.
///
/// The subjects are simulated: the scores show that the pipeline works, not how people look
/// at bunnies.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(short, long, default_value = "meshgaze-demo")]
    pub output: PathBuf,
    /// Virtual subjects.
    #[arg(long, default_value_t = 8)]
    pub subjects: usize,
    /// Seed of the virtual observers.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Parses a command's arguments as if typed, so the demo runs exactly what a user would.
fn args_of<T: clap::Args + clap::FromArgMatches>(argv: &[String]) -> Result<T> {
    let m = T::augment_args(clap::Command::new("meshgaze")).try_get_matches_from(
        std::iter::once("meshgaze".to_string()).chain(argv.iter().cloned()),
    )?;
    Ok(T::from_arg_matches(&m)?)
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

pub fn run(args: DemoArgs) -> Result<()> {
    let t_all = Instant::now();
    let out = &args.output;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    let say = |m: &str| {
        if !args.quiet {
            eprintln!("meshgaze demo: {m}");
        }
    };
    let mut steps: Vec<StepTiming> = Vec::new();
    let mut step = |name: &str, t: Instant, outputs: &str| {
        steps.push(StepTiming {
            name: name.to_string(),
            seconds: t.elapsed().as_secs_f64(),
            outputs: outputs.to_string(),
        })
    };
    let mesh_path = out.join("bunny.ply");
    std::fs::write(&mesh_path, BUNNY).with_context(|| format!("cannot write {}", s(&mesh_path)))?;
    let protocol_path = out.join("hu2020.toml");
    std::fs::write(&protocol_path, PROTOCOL)
        .with_context(|| format!("cannot write {}", s(&protocol_path)))?;
    let (mesh, load) = parse_mesh_bytes(BUNNY, &mesh_path, MeshFormat::Ply)?;
    let protocol = Protocol::from_toml(PROTOCOL, "hu2020.toml")?;
    let bars = Bars::new(args.quiet);

    // 1. Stimulus.
    say("1/7 rendering the 48 s stimulus video (12 viewpoints, 3 s holds, 1 s moves)");
    let t = Instant::now();
    let stim_dir = out.join("stimulus");
    render_stimulus(
        &mesh_path,
        &mesh,
        &protocol,
        PROTOCOL,
        &s(&protocol_path),
        &stim_dir,
        &StimulusOptions {
            frames: FrameImages::Keyframes,
            id_buffer: false,
            verify: false,
        },
        &bars,
    )
    .map_err(anyhow::Error::msg)?;
    step(
        "stimulus",
        t,
        "stimulus/stimulus.mp4, timeline.csv, manifest.json, frames/",
    );

    // 2. Virtual observers.
    say(&format!(
        "2/7 simulating {} virtual observers (SMI RED250 exports)",
        args.subjects
    ));
    let t = Instant::now();
    let rec_dir = out.join("recordings");
    // The fast middle steps run quietly; the demo reports their results in one line each.
    let q = vec!["--quiet".to_string()];
    let mut argv = vec![
        "--stimulus".into(),
        s(&stim_dir),
        "-o".into(),
        s(&rec_dir),
        "--subjects".into(),
        args.subjects.to_string(),
        "--seed".into(),
        args.seed.to_string(),
    ];
    argv.extend(q.clone());
    super::simulate::run(args_of(&argv)?)?;
    step(
        "simulate",
        t,
        "recordings/sNN_samples.txt (A), sNN_events.txt (C1), targets.csv",
    );

    // 3. Ingest.
    say("3/7 ingesting the recordings: I-DT fixations, drop 2 first / 2 last, keep 15 longest");
    let t = Instant::now();
    let ing_dir = out.join("ingest");
    let mut argv: Vec<String> = (1..=args.subjects)
        .map(|k| s(&rec_dir.join(format!("s{k:02}_samples.txt"))))
        .collect();
    argv.extend([
        "-o".into(),
        s(&ing_dir),
        "--protocol".into(),
        s(&protocol_path),
    ]);
    argv.extend(q.clone());
    super::ingest::run(args_of(&argv)?)?;
    step(
        "ingest",
        t,
        "ingest/fixations.csv, quality.csv, ingest.json",
    );

    // 4. Projection.
    say("4/7 projecting fixations onto the mesh (BVH, watertight rays, nearest vertex)");
    let t = Instant::now();
    let proj_dir = out.join("projection");
    let mut argv = vec![
        "--stimulus".into(),
        s(&stim_dir),
        "--fixations".into(),
        s(&ing_dir.join("fixations.csv")),
        "-o".into(),
        s(&proj_dir),
        "--targets".into(),
        s(&rec_dir.join("targets.csv")),
    ];
    argv.extend(q.clone());
    super::project::run(args_of(&argv)?)?;
    step("project", t, "projection/projected.csv, project.json");
    let pj: serde_json::Value =
        serde_json::from_slice(&std::fs::read(proj_dir.join("project.json"))?)?;
    let totals = pj["totals"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter(|(_, v)| v.as_u64() != Some(0))
                .map(|(k, v)| format!("{v} {k}"))
                .collect::<Vec<_>>()
                .join(", ")
        })
        .unwrap_or_default();
    say(&format!(
        "    fates: {totals}; self-check {}+{} sub-pixel of {}; round trip {}/{} within 1° of the true target",
        pj["self_check"]["agreed"],
        pj["self_check"]["sub_pixel"],
        pj["self_check"]["checked"],
        pj["round_trip"]["within_1deg"],
        pj["round_trip"]["matched"]
    ));

    // 5. Ground truth.
    say("5/7 building the ground truth and the split-half human ceiling");
    let t = Instant::now();
    let truth_dir = out.join("truth");
    let stim = load_stimulus(&stim_dir, None).map_err(anyhow::Error::msg)?;
    let projections = read_projections(&stim, &[proj_dir.join("projected.csv")])?;
    let truth = build_truth(&stim, projections, &TruthParams::default(), &bars)?;
    write_truth(&truth_dir, &stim, &truth)?;
    step(
        "truth",
        t,
        "truth/truth.csv, density.csv, truth.ply, human.csv, truth.json",
    );

    // 6. Saliency.
    say("6/7 computing saliency: SMS (the paper's method), MS (Lee 2005), MC (mean curvature)");
    let t = Instant::now();
    let sal_dir = out.join("saliency");
    let mut maps = Vec::new();
    let mut seconds = Vec::new();
    let mut ginis = Vec::new();
    for method in [Method::Sms, Method::Ms, Method::Mc] {
        let r = compute_and_write_map(
            &mesh_path,
            &mesh,
            &load,
            InputFile::hash(&mesh_path)?,
            method,
            &SmsParams::default(),
            MapOutputs::default(),
            &sal_dir.join(format!("bunny_{}", method.name())),
            &meshgaze::progress::Silent,
        )?;
        seconds.push((method.name().to_string(), r.seconds));
        ginis.push((method.name(), r.gini));
        maps.push((method.name().to_string(), r.values));
    }
    step("saliency", t, "saliency/bunny_{sms,ms,mc}.csv, .ply, .json");

    // 7. Scores and report.
    say("7/7 scoring against the ground truth and writing report.html");
    let t = Instant::now();
    let score_dir = out.join("score");
    std::fs::create_dir_all(&score_dir)?;
    let params = ScoreParams::default();
    let score =
        score_mesh(&mesh, &truth.truth, &maps, &params, &bars).map_err(anyhow::Error::msg)?;
    let mut csv = format!("{SCORE_CSV_HEADER}\n").into_bytes();
    write_score_rows(&mut csv, "bunny", &score.rows)?;
    std::fs::write(score_dir.join("score.csv"), csv)?;
    std::fs::write(
        score_dir.join("score.json"),
        serde_json::to_string_pretty(&score.summaries)? + "\n",
    )?;
    let plots = write_score_plots(&score_dir.join("score"), "bunny", &maps, &score)?;
    step(
        "score",
        t,
        "score/score.csv, score.json, AUC and Lorenz plots",
    );
    let report = out.join("report.html");
    write_report(
        &report,
        &ReportInputs {
            out_dir: out,
            stim: &stim,
            truth: &truth,
            maps: &maps,
            method_seconds: &seconds,
            score: &score,
            plots: &plots,
            steps: &steps,
            total_seconds: t_all.elapsed().as_secs_f64(),
        },
    )?;
    if !args.quiet {
        for m in &score.summaries {
            let gini = ginis
                .iter()
                .find(|g| g.0 == m.method)
                .map_or(String::new(), |g| format!("; Gini {:.3}", g.1));
            eprintln!(
                "  {:<7} AUC-Judd {:.3} unblurred, {:.3} peak at σ_b {:.2}{gini}",
                m.method, m.auc_judd_unblurred, m.auc_judd_peak, m.auc_judd_peak_blur
            );
        }
        eprintln!(
            "  human   AUC-Judd {:.3} peak at σ_b {:.2} (split-half ceiling)",
            truth.sidecar.human_auc_judd_peak, truth.sidecar.human_auc_judd_peak_blur
        );
        eprintln!(
            "meshgaze demo: done in {:.1} s. Open {} in a browser.",
            t_all.elapsed().as_secs_f64(),
            report.display()
        );
    }
    println!("{}", report.display());
    Ok(())
}

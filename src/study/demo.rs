//! The demo: the whole pipeline end to end on one mesh with virtual observers, written as
//! the single-mesh commands write each stage (`meshgaze demo` runs it on the bundled bunny).
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::error::{OrStage, StudyError};

type Result<T, E = StudyError> = std::result::Result<T, E>;

use crate::file_bytes::create_output_dir;
use crate::gaze::ingest::{ingest_files, write_ingest, IngestParams};
use crate::mesh::{parse_mesh_bytes, LoadReport, Mesh, MeshFormat};
use crate::progress::{Progress, Silent};
use crate::projection::project_file::{project_files, write_projection, ProjectOptions};
use crate::protocol::Protocol;
use crate::provenance::InputFile;
use crate::report::demo_report::{write_report, ReportInputs, StepTiming};
use crate::report::score_plots::write_score_plots;
use crate::saliency::map_file::{compute_and_write_map, MapOutputs};
use crate::saliency::{SmsParams, PAPER_METHODS};
use crate::scoring::dataset::{write_score_rows, SCORE_CSV_HEADER};
use crate::scoring::{score_mesh, MeshScore, ScoreParams};
use crate::simulate::{
    extremity_map, simulate_observers, write_simulation, ObserverParams, RecordingFormat,
    TargetModel,
};
use crate::stimulus::load::{load_stimulus, LoadedStimulus};
use crate::stimulus::{render_stimulus, FrameImages, StimulusOptions};
use crate::truth::{build_truth, read_projections, write_truth, TruthParams, TruthResult};

fn s(p: &Path) -> String {
    p.display().to_string()
}

/// What the demo runs on: the mesh and protocol as bytes (the binary bundles the bunny and
/// hu2020), where it writes, and the virtual observers.
pub struct DemoInputs<'a> {
    /// The mesh file's bytes (PLY).
    pub mesh_bytes: &'a [u8],
    /// The protocol's TOML text.
    pub protocol_toml: &'a str,
    /// The output folder.
    pub output: &'a Path,
    /// Virtual observers.
    pub subjects: usize,
    /// Seed of the virtual observers (the other steps use their own default seeds).
    pub seed: u64,
}

/// What the demo made, for the caller to print.
pub struct DemoOutcome {
    /// report.html.
    pub report: PathBuf,
    /// The seven maps' scores against the observers' truth.
    pub score: MeshScore,
    /// Gini index of each method's map.
    pub ginis: Vec<(&'static str, f64)>,
    /// The truth built from the observers.
    pub truth: TruthResult,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
}

/// Runs the whole pipeline end to end on one mesh: stimulus, virtual observers (SMI exports),
/// ingest, projection, ground truth, the paper's seven methods, scores and report.html, each
/// stage's outputs in OUT's subfolders as the single-mesh commands write them. `say` gets one
/// line per step.
pub fn run_demo(
    inputs: &DemoInputs,
    progress: &dyn Progress,
    say: &dyn Fn(&str),
) -> Result<DemoOutcome> {
    let t_all = Instant::now();
    let out = inputs.output;
    std::fs::create_dir_all(out).map_err(StudyError::io("create", &out))?;
    let mut steps = StepLog(Vec::new());
    let mesh_path = out.join("bunny.ply");
    std::fs::write(&mesh_path, inputs.mesh_bytes).map_err(StudyError::io("write", &mesh_path))?;
    let protocol_path = out.join("hu2020.toml");
    std::fs::write(&protocol_path, inputs.protocol_toml)
        .map_err(StudyError::io("write", &protocol_path))?;
    let (mesh, load) =
        parse_mesh_bytes(inputs.mesh_bytes, &mesh_path, MeshFormat::Ply).or_stage()?;
    let protocol = Protocol::from_toml(inputs.protocol_toml, "hu2020.toml").or_stage()?;
    let stage = DemoStage {
        inputs,
        mesh: &mesh,
        mesh_path: &mesh_path,
        protocol: &protocol,
        protocol_path: &protocol_path,
        progress,
        say,
    };
    let (stim, rec_dir, ing_dir) = stage.record(&mut steps)?;
    let truth = stage.truth_of(&stim, &rec_dir, &ing_dir, &mut steps)?;

    // 6. Saliency.
    say("6/7 computing saliency: SMS (the paper's method) and its six competitors MC, MS, SI, SRI, MR, GR");
    let t = Instant::now();
    let sal_dir = out.join("saliency");
    let (maps, seconds, ginis) = saliency_step(&mesh_path, &mesh, &load, &sal_dir)?;
    steps.done(
        "saliency",
        t,
        "saliency/bunny_{sms,mc,ms,si,sri,mr,gr}.csv, .ply, .json",
    );

    // 7. Scores and report.
    say("7/7 scoring against the ground truth and writing report.html");
    let t = Instant::now();
    let seen = crate::stimulus::hold_views::hold_view_exposure(&mesh, &protocol)
        .or_stage()?
        .seen();
    let (score, plots) = score_step(&mesh, &seen, &truth, &maps, &out.join("score"), progress)?;
    steps.done(
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
            steps: &steps.0,
            total_seconds: t_all.elapsed().as_secs_f64(),
        },
    )
    .or_stage()?;
    Ok(DemoOutcome {
        report,
        score,
        ginis,
        truth,
        seconds: t_all.elapsed().as_secs_f64(),
    })
}

/// Each step's seconds and outputs, for the report.
struct StepLog(Vec<StepTiming>);

impl StepLog {
    fn done(&mut self, name: &str, started: Instant, outputs: &str) {
        self.0.push(StepTiming {
            name: name.to_string(),
            seconds: started.elapsed().as_secs_f64(),
            outputs: outputs.to_string(),
        })
    }
}

/// What every step of the demo reads.
struct DemoStage<'a> {
    inputs: &'a DemoInputs<'a>,
    mesh: &'a Mesh,
    mesh_path: &'a Path,
    protocol: &'a Protocol,
    protocol_path: &'a Path,
    progress: &'a dyn Progress,
    say: &'a dyn Fn(&str),
}

impl DemoStage<'_> {
    /// Steps 1–3: the stimulus, the virtual observers' recordings, and their fixations.
    /// Returns the stimulus and the recordings' and ingest's folders.
    fn record(&self, steps: &mut StepLog) -> Result<(LoadedStimulus, PathBuf, PathBuf)> {
        let (inputs, say, out) = (self.inputs, self.say, self.inputs.output);
        say("1/7 rendering the 48 s stimulus video (12 viewpoints, 3 s holds, 1 s moves)");
        let t = Instant::now();
        let stim_dir = out.join("stimulus");
        render_stimulus(
            self.mesh_path,
            self.mesh,
            self.protocol,
            inputs.protocol_toml,
            &s(self.protocol_path),
            &stim_dir,
            &StimulusOptions {
                frames: FrameImages::Keyframes,
                id_buffer: false,
                verify: false,
            },
            self.progress,
        )
        .or_stage()?;
        steps.done(
            "stimulus",
            t,
            "stimulus/stimulus.mp4, timeline.csv, manifest.json, frames/",
        );

        say(&format!(
            "2/7 simulating {} virtual observers (SMI RED250 exports)",
            inputs.subjects
        ));
        let t = Instant::now();
        let rec_dir = out.join("recordings");
        let stim = load_stimulus(&stim_dir, None).or_stage()?;
        simulate_step(&stim, &rec_dir, inputs.subjects, inputs.seed)?;
        steps.done(
            "simulate",
            t,
            "recordings/sNN_samples.txt (A), sNN_events.txt (C1), targets.csv",
        );

        say("3/7 ingesting the recordings: I-DT fixations, drop 2 first / 2 last, keep 15 longest");
        let t = Instant::now();
        let ing_dir = out.join("ingest");
        ingest_step(self.protocol, &rec_dir, &ing_dir, inputs.subjects)?;
        steps.done(
            "ingest",
            t,
            "ingest/fixations.csv, quality.csv, ingest.json",
        );
        Ok((stim, rec_dir, ing_dir))
    }

    /// Steps 4–5: the fixations projected onto the mesh, and the ground truth built from them.
    fn truth_of(
        &self,
        stim: &LoadedStimulus,
        rec_dir: &Path,
        ing_dir: &Path,
        steps: &mut StepLog,
    ) -> Result<TruthResult> {
        let (say, out) = (self.say, self.inputs.output);
        say("4/7 projecting fixations onto the mesh (BVH, watertight rays, nearest vertex)");
        let t = Instant::now();
        let proj_dir = out.join("projection");
        let options = ProjectOptions {
            targets: Some(rec_dir.join("targets.csv")),
            self_check: true,
            ..ProjectOptions::default()
        };
        let run =
            project_files(stim, &[ing_dir.join("fixations.csv")], &options, &Silent).or_stage()?;
        write_projection(&proj_dir, &run).or_stage()?;
        steps.done("project", t, "projection/projected.csv, project.json");
        let pj: serde_json::Value =
            serde_json::from_slice(&std::fs::read(proj_dir.join("project.json")).or_stage()?)
                .or_stage()?;
        say(&projection_summary(&pj));

        say("5/7 building the ground truth and the split-half human ceiling");
        let t = Instant::now();
        let truth_dir = out.join("truth");
        let projections = read_projections(stim, &[proj_dir.join("projected.csv")]).or_stage()?;
        let truth =
            build_truth(stim, projections, &TruthParams::default(), self.progress).or_stage()?;
        write_truth(&truth_dir, stim, &truth).or_stage()?;
        steps.done(
            "truth",
            t,
            "truth/truth.csv, density.csv, truth.ply, human.csv, truth.json",
        );
        Ok(truth)
    }
}

/// Step 2: virtual observers drawn by the extremity model, written as SMI exports.
fn simulate_step(stim: &LoadedStimulus, rec_dir: &Path, subjects: usize, seed: u64) -> Result<()> {
    let params = ObserverParams {
        subjects,
        seed,
        ..ObserverParams::default()
    };
    let stimulus_name = format!("{}.mp4", stim.mesh_stem());
    let simulated = simulate_observers(
        &stim.mesh,
        &stim.plan,
        &stim.protocol,
        &TargetModel::Saliency(extremity_map(&stim.mesh)),
        &stimulus_name,
        &params,
    )
    .or_stage()?;
    write_simulation(
        rec_dir,
        &simulated,
        vec![
            InputFile::hash(&stim.manifest_path).or_stage()?,
            InputFile::hash(&stim.mesh_path).or_stage()?,
        ],
        &stimulus_name,
        "extremity (distance from the centroid)",
        &params,
        RecordingFormat::Smi,
    )
    .or_stage()
}

/// Step 3: the subjects' format-A recordings through ingest with the protocol's rules.
fn ingest_step(protocol: &Protocol, rec_dir: &Path, ing_dir: &Path, subjects: usize) -> Result<()> {
    let params = IngestParams::from_protocol(protocol, None).or_stage()?;
    let paths: Vec<PathBuf> = (1..=subjects)
        .map(|k| rec_dir.join(format!("s{k:02}_samples.txt")))
        .collect();
    let (files, inputs) = ingest_files(&paths, &params).or_stage()?;
    write_ingest(ing_dir, &files, inputs, protocol, &params).or_stage()?;
    Ok(())
}

/// One line on the projection: fates, the self-check and the round trip.
fn projection_summary(pj: &serde_json::Value) -> String {
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
    format!(
        "    fates: {totals}; self-check {}+{} sub-pixel of {}; round trip {}/{} within 1° of the true target",
        pj["self_check"]["agreed"],
        pj["self_check"]["sub_pixel"],
        pj["self_check"]["checked"],
        pj["round_trip"]["within_1deg"],
        pj["round_trip"]["matched"]
    )
}

/// The maps the demo scores, with their seconds and Gini indices.
type DemoMaps = (
    Vec<(String, Vec<f64>)>,
    Vec<(String, f64)>,
    Vec<(&'static str, f64)>,
);

/// Step 6: the paper's seven methods, each written as the `saliency` command writes it.
fn saliency_step(
    mesh_path: &Path,
    mesh: &Mesh,
    load: &LoadReport,
    sal_dir: &Path,
) -> Result<DemoMaps> {
    let mut maps = Vec::new();
    let mut seconds = Vec::new();
    let mut ginis = Vec::new();
    for method in PAPER_METHODS {
        let r = compute_and_write_map(
            mesh_path,
            mesh,
            load,
            InputFile::hash(mesh_path).or_stage()?,
            method,
            &SmsParams::default(),
            &crate::saliency::Viewing::builtin(),
            MapOutputs::default(),
            &sal_dir.join(format!("bunny_{}", method.name())),
            &Silent,
        )
        .or_stage()?;
        seconds.push((method.name().to_string(), r.seconds));
        ginis.push((method.name(), r.gini));
        maps.push((method.name().to_string(), r.values));
    }
    Ok((maps, seconds, ginis))
}

/// Step 7: the maps scored against the truth: score.csv, score.json and the charts.
fn score_step(
    mesh: &Mesh,
    seen: &[bool],
    truth: &TruthResult,
    maps: &[(String, Vec<f64>)],
    score_dir: &Path,
    bars: &dyn Progress,
) -> Result<(MeshScore, Vec<String>)> {
    create_output_dir(score_dir).or_stage()?;
    let score = score_mesh(
        mesh,
        &truth.truth,
        maps,
        &ScoreParams::default(),
        Some(seen),
        bars,
    )
    .or_stage()?;
    let mut csv = format!("{SCORE_CSV_HEADER}\n").into_bytes();
    write_score_rows(&mut csv, "bunny", &score.rows).or_stage()?;
    std::fs::write(score_dir.join("score.csv"), csv).or_stage()?;
    std::fs::write(
        score_dir.join("score.json"),
        serde_json::to_string_pretty(&score.summaries).or_stage()? + "\n",
    )
    .or_stage()?;
    let plots = write_score_plots(&score_dir.join("score"), "bunny", maps, &score).or_stage()?;
    Ok((score, plots))
}

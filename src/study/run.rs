//! Running a study like `make`: every step writes its outputs, then a stamp holding the hash of
//! its inputs; a step whose stamp matches is skipped. Every mesh is an independent job, so meshes
//! run in parallel (`jobs`) or in shards on separate machines (`shard`), and a run killed at any
//! point redoes only the steps without a stamp.
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

use super::error::{OrStage, StudyError};

type Result<T, E = StudyError> = std::result::Result<T, E>;
use rayon::prelude::*;
use serde::Serialize;

use super::config::{stem_of, Study, StudyMesh};
use crate::file_bytes::create_output_dir;
use crate::gaze::ingest::{check_one_source_per_subject, ingest_file, write_ingest, IngestParams};
use crate::mesh::load_mesh;
use crate::progress::{Progress, Silent};
use crate::projection::project_file::{project_files, write_projection, ProjectOptions};
use crate::provenance::{sha256_hex, InputFile};
use crate::report::mesh_page::{write_mesh_page, MeshPage};
use crate::report::study_report::{write_chance_draws, write_study_report};
use crate::saliency::map_file::{compute_and_write_map, read_map, MapOutputs};
use crate::saliency::SmsParams;
use crate::scoring::dataset::{write_score_rows, SCORE_CSV_HEADER};
use crate::scoring::{score_mesh, ScoreParams};
use crate::stimulus::hold_views::hold_view_exposure;
use crate::stimulus::load::{load_stimulus, LoadedStimulus};
use crate::stimulus::{render_stimulus, FrameImages, StimulusOptions};
use crate::truth::{build_truth, read_projections, write_truth, TruthParams};

const STAMP: &str = ".meshgaze-stamp";

/// How a run is split and shown.
#[derive(Debug, Clone, Copy)]
pub struct RunOptions {
    /// (i, n): run the i-th (1-based) of n shares of the meshes.
    pub shard: Option<(usize, usize)>,
    /// Meshes processed at once.
    pub jobs: usize,
}

/// What happened to one step.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StepLog {
    /// The mesh (`*` for the study-wide ingest).
    pub mesh: String,
    /// `stimulus`, `ingest`, `project`, `truth`, `saliency` or `score`.
    pub step: String,
    /// `done`, `up-to-date`, `skipped` or `failed`.
    pub outcome: &'static str,
    /// What it wrote, or why it failed.
    pub detail: String,
    /// Wall-clock seconds the step took (the ingest of every recording for `ingest`).
    pub seconds: f64,
}

/// A mesh job's log in the making: each step pushed gets the seconds since the previous one
/// (the steps of one mesh run one after another, so the gaps are the steps' own times).
struct StepClock<'a> {
    logs: &'a mut Vec<StepLog>,
    last: Instant,
}

impl StepClock<'_> {
    fn push(&mut self, mut step: StepLog) {
        let now = Instant::now();
        step.seconds = (now - self.last).as_secs_f64();
        self.last = now;
        self.logs.push(step);
    }
}

/// The run's account, as study.json and the log show it.
#[derive(Debug, Clone, Serialize)]
pub struct StudyRun {
    /// Every step, in order.
    pub steps: Vec<StepLog>,
    /// Problems that did not stop the study (a video no mesh has, a mesh no recording shows,
    /// an unreadable recording).
    pub problems: Vec<String>,
    /// The meshes this run (or shard) took.
    pub meshes_in_shard: Vec<String>,
    /// Recordings of the study.
    pub recordings: usize,
}

/// The stable share of a mesh among `n`: from a hash of its name, so adding a mesh does not
/// move the others.
pub fn shard_of(name: &str, n: usize) -> usize {
    let h = sha256_hex(name.as_bytes());
    let v = u64::from_str_radix(&h[..15], 16).unwrap_or(0);
    (v % n as u64) as usize + 1
}

fn key_of(parts: &[&str]) -> String {
    let mut text = format!("meshgaze {}\n", env!("CARGO_PKG_VERSION"));
    for p in parts {
        text.push_str(p);
        text.push('\n');
    }
    sha256_hex(text.as_bytes())
}

fn stamped(dir: &Path, key: &str) -> bool {
    std::fs::read_to_string(dir.join(STAMP)).is_ok_and(|k| k.trim() == key)
}

fn stamp(dir: &Path, key: &str) -> Result<()> {
    let p = dir.join(STAMP);
    std::fs::write(&p, format!("{key}\n")).map_err(StudyError::io("write", &p))
}

fn hash_file(p: &Path) -> Result<String> {
    Ok(InputFile::hash(p)
        .map_err(StudyError::io("read", &p))?
        .sha256)
}

/// Runs a study (see `meshgaze study run --help`).
pub fn run_study(study: &Study, options: &RunOptions, progress: &dyn Progress) -> Result<StudyRun> {
    let out = &study.output;
    create_output_dir(out).or_stage()?;
    let mut problems: Vec<String> = study.unmatched.clone();
    let meshes: Vec<&StudyMesh> = study
        .meshes
        .iter()
        .filter(|m| options.shard.is_none_or(|(i, n)| shard_of(&m.name, n) == i))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(options.jobs.max(1))
        .build()
        .map_err(|e| StudyError::Invalid(format!("cannot start the worker threads: {e}")))?;
    let protocol_hash = sha256_hex(study.protocol_text.as_bytes());

    // 1. Stimuli: every mesh of the shard, whether or not recordings exist yet.
    progress.start("stimuli", meshes.len() as u64);
    let stimulus_logs: Vec<StepLog> = pool.install(|| {
        meshes
            .par_iter()
            .map(|m| {
                let r = ensure_stimulus(study, m, &protocol_hash);
                progress.advance(1);
                r
            })
            .collect()
    });
    progress.finish();
    let mut steps = stimulus_logs;
    for s in steps.iter().filter(|s| s.outcome == "failed") {
        problems.push(format!("mesh `{}`: {}", s.mesh, s.detail));
    }

    // 2. Ingest: every recording, once (each shard does the same, with the same bytes).
    if study.recordings.is_empty() {
        problems.push(
            "no recordings found yet: the stimuli are rendered; record the subjects watching them, then run the study again".to_string(),
        );
        return finish(study, steps, problems, &meshes, 0);
    }
    let t_ingest = Instant::now();
    let (mut ingest_log, ingest_problems) = ingest_all(study, &protocol_hash)?;
    ingest_log.seconds = t_ingest.elapsed().as_secs_f64();
    steps.push(ingest_log);
    problems.extend(ingest_problems);
    let fixations_csv = out.join("ingest").join("fixations.csv");
    let stimuli_seen = stimuli_in(&fixations_csv)?;
    let mut other_images = Vec::new();
    for s in &stimuli_seen {
        if study.meshes.iter().any(|m| m.name == stem_of(Path::new(s))) {
            continue;
        }
        let is_video = s.rsplit_once('.').is_some_and(|(_, e)| {
            [
                "avi", "mp4", "m4v", "mov", "mkv", "wmv", "mpg", "mpeg", "webm", "flv", "ogv",
                "3gp",
            ]
            .iter()
            .any(|v| e.eq_ignore_ascii_case(v))
        });
        if is_video {
            problems.push(format!(
                "the recordings show the video `{s}`, but no mesh of the study is named `{}`",
                stem_of(Path::new(s))
            ));
        } else {
            other_images.push(s.as_str());
        }
    }
    if !other_images.is_empty() {
        problems.push(format!(
            "other stimuli in the recordings, not videos of this study (their fixations are not used): {}",
            other_images.join(", ")
        ));
    }

    // 3. Per mesh: project, truth, saliency, score.
    progress.start("meshes", meshes.len() as u64);
    let per_mesh: Vec<(Vec<StepLog>, Vec<String>)> = pool.install(|| {
        meshes
            .par_iter()
            .map(|m| {
                let failed = steps
                    .iter()
                    .any(|s| s.mesh == m.name && s.step == "stimulus" && s.outcome == "failed");
                let r = mesh_job(study, m, &fixations_csv, &stimuli_seen, failed);
                progress.advance(1);
                r
            })
            .collect()
    });
    progress.finish();
    for (logs, p) in per_mesh {
        steps.extend(logs);
        problems.extend(p);
    }
    finish(study, steps, problems, &meshes, study.recordings.len())
}

fn finish(
    study: &Study,
    steps: Vec<StepLog>,
    problems: Vec<String>,
    meshes: &[&StudyMesh],
    recordings: usize,
) -> Result<StudyRun> {
    let run = StudyRun {
        steps,
        problems,
        meshes_in_shard: meshes.iter().map(|m| m.name.clone()).collect(),
        recordings,
    };
    merge_scores(study)?;
    write_study_json(study, &run)?;
    write_study_report(&study.output, &run.problems).or_stage()?;
    let log = study.output.join("run.log");
    let mut w = std::fs::File::create(&log).map_err(StudyError::io("create", &log))?;
    for s in &run.steps {
        // Seconds before the detail, which may be long free text.
        writeln!(
            w,
            "{}\t{}\t{}\t{:.3}\t{}",
            s.mesh, s.step, s.outcome, s.seconds, s.detail
        )
        .or_stage()?;
    }
    for p in &run.problems {
        writeln!(w, "problem\t{p}").or_stage()?;
    }
    Ok(run)
}

/// OUT/study.json: the provenance of every input (study.toml, protocol, meshes, recordings),
/// the methods and this run's steps and problems.
fn write_study_json(study: &Study, run: &StudyRun) -> Result<()> {
    let mut inputs =
        vec![InputFile::hash(&study.file).map_err(StudyError::io("read", &study.file))?];
    inputs.push(InputFile::of_bytes(
        &format!("protocol {}", study.protocol_name),
        study.protocol_text.as_bytes(),
    ));
    for m in &study.meshes {
        inputs.push(InputFile::hash(&m.path).map_err(StudyError::io("read", &m.path))?);
    }
    for r in &study.recordings {
        inputs.push(InputFile::hash(r).map_err(StudyError::io("read", &r))?);
    }
    #[derive(Serialize)]
    struct StudyJson<'a> {
        provenance: crate::provenance::Provenance,
        methods: Vec<&'static str>,
        /// The study's `set` lines and every parameter of sri, gr and mr they give.
        settings: &'a [String],
        rarity: &'a crate::saliency::RarityParams,
        output: String,
        run: &'a StudyRun,
    }
    let json = StudyJson {
        provenance: crate::provenance::Provenance::new(inputs),
        methods: study.methods.iter().map(|m| m.name()).collect(),
        settings: &study.settings,
        rarity: &study.rarity,
        output: study.output.display().to_string(),
        run,
    };
    let path = study.output.join("study.json");
    std::fs::write(&path, serde_json::to_vec_pretty(&json).or_stage()?)
        .map_err(StudyError::io("write", &path))
}

fn log(mesh: &str, step: &str, outcome: &'static str, detail: impl Into<String>) -> StepLog {
    StepLog {
        mesh: mesh.to_string(),
        step: step.to_string(),
        outcome,
        detail: detail.into(),
        seconds: 0.0,
    }
}

fn ensure_stimulus(study: &Study, m: &StudyMesh, protocol_hash: &str) -> StepLog {
    let t0 = Instant::now();
    let dir = study.output.join("stimuli").join(&m.name);
    let attempt = || -> Result<&'static str> {
        let key = key_of(&["stimulus", &hash_file(&m.path)?, protocol_hash]);
        if stamped(&dir, &key) {
            return Ok("up-to-date");
        }
        // Once recordings exist, the videos were shown: a mesh or protocol that changed since
        // cannot get a new video, or its fixations would land on a shape nobody saw.
        if dir.join(STAMP).exists() && !study.recordings.is_empty() {
            return Err(StudyError::Changed(format!(
                "{} (or the protocol) changed after its video was rendered and shown: the subjects saw the old one, so it is not re-rendered and its fixations are not projected; restore the old file, or start a new study for the new mesh",
                m.path.display()
            )));
        }
        let (mesh, _) = load_mesh(&m.path).or_stage()?;
        render_stimulus(
            &m.path,
            &mesh,
            &study.protocol,
            &study.protocol_text,
            &study.protocol_name,
            &dir,
            &StimulusOptions {
                frames: FrameImages::None,
                id_buffer: false,
                verify: false,
            },
            &Silent,
        )
        .or_stage()?;
        stamp(&dir, &key)?;
        Ok("done")
    };
    let mut step = match attempt() {
        Ok(o) => log(&m.name, "stimulus", o, format!("{}", dir.display())),
        Err(e) => log(&m.name, "stimulus", "failed", format!("{e:#}")),
    };
    step.seconds = t0.elapsed().as_secs_f64();
    step
}

fn ingest_params(study: &Study) -> Result<IngestParams> {
    let pattern = study
        .stimulus_pattern
        .as_deref()
        .map(|p| (p, study.stimulus_end_pattern.as_deref()));
    IngestParams::from_protocol(&study.protocol, pattern).map_err(|e| StudyError::Config {
        path: study.file.clone(),
        message: e.to_string(),
    })
}

/// Ingests every recording into OUT/ingest; a recording that cannot be read is reported and
/// left out, the others go on.
fn ingest_all(study: &Study, protocol_hash: &str) -> Result<(StepLog, Vec<String>)> {
    let dir = study.output.join("ingest");
    let mut parts = vec!["ingest".to_string(), protocol_hash.to_string()];
    parts.push(format!(
        "{:?}{:?}",
        study.stimulus_pattern, study.stimulus_end_pattern
    ));
    for r in &study.recordings {
        parts.push(hash_file(r)?);
    }
    let refs: Vec<&str> = parts.iter().map(String::as_str).collect();
    let key = key_of(&refs);
    let problems_file = dir.join("problems.txt");
    if stamped(&dir, &key) {
        let problems = std::fs::read_to_string(&problems_file)
            .unwrap_or_default()
            .lines()
            .map(str::to_string)
            .collect();
        return Ok((
            log("*", "ingest", "up-to-date", dir.display().to_string()),
            problems,
        ));
    }
    let params = ingest_params(study)?;
    let mut files = Vec::new();
    let mut problems = Vec::new();
    for r in &study.recordings {
        match ingest_file(r, &params) {
            Ok(f) => files.push(f),
            Err(e) => problems.push(format!("recording left out: {e}")),
        }
    }
    check_one_source_per_subject(&files).map_err(|e| StudyError::Invalid(e.to_string()))?;
    for f in &files {
        problems.extend(f.warnings.iter().cloned());
    }
    let inputs = files
        .iter()
        .map(|f| InputFile::hash(&f.path))
        .collect::<std::io::Result<Vec<_>>>()
        .or_stage()?;
    let (fixations, _) = write_ingest(&dir, &files, inputs, &study.protocol, &params).or_stage()?;
    std::fs::write(
        &problems_file,
        problems
            .iter()
            .map(|p| format!("{p}\n"))
            .collect::<String>(),
    )
    .or_stage()?;
    stamp(&dir, &key)?;
    Ok((
        log(
            "*",
            "ingest",
            "done",
            format!("{} recordings, {fixations} fixations", files.len()),
        ),
        problems,
    ))
}

/// The distinct stimulus names in a fixations.csv.
fn stimuli_in(fixations_csv: &Path) -> Result<Vec<String>> {
    let rows = crate::gaze::fixation_table::read_fixations_csv(fixations_csv).or_stage()?;
    let mut names: Vec<String> = rows
        .into_iter()
        .map(|r| r.stimulus)
        .filter(|s| !s.is_empty())
        .collect();
    names.sort();
    names.dedup();
    Ok(names)
}

fn mesh_job(
    study: &Study,
    m: &StudyMesh,
    fixations_csv: &Path,
    stimuli_seen: &[String],
    stimulus_failed: bool,
) -> (Vec<StepLog>, Vec<String>) {
    let mut log_lines = Vec::new();
    let mut logs = StepClock {
        logs: &mut log_lines,
        last: Instant::now(),
    };
    let mut problems = Vec::new();
    if stimulus_failed {
        logs.push(log(&m.name, "project", "skipped", "its stimulus failed"));
        return (log_lines, problems);
    }
    let shown: Vec<&String> = stimuli_seen
        .iter()
        .filter(|s| stem_of(Path::new(s.as_str())) == m.name)
        .collect();
    let name = match shown.as_slice() {
        [] => {
            problems.push(format!(
                "mesh `{}`: no recording shows it (no message names {}.*)",
                m.name, m.name
            ));
            logs.push(log(
                &m.name,
                "project",
                "skipped",
                "no recording shows this mesh",
            ));
            return (log_lines, problems);
        }
        [one] => (*one).clone(),
        several => {
            problems.push(format!(
                "mesh `{}`: several stimuli map to it ({}); using {}",
                m.name,
                several
                    .iter()
                    .map(|s| s.as_str())
                    .collect::<Vec<_>>()
                    .join(", "),
                several[0]
            ));
            several[0].clone()
        }
    };
    if let Err(e) = mesh_steps(study, m, fixations_csv, &name, &mut logs) {
        logs.push(log(&m.name, "mesh", "failed", format!("{e:#}")));
        problems.push(format!("mesh `{}`: {e:#}", m.name));
    }
    (log_lines, problems)
}

fn mesh_steps(
    study: &Study,
    m: &StudyMesh,
    fixations_csv: &Path,
    name: &str,
    logs: &mut StepClock,
) -> Result<()> {
    let stim = load_unchanged_stimulus(study, m)?;
    let projected = project_step(study, m, &stim, fixations_csv, name, logs)?;
    let truth_dir = truth_step(study, m, &stim, &projected, logs)?;
    let maps = saliency_step(study, m, &stim, logs)?;
    score_step(study, m, &stim, &truth_dir, &maps, logs)
}

/// The mesh's stimulus, refused when the mesh file changed after its video was rendered.
fn load_unchanged_stimulus(study: &Study, m: &StudyMesh) -> Result<LoadedStimulus> {
    let stim_dir = study.output.join("stimuli").join(&m.name);
    // The study's own mesh file, not the name in the manifest: the same file (its sha256 is
    // checked against the manifest's), wherever the study is run from.
    let stim = load_stimulus(&stim_dir, Some(&m.path)).map_err(|e| {
        if e.is_changed_after_rendering() {
            StudyError::Changed(format!(
                "{} changed after its video was rendered: the subjects saw the old mesh, so its fixations cannot be projected onto this one ({e})",
                m.path.display()
            ))
        } else {
            StudyError::Stage(e.to_string())
        }
    })?;
    if stim.mesh_sha256 != hash_file(&m.path)? {
        return Err(StudyError::Changed(format!(
            "{} changed after its video was shown: the subjects saw the old mesh (manifest {}), so its fixations are not projected onto the new one; restore the old file or start a new study",
            m.path.display(),
            stim.manifest_path.display()
        )));
    }
    Ok(stim)
}

/// Projects the fixations shown with stimulus `name`; returns projected.csv.
fn project_step(
    study: &Study,
    m: &StudyMesh,
    stim: &LoadedStimulus,
    fixations_csv: &Path,
    name: &str,
    logs: &mut StepClock,
) -> Result<PathBuf> {
    let proj_dir = study.output.join("projection").join(&m.name);
    let key = key_of(&[
        "project",
        &stim.manifest_sha256,
        &hash_file(fixations_csv)?,
        name,
    ]);
    if stamped(&proj_dir, &key) {
        logs.push(log(&m.name, "project", "up-to-date", ""));
    } else {
        let options = ProjectOptions {
            stimulus_name: Some(name.to_string()),
            self_check: true,
            ..ProjectOptions::default()
        };
        let run =
            project_files(stim, &[fixations_csv.to_path_buf()], &options, &Silent).or_stage()?;
        write_projection(&proj_dir, &run).or_stage()?;
        stamp(&proj_dir, &key)?;
        logs.push(log(
            &m.name,
            "project",
            "done",
            format!("{} fixations", run.projected.len()),
        ));
    }
    Ok(proj_dir.join("projected.csv"))
}

/// Builds the mesh's truth from its projections; returns the truth folder.
fn truth_step(
    study: &Study,
    m: &StudyMesh,
    stim: &LoadedStimulus,
    projected: &Path,
    logs: &mut StepClock,
) -> Result<PathBuf> {
    let truth_dir = study.output.join("truth").join(&m.name);
    let key = key_of(&["truth", &stim.manifest_sha256, &hash_file(projected)?]);
    if stamped(&truth_dir, &key) {
        logs.push(log(&m.name, "truth", "up-to-date", ""));
    } else {
        let projections = read_projections(stim, &[projected.to_path_buf()]).or_stage()?;
        let truth = build_truth(stim, projections, &TruthParams::default(), &Silent).or_stage()?;
        write_truth(&truth_dir, stim, &truth).or_stage()?;
        stamp(&truth_dir, &key)?;
        logs.push(log(
            &m.name,
            "truth",
            "done",
            format!("{} fixations on the mesh", truth.sidecar.fixations_on_mesh),
        ));
    }
    Ok(truth_dir)
}

/// Computes (or reads back) every method's map, one file per method.
fn saliency_step(
    study: &Study,
    m: &StudyMesh,
    stim: &LoadedStimulus,
    logs: &mut StepClock,
) -> Result<Vec<(String, Vec<f64>)>> {
    let mut maps = Vec::new();
    for &method in &study.methods {
        let step = format!("saliency {}", method.name());
        let dir = study.output.join("saliency").join(method.name());
        let prefix = dir.join(&m.name);
        let stamp_dir = dir.join(format!(".{}", m.name));
        // A method's own `set` lines are part of its key: changing them recomputes its maps.
        let own: Vec<&str> = study
            .settings
            .iter()
            .filter(|s| s.trim_start().starts_with(&format!("{}.", method.name())))
            .map(String::as_str)
            .collect();
        let mut parts = vec!["saliency", method.name(), &stim.mesh_sha256];
        parts.extend(own);
        let key = key_of(&parts);
        if stamped(&stamp_dir, &key) {
            logs.push(log(&m.name, &step, "up-to-date", ""));
            let values =
                read_map(&prefix.with_extension("csv"), stim.mesh.positions.len()).or_stage()?;
            maps.push((method.name().to_string(), values));
            continue;
        }
        let r = compute_and_write_map(
            &stim.mesh_path,
            &stim.mesh,
            &stim.mesh_report,
            InputFile::hash(&stim.mesh_path).or_stage()?,
            method,
            &SmsParams::default(),
            &crate::saliency::Viewing {
                protocol: study.protocol.clone(),
                model: None,
                rarity: study.rarity.clone(),
            },
            MapOutputs::default(),
            &prefix,
            &Silent,
        )
        .or_stage()?;
        create_output_dir(&stamp_dir).or_stage()?;
        stamp(&stamp_dir, &key)?;
        logs.push(log(&m.name, &step, "done", ""));
        maps.push((method.name().to_string(), r.values));
    }
    Ok(maps)
}

/// Scores the maps against the truth: OUT/scores/MESH.csv, the chance draws in
/// OUT/scores/chance/MESH.csv and the mesh's page OUT/report/MESH.html.
fn score_step(
    study: &Study,
    m: &StudyMesh,
    stim: &LoadedStimulus,
    truth_dir: &Path,
    maps: &[(String, Vec<f64>)],
    logs: &mut StepClock,
) -> Result<()> {
    let out = &study.output;
    let score_dir = out.join("scores");
    let score_file = score_dir.join(format!("{}.csv", m.name));
    let chance_file = score_dir.join("chance").join(format!("{}.csv", m.name));
    let page_file = out.join("report").join(format!("{}.html", m.name));
    let truth_csv = truth_dir.join("truth.csv");
    let mut parts = vec![
        "score".to_string(),
        "visible-negatives".to_string(),
        stim.mesh_sha256.clone(),
        hash_file(&truth_csv)?,
    ];
    parts.extend(study.methods.iter().map(|m| m.name().to_string()));
    let refs: Vec<&str> = parts.iter().map(String::as_str).collect();
    let key = key_of(&refs);
    let stamp_dir = score_dir.join(format!(".{}", m.name));
    if stamped(&stamp_dir, &key)
        && [&score_file, &chance_file, &page_file]
            .iter()
            .all(|f| f.exists())
    {
        logs.push(log(&m.name, "score", "up-to-date", ""));
        return Ok(());
    }
    let truth =
        crate::truth::load_ground_truth(&truth_csv, stim.mesh.positions.len(), 0.05).or_stage()?;
    let seen = hold_view_exposure(&stim.mesh, &stim.protocol)
        .or_stage()?
        .seen();
    let score = score_mesh(
        &stim.mesh,
        &truth,
        maps,
        &ScoreParams::default(),
        Some(&seen),
        &Silent,
    )
    .or_stage()?;
    create_output_dir(&score_dir.join("chance")).or_stage()?;
    let mut bytes = Vec::new();
    write_score_rows(&mut bytes, &m.name, &score.rows).or_stage()?;
    std::fs::write(&score_file, bytes).map_err(StudyError::io("write", &score_file))?;
    write_chance_draws(&chance_file, &score.chance_auc_judd).or_stage()?;
    let density =
        crate::truth::read_density(&truth_dir.join("density.csv"), stim.mesh.positions.len())
            .or_stage()?;
    let truth_json_path = truth_dir.join("truth.json");
    let truth_json: serde_json::Value = serde_json::from_slice(
        &std::fs::read(&truth_json_path).map_err(StudyError::io("read", &truth_json_path))?,
    )
    .map_err(|e| StudyError::Stage(format!("{}: not JSON: {e}", truth_json_path.display())))?;
    let fixations = crate::projection::table::read_projected_csv(&truth_csv).or_stage()?;
    let n = &m.name;
    let mut links = vec![
        (
            format!("stimulus video ({n})"),
            format!("../stimuli/{n}/stimulus.mp4"),
        ),
        (
            "camera timeline".to_string(),
            format!("../stimuli/{n}/timeline.csv"),
        ),
        (
            "projected fixations".to_string(),
            format!("../projection/{n}/projected.csv"),
        ),
        (
            "truth (fixations on vertices)".to_string(),
            format!("../truth/{n}/truth.csv"),
        ),
        (
            "truth on the mesh (PLY)".to_string(),
            format!("../truth/{n}/truth.ply"),
        ),
        ("scores".to_string(), format!("../scores/{n}.csv")),
    ];
    for (method, _) in maps {
        links.push((
            format!("{method} map"),
            format!("../saliency/{method}/{n}.csv"),
        ));
    }
    write_mesh_page(
        &out.join("report"),
        &MeshPage {
            name: n,
            stim,
            maps,
            score: &score,
            density: &density,
            truth_json: &truth_json,
            fixations: &fixations,
            links: &links,
        },
    )
    .or_stage()?;
    create_output_dir(&stamp_dir).or_stage()?;
    stamp(&stamp_dir, &key)?;
    logs.push(log(&m.name, "score", "done", ""));
    Ok(())
}

/// What `study merge` does after sharded runs: joins the shards' scores and writes the study
/// report with the problems each shard logged in run.log. Returns the meshes merged and the
/// report's path.
pub fn merge_study(study: &Study) -> Result<(usize, PathBuf)> {
    let merged = merge_scores(study)?;
    let problems: Vec<String> = std::fs::read_to_string(study.output.join("run.log"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.strip_prefix("problem\t").map(str::to_string))
        .collect();
    let report = write_study_report(&study.output, &problems).or_stage()?;
    Ok((merged, report))
}

/// Joins `OUT/scores/<mesh>.csv` of every mesh present (from any shard) into `OUT/scores.csv`, in
/// mesh-name order.
pub fn merge_scores(study: &Study) -> Result<usize> {
    let dir = study.output.join("scores");
    let mut parts: BTreeMap<String, PathBuf> = BTreeMap::new();
    if let Ok(entries) = std::fs::read_dir(&dir) {
        for e in entries.flatten() {
            let p = e.path();
            if p.extension().is_some_and(|x| x == "csv") {
                parts.insert(stem_of(&p), p);
            }
        }
    }
    let mut out = format!("{SCORE_CSV_HEADER}\n").into_bytes();
    for p in parts.values() {
        out.extend(std::fs::read(p).map_err(StudyError::io("read", &p))?);
    }
    let target = study.output.join("scores.csv");
    std::fs::write(&target, out).map_err(StudyError::io("write", &target))?;
    Ok(parts.len())
}

use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::gaze::writers::write_samples_a;
use meshgaze::mesh::Mesh;
use meshgaze::progress::Progress;
use meshgaze::provenance::InputFile;
use meshgaze::saliency::{compute_saliency, Method, SmsParams};
use meshgaze::simulate::{
    extremity_map, simulate_observers, write_simulation, ObserverParams, RecordingFormat,
    TargetModel,
};
use meshgaze::stimulus::load::load_stimulus;
use meshgaze::truth::{load_ground_truth, GroundTruth};

use super::progress_bar::Bars;

/// Simulate virtual observers watching a stimulus: tracker recordings with known answers.
///
/// Each virtual subject gets a format A sample file (IDF Converter text at 250 Hz: both
/// eyes, blinks as SMI's (0, 0), messages at stimulus onset) and a format C1 event file (IDF
/// Event Detector text), as a RED250 lab would export them; `meshgaze ingest` reads both.
/// With --recording-format eyelink each subject gets one EyeLink ASC file (sNN.asc: samples,
/// EFIX/ESACC/EBLINK events and messages, as edf2asc writes them) instead; with
/// --recording-format tobii one Tobii Pro Lab data export (sNN.tsv: samples with the I-VT
/// filter's fixation labels, stimulus start events).
/// targets.csv records the true target vertex of every fixation, so the pipeline ingest →
/// filter → project can be checked against the truth.
///
/// What the observers look at: --model extremity (default: protruding parts, independent of
/// every saliency method), --model uniform, --method sms|ms|mc|si (a computed map),
/// --saliency FILE (vertex,value CSV) or --vertices LIST. The observer model (durations,
/// saccades, blinks, 0.4° accuracy, head distance) is described in the simulate module's
/// documentation; every parameter is a flag and recorded in simulate.json.
///
/// With --study study.toml (after `meshgaze study run` rendered its stimuli): one playlist
/// recording per subject, sNN_samples.txt, in which every video of the study plays once in an
/// order shuffled per subject, each with its onset message, as Experiment Center records a
/// real study; subjects look at extremities.
#[derive(Debug, Args)]
pub struct SimulateArgs {
    /// The stimulus: its manifest.json or the folder holding it.
    #[arg(long, required_unless_present = "study", conflicts_with = "study")]
    pub stimulus: Option<PathBuf>,
    /// A study whose stimuli are rendered: write playlist recordings covering all of them.
    #[arg(long)]
    pub study: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, default_value_t = 8)]
    pub subjects: usize,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// A built-in target model.
    #[arg(long, value_enum, conflicts_with_all = ["method", "saliency", "vertices"])]
    pub model: Option<BuiltinModel>,
    /// Targets drawn from this method's saliency map.
    #[arg(long, value_enum, conflicts_with_all = ["saliency", "vertices"])]
    pub method: Option<Method>,
    /// Targets drawn from a per-vertex map file (vertex,value).
    #[arg(long, conflicts_with = "vertices")]
    pub saliency: Option<PathBuf>,
    /// Only these target vertices (comma-separated indices).
    #[arg(long, value_delimiter = ',')]
    pub vertices: Option<Vec<usize>>,
    /// The stimulus name in the recordings' messages [default: the mesh file name with .mp4].
    #[arg(long)]
    pub stimulus_name: Option<String>,
    /// RMS accuracy error per fixation, degrees (RED250: 0.4).
    #[arg(long, default_value_t = 0.4)]
    pub accuracy_deg: f64,
    /// RMS sample-to-sample jitter per axis, degrees.
    #[arg(long, default_value_t = 0.03)]
    pub precision_deg: f64,
    /// Target probability ∝ saliency^sharpness.
    #[arg(long, default_value_t = 2.0)]
    pub sharpness: f64,
    /// Smallest saccade, degrees (keeps consecutive fixations apart for the detector).
    #[arg(long, default_value_t = 2.0)]
    pub min_saccade_deg: f64,
    /// Chance of a blink after each fixation.
    #[arg(long, default_value_t = 0.05)]
    pub blink_probability: f64,
    /// Which tracker's files to write: smi (format A samples and C1 events, a RED250 lab's
    /// exports), eyelink (one ASC file per subject, as edf2asc writes it) or tobii (one Pro
    /// Lab TSV data export per subject).
    #[arg(long, value_enum, default_value_t = RecordingFormat::Smi)]
    pub recording_format: RecordingFormat,
    /// The mesh, if it moved since the stimulus was rendered (its hash must match).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum BuiltinModel {
    /// Distance from the mesh's centroid: protruding parts attract.
    Extremity,
    /// Every visible vertex equally.
    Uniform,
}

fn observer_params(args: &SimulateArgs) -> Result<ObserverParams> {
    if args.subjects == 0 {
        bail!("--subjects must be at least 1");
    }
    Ok(ObserverParams {
        subjects: args.subjects,
        seed: args.seed,
        accuracy_deg: args.accuracy_deg,
        precision_deg: args.precision_deg,
        sharpness: args.sharpness,
        min_saccade_deg: args.min_saccade_deg,
        blink_probability: args.blink_probability,
        ..ObserverParams::default()
    })
}

fn run_playlists(args: &SimulateArgs, study_file: &std::path::Path) -> Result<()> {
    let study = meshgaze::study::Study::load(study_file)?;
    let mut stimuli = Vec::new();
    for m in &study.meshes {
        let dir = study.output.join("stimuli").join(&m.name);
        stimuli.push(load_stimulus(&dir, None).map_err(|e| {
            anyhow::anyhow!(
                "{e}\n(render the study's stimuli first: meshgaze study run {})",
                study_file.display()
            )
        })?);
    }
    let params = observer_params(args)?;
    let subjects = meshgaze::simulate::playlist::simulate_playlists(&stimuli, &params)
        .map_err(anyhow::Error::msg)?;
    meshgaze::file_bytes::create_output_dir(&args.output)?;
    for s in &subjects {
        let r = &s.recording;
        // A playlist's SMI recording is its sample file alone (as a study's lab exports it).
        let files = match args.recording_format {
            RecordingFormat::Smi => vec![(
                format!("{}_samples.txt", r.id),
                write_samples_a(&r.header, &r.samples, &r.messages),
            )],
            f => f.files(&r.id, &r.header, &r.samples, &r.events, &r.messages),
        };
        for (name, text) in files {
            let p = args.output.join(name);
            std::fs::write(&p, text).with_context(|| format!("cannot write {}", p.display()))?;
            if !args.quiet {
                eprintln!("{}: {}", p.display(), s.order.join(", "));
            }
        }
    }
    Ok(())
}

pub fn run(args: SimulateArgs) -> Result<()> {
    if let Some(study) = &args.study {
        return run_playlists(&args, study);
    }
    let stimulus = args.stimulus.as_deref().expect("clap requires --stimulus");
    let stim = load_stimulus(stimulus, args.mesh.as_deref()).map_err(anyhow::Error::msg)?;
    let mesh = &stim.mesh;
    let bars = Bars::new(args.quiet);
    let mut inputs = vec![
        InputFile::hash(&stim.manifest_path)?,
        InputFile::hash(&stim.mesh_path)?,
    ];
    let (model, model_name) = target_model(&args, mesh, &bars, &mut inputs)?;
    let stimulus_name = args
        .stimulus_name
        .clone()
        .unwrap_or_else(|| format!("{}.mp4", stim.mesh_stem()));
    let params = observer_params(&args)?;
    bars.start("simulating observers", 0);
    let subjects = simulate_observers(
        mesh,
        &stim.plan,
        &stim.protocol,
        &model,
        &stimulus_name,
        &params,
    )
    .map_err(anyhow::Error::msg)?;
    bars.finish();
    write_simulation(
        &args.output,
        &subjects,
        inputs,
        &stimulus_name,
        &model_name,
        &params,
        args.recording_format,
    )
    .map_err(anyhow::Error::msg)?;
    if !args.quiet {
        let n: usize = subjects.iter().map(|s| s.fixations.len()).sum();
        eprintln!(
            "{} virtual subjects ({model_name}), {n} fixations; wrote sNN_samples.txt (format A), sNN_events.txt (format C1), targets.csv, simulate.json to {}",
            subjects.len(),
            args.output.display()
        );
    }
    Ok(())
}

/// What the observers look at, from --method, --saliency, --vertices or --model, and its
/// description for simulate.json; a --saliency file joins the hashed inputs.
fn target_model(
    args: &SimulateArgs,
    mesh: &Mesh,
    bars: &Bars,
    inputs: &mut Vec<InputFile>,
) -> Result<(TargetModel, String)> {
    Ok(
        match (&args.model, &args.method, &args.saliency, &args.vertices) {
            (_, Some(m), _, _) => {
                let out = compute_saliency(*m, mesh, &SmsParams::default(), bars)
                    .map_err(anyhow::Error::msg)?;
                (
                    TargetModel::Saliency(out.values),
                    format!("method {}", m.name()),
                )
            }
            (_, _, Some(file), _) => {
                let GroundTruth::VertexMap(m) =
                    load_ground_truth(file, mesh.positions.len(), 0.05)?
                else {
                    bail!(
                        "{}: expected a per-vertex map (vertex,value)",
                        file.display()
                    );
                };
                inputs.push(InputFile::hash(file)?);
                (
                    TargetModel::Saliency(m.values),
                    format!("map {}", file.display()),
                )
            }
            (_, _, _, Some(v)) => {
                if v.is_empty() {
                    bail!("--vertices: give at least one vertex index");
                }
                (
                    TargetModel::Vertices(v.clone()),
                    format!("{} listed vertices", v.len()),
                )
            }
            (Some(BuiltinModel::Uniform), _, _, _) => (
                TargetModel::Saliency(vec![1.0; mesh.positions.len()]),
                "uniform".to_string(),
            ),
            _ => (
                TargetModel::Saliency(extremity_map(mesh)),
                "extremity (distance from the centroid)".to_string(),
            ),
        },
    )
}

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::gaze_model::GazeModel;
use meshgaze::mesh::load_mesh;
use meshgaze::protocol::Protocol;
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::report::score_plots::write_score_plots;
use meshgaze::saliency::map_file::output_prefix;
use meshgaze::saliency::{compute_saliency_viewed, Method, RarityParams, SmsParams, Viewing};
use meshgaze::scoring::dataset::{
    dataset_pairs, mean_summaries, mesh_stem, score_table_markdown, write_score_rows, MeshEntry,
    SCORE_CSV_HEADER,
};
use meshgaze::scoring::surface_blur::BlurKernel;
use meshgaze::scoring::{blur_grid, score_mesh, MeshScore, MethodSummary, ScoreParams, Weighting};
use meshgaze::stimulus::hold_views::hold_view_exposure;
use meshgaze::truth::{load_ground_truth, GroundTruth};

use super::progress_bar::Bars;

/// Score saliency maps against human ground truth.
///
/// For one mesh: --mesh and --truth, with maps given as files (--saliency, `vertex,saliency`
/// CSV as `meshgaze saliency` writes) and/or computed here (--method sms,ms,mc). For a dataset:
/// --dataset DIR with DIR/meshes/NAME.obj[.gz] (or .ply/.off) and DIR/truth/NAME*.txt[.gz]
/// or .csv, paired by name.
///
/// Every map is blurred over the surface at σ_b = 0, 0.01, …, 0.2 (normalized units: half the
/// bounding-box diagonal = 1; Euclidean Gaussian, area-weighted, cut at 3σ, or heat diffusion
/// along the surface with --kernel heat) and scored with
/// AUC-Judd (ties split evenly), AUC-Borji (seeded), LCC, NSS, SIM, KL and the Gini index,
/// beside a seeded random map blurred the same way ("chance") and, for fixation sets with
/// subject ids, the split-half human ceiling ("human"). Ground-truth formats:
/// docs/ground-truth-format.md.
///
/// Writes OUT.csv (mesh,method,metric,blur,value) and OUT.json (summaries, provenance), and
/// prints a Markdown table of AUC-Judd and LCC, unblurred and at the peak over blur.
#[derive(Debug, Args)]
pub struct ScoreArgs {
    /// The mesh (with --truth).
    #[arg(long, requires = "truth", conflicts_with = "dataset")]
    pub mesh: Option<PathBuf>,
    /// Ground truth for --mesh: a per-vertex map or a fixation set.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// A folder with meshes/ and truth/ to score mesh by mesh, with a mean table.
    #[arg(long)]
    pub dataset: Option<PathBuf>,
    /// Saliency map files to score (named by their file stem). Single-mesh mode only.
    #[arg(long, num_args = 1.., conflicts_with = "dataset")]
    pub saliency: Vec<PathBuf>,
    /// Methods to compute and score.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub method: Vec<Method>,
    /// Output prefix: PREFIX.csv and PREFIX.json.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Largest blur σ_b (normalized units).
    #[arg(long, default_value_t = 0.2)]
    pub blur_max: f64,
    /// Step of the blur grid.
    #[arg(long, default_value_t = 0.01)]
    pub blur_step: f64,
    /// How vertices count in the metrics.
    #[arg(long, value_enum, default_value_t = Weighting::Vertex)]
    pub weighting: Weighting,
    /// Blur kernel: euclidean (Gaussian, kd-tree) or heat (diffusion along the surface).
    #[arg(long, value_enum, default_value_t = BlurKernel::Euclidean)]
    pub kernel: BlurKernel,
    /// For per-vertex truth maps without a 0/1 column: the top fraction of vertices by value
    /// taken as fixated.
    #[arg(long, default_value_t = 0.05)]
    pub top_fraction: f64,
    /// Seed of AUC-Borji's random negatives, the chance map and random human splits.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Random negative sets of AUC-Borji.
    #[arg(long, default_value_t = 100)]
    pub borji_splits: usize,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
    /// The protocol whose hold views decide which vertices were ever shown (for
    /// `auc_judd_visible`) and which the `up`, `centre` and `gaze` methods use (default: the
    /// built-in hu2020).
    #[arg(long)]
    pub protocol: Option<PathBuf>,
    /// A gaze model from `meshgaze train` for `--method gaze` (default: the built-in one).
    /// A mesh named like one of the model's training objects is refused: that score would
    /// be a training-set figure (use `meshgaze train --cv` for held-out figures).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Set a parameter of sri, gr or mr as METHOD.NAME=VALUE (repeatable), e.g.
    /// `--set sri.most_similar=32 --set gr.radii=[0.1,0.2]`; docs/baselines.md lists every
    /// parameter, its default and why.
    #[arg(long = "set", value_name = "METHOD.NAME=VALUE")]
    pub settings: Vec<String>,
}

/// Refuses to score the gaze model on an object it was trained on.
fn refuse_training_object(viewing: &Viewing, mesh_name: &str) -> Result<()> {
    let model = viewing.gaze_model();
    if model.training.objects.iter().any(|o| o.name == mesh_name) {
        bail!(
            "{mesh_name}: the gaze model was trained on an object named `{mesh_name}`, so its score here would be a training-set figure; `meshgaze train --cv` gives leave-one-object-out figures, or pass --model trained without it"
        );
    }
    Ok(())
}

#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    parameters: &'a ScoreParams,
    top_fraction: f64,
    meshes: Vec<MeshEntry>,
    mean: Vec<MethodSummary>,
}

pub fn run(args: ScoreArgs) -> Result<()> {
    let params = ScoreParams {
        blur_sigmas: blur_grid(args.blur_max, args.blur_step).map_err(anyhow::Error::msg)?,
        weighting: args.weighting,
        kernel: args.kernel,
        borji_splits: args.borji_splits,
        seed: args.seed,
        ..ScoreParams::default()
    };
    if !(args.top_fraction > 0.0 && args.top_fraction <= 1.0) {
        bail!("--top-fraction must be in (0, 1]");
    }
    let pairs: Vec<(String, PathBuf, PathBuf)> = match (&args.dataset, &args.mesh, &args.truth) {
        (Some(dir), _, _) => dataset_pairs(dir)?,
        (None, Some(mesh), Some(truth)) => {
            vec![(mesh_stem(mesh), mesh.clone(), truth.clone())]
        }
        _ => bail!("give --mesh and --truth, or --dataset DIR (see meshgaze score --help)"),
    };
    if args.method.is_empty() && args.saliency.is_empty() {
        bail!("nothing to score: give --method (e.g. sms,ms,mc) and/or --saliency FILE");
    }
    let bars = Bars::new(args.quiet);
    let (protocol, _, _) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let model = match &args.model {
        Some(path) => Some(GazeModel::load(path).map_err(anyhow::Error::msg)?),
        None => None,
    };
    let rarity = RarityParams::default()
        .with_settings(&args.settings)
        .map_err(anyhow::Error::msg)?;
    let viewing = Viewing {
        protocol,
        model,
        rarity,
    };
    let mut inputs = Vec::new();
    let mut entries = Vec::new();
    let prefix = output_prefix(&args.output);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let csv_path = PathBuf::from(format!("{}.csv", prefix.display()));
    let mut csv = std::io::BufWriter::new(
        std::fs::File::create(&csv_path)
            .with_context(|| format!("cannot create {}", csv_path.display()))?,
    );
    writeln!(csv, "{SCORE_CSV_HEADER}")?;
    for (name, mesh_path, truth_path) in &pairs {
        let (mesh, load) = load_mesh(mesh_path)?;
        let truth = load_ground_truth(truth_path, mesh.positions.len(), args.top_fraction)?;
        inputs.push(InputFile::hash(mesh_path)?);
        inputs.push(InputFile::hash(truth_path)?);
        let mut maps = Vec::new();
        let mut seconds = Vec::new();
        for file in &args.saliency {
            let GroundTruth::VertexMap(m) = load_ground_truth(file, mesh.positions.len(), 0.05)?
            else {
                bail!(
                    "{}: expected a per-vertex map (vertex,saliency)",
                    file.display()
                );
            };
            inputs.push(InputFile::hash(file)?);
            let stem = file.file_name().unwrap_or_default().to_string_lossy();
            maps.push((
                stem.split('.').next().unwrap_or("map").to_string(),
                m.values,
            ));
        }
        for &method in &args.method {
            if method == Method::Gaze {
                refuse_training_object(&viewing, name)?;
            }
            let out =
                compute_saliency_viewed(method, &mesh, &SmsParams::default(), &viewing, &bars)
                    .map_err(|e| anyhow::anyhow!("{}: {e}", mesh_path.display()))?;
            seconds.push((method.name().to_string(), out.seconds));
            maps.push((method.name().to_string(), out.values));
        }
        let seen = hold_view_exposure(&mesh, &viewing.protocol)
            .map_err(|e| anyhow::anyhow!("{}: {e}", mesh_path.display()))?
            .seen();
        let score: MeshScore = score_mesh(&mesh, &truth, &maps, &params, Some(&seen), &bars)
            .map_err(|e| anyhow::anyhow!("{}: {e}", mesh_path.display()))?;
        let plots = write_score_plots(&prefix, name, &maps, &score)?;
        write_score_rows(&mut csv, name, &score.rows)?;
        if !args.quiet {
            eprintln!("{name}: plots {}", plots.join(", "));
            eprintln!(
                "{name}: {} vertices, {} positives, {} fixations{}",
                mesh.positions.len(),
                score.positives,
                score.fixations,
                if score.human_splits > 0 {
                    format!(", human ceiling over {} splits", score.human_splits)
                } else {
                    String::new()
                }
            );
        }
        entries.push(MeshEntry {
            mesh: name.clone(),
            load,
            truth_kind: match truth {
                GroundTruth::VertexMap(_) => "vertex_map",
                GroundTruth::Fixations(_) => "fixations",
            },
            positives: score.positives,
            fixations: score.fixations,
            human_splits: score.human_splits,
            chance_auc_judd: score.chance_auc_judd.clone(),
            seconds_per_method: seconds,
            summaries: score.summaries,
        });
    }
    csv.flush()?;
    let mean = mean_summaries(&entries);
    print!("{}", score_table_markdown(&entries, &mean));
    let json_path = PathBuf::from(format!("{}.json", prefix.display()));
    let summary = Summary {
        provenance: Provenance::new(inputs),
        parameters: &params,
        top_fraction: args.top_fraction,
        meshes: entries,
        mean,
    };
    std::fs::write(&json_path, serde_json::to_string_pretty(&summary)? + "\n")
        .with_context(|| format!("cannot write {}", json_path.display()))?;
    if !args.quiet {
        eprintln!("wrote {}, {}", csv_path.display(), json_path.display());
    }
    Ok(())
}

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;

use meshgaze::gaze_model::GazeModel;
use meshgaze::pipeline::score_dataset::{score_dataset, ScoreRequest, ScoredMesh};
use meshgaze::protocol::{Protocol, UpAxis};
use meshgaze::saliency::map_file::output_prefix;
use meshgaze::saliency::{Method, RarityParams, Viewing};
use meshgaze::scoring::dataset::{dataset_pairs, mesh_stem, score_table_markdown};
use meshgaze::scoring::surface_blur::BlurKernel;
use meshgaze::scoring::{blur_grid, ScoreParams, Weighting};
use meshgaze::truth::TruthLayout;

use super::progress_bar::Bars;

/// Score saliency maps against human ground truth.
///
/// For one mesh: --mesh and --truth, with maps given as files (--saliency, `vertex,saliency`
/// CSV as `meshgaze saliency` writes) and/or computed here (--method sms,ms,mc). For a dataset:
/// --dataset DIR with DIR/meshes/NAME.obj[.gz] (or .ply/.off) and DIR/truth/NAME*.txt[.gz]
/// or .csv, paired by name.
///
/// Every map is blurred over the surface at σ_b = 0, 0.01, …, 0.2 (normalized units: half the
/// bounding-box diagonal = 1; Euclidean Gaussian, area-weighted, cut at 3σ; the full Gaussian,
/// which ranks the cut's exact zeros by distance and so gives other numbers, with --kernel
/// gaussian; or heat
/// diffusion along the surface with --kernel heat) and scored with
/// AUC-Judd (ties split evenly), AUC-Borji (seeded), LCC, NSS, SIM, KL and the Gini index,
/// beside 20 seeded random maps blurred the same way (the "chance" band: their mean, 2.5th and
/// 97.5th percentiles; where large blurs merge sources, the random maps' go to first order
/// and the methods' to second, each within a few 10⁻⁴ of the exact sums' scores)
/// and, for fixation sets with subject ids, the split-half human ceiling ("human"). Ground-truth formats:
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
    /// Whether a truth map gives one value per vertex or per face (many published 3D gaze
    /// datasets give faces). auto: per face when its rows number the mesh's triangles (and
    /// not its vertices); a per-face map is carried to vertices by the area-weighted mean of
    /// each vertex's faces.
    #[arg(long, value_enum, default_value_t = TruthLayout::Auto)]
    pub truth_layout: TruthLayout,
    /// The axis the mesh files hold as up, as the subjects saw them (default: the protocol's,
    /// +y in the built-in one). The `up`, `centre` and `gaze` methods depend on it: the
    /// built-in gaze model on 15 VR meshes turned from +y-up to +z-up falls from AUC-Judd
    /// 0.87 to 0.57 with the default, and is 0.87 again with `--up z` (docs/gaze_model.md).
    #[arg(long, value_enum)]
    pub up: Option<UpAxis>,
    /// A gaze model from `meshgaze train` for `--method gaze` (default: the built-in one).
    /// A mesh named like one of the model's training objects, or whose surface passes
    /// through the points the model file keeps of one (a renamed copy), is refused: that
    /// score would be a training-set figure (use `meshgaze train --cv` for held-out figures).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Set a parameter of sri, gr or mr as METHOD.NAME=VALUE (repeatable), e.g.
    /// `--set sri.most_similar=32 --set gr.radii=[0.1,0.2]`; docs/baselines.md lists every
    /// parameter, its default and why.
    #[arg(long = "set", value_name = "METHOD.NAME=VALUE")]
    pub settings: Vec<String>,
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
    let pairs: Vec<(String, PathBuf, PathBuf)> = match (&args.dataset, &args.mesh, &args.truth) {
        (Some(dir), _, _) => dataset_pairs(dir)?,
        (None, Some(mesh), Some(truth)) => {
            vec![(mesh_stem(mesh), mesh.clone(), truth.clone())]
        }
        _ => bail!("give --mesh and --truth, or --dataset DIR (see meshgaze score --help)"),
    };
    let viewing = viewing_of(&args)?;
    let request = ScoreRequest {
        pairs: &pairs,
        saliency_files: &args.saliency,
        methods: &args.method,
        params: &params,
        top_fraction: args.top_fraction,
        viewing: &viewing,
        truth_layout: args.truth_layout,
    };
    let quiet = args.quiet;
    let mut tell = |m: &ScoredMesh| {
        if quiet {
            return;
        }
        eprintln!("{}: plots {}", m.name, m.plots.join(", "));
        let ceiling = if m.human_splits > 0 {
            format!(", human ceiling over {} splits", m.human_splits)
        } else {
            String::new()
        };
        eprintln!(
            "{}: {} vertices, {} positives, {} fixations{ceiling}",
            m.name, m.vertices, m.score_positives, m.score_fixations
        );
    };
    let bars = Bars::new(args.quiet);
    let out = score_dataset(&request, &output_prefix(&args.output), &bars, &mut tell)?;
    print!("{}", score_table_markdown(&out.entries, &out.mean));
    if !args.quiet {
        eprintln!("wrote {}, {}", out.csv.display(), out.json.display());
    }
    Ok(())
}

/// The protocol, learned model and method settings the maps are computed with.
fn viewing_of(args: &ScoreArgs) -> Result<Viewing> {
    let (protocol, _, _) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let protocol = match args.up {
        Some(axis) => protocol.with_up_axis(axis),
        None => protocol,
    };
    let model = match &args.model {
        Some(path) => Some(GazeModel::load(path).map_err(anyhow::Error::msg)?),
        None => None,
    };
    let rarity = RarityParams::default()
        .with_settings(&args.settings)
        .map_err(anyhow::Error::msg)?;
    Ok(Viewing {
        protocol,
        model,
        rarity,
    })
}

use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use rayon::prelude::*;

use meshgaze::experiments::gaze_model_cross_validation::{cross_validate, Categories, CvPlan};
use meshgaze::gaze_model::boosted_trees::BoostParams;
use meshgaze::gaze_model::{train_model, TrainOptions, TrainingObject};
use meshgaze::pipeline::training_data::{
    check_unique_names, dataset_names, evaluation_meshes, training_sources,
};
use meshgaze::progress::Progress;
use meshgaze::protocol::{Protocol, ProtocolPerDataset, UpAxis};
use meshgaze::report::cross_validation_report::{
    cv_markdown, held_out_markdown, write_cv_csv, write_cv_figures, write_held_out_csv,
};
use meshgaze::truth::TruthLayout;

use super::progress_bar::Bars;

/// Train the gaze model: boosted trees that predict which points people look at most, from
/// features needing no human input (multi-scale shape, height along the protocol's up axis,
/// placement towards its front, what its hold views show, openness).
///
/// Each DATASET folder holds `points/NAME.txt[.gz]` files, one line per surface point:
/// `x y z nx ny nz time flag` (flag 1 = among the most looked-at, as in
/// ../shared/data/fixations-vr/points). Every object of a dataset weighs the same
/// (`--rows-per-object` points are drawn from each with `--seed`), and every dataset weighs
/// the same whatever its number of objects: a lab's 2 pilot meshes count as much as the 44
/// objects of fixations-vr, or `--weight NAME=W` times as much. The model (OUT) records the
/// feature list, the SHA-256 of every training file, each dataset's weight and the
/// parameters; the same data and options give the same bytes.
///
/// With `--cv`, every mesh of a dataset's `meshes/` + `truth/` (as `meshgaze score
/// --dataset` reads them) is held out in turn: a model trained on every other object
/// predicts it and is scored (AUC-Judd plain and with never-shown vertices left out of the
/// negatives, and LCC) beside mc, ms, sms, up, centre, up+mc and chance. The table goes to
/// stdout and to OUT with `.cv.csv` in place of `.json`. With two datasets or more, each
/// dataset is also held out whole (leave-one-dataset-out: how the model does on a lab it
/// never saw); with `--categories FILE`, each object family is (leave-one-category-out, the
/// proxy for transfer within one dataset); `--ablations` retrains each of those without
/// each feature group. Those rows go to OUT with `.held-out.csv`.
///
/// Examples:
///   meshgaze train --dataset ../shared/data/fixations-vr -o gaze.json --cv
///   meshgaze train --dataset ../shared/data/fixations-vr my-lab --weight my-lab=2 -o lab.json --cv
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// Dataset folders with `points/` and/or `meshes/` + `truth/` (as `meshgaze score
    /// --dataset` reads them). A mesh with no points file of its name trains too, its
    /// top `--top-fraction` vertices by truth value as positives.
    #[arg(long, num_args = 1..)]
    pub dataset: Vec<PathBuf>,
    /// A dataset's (or study folder's) weight relative to the others, by folder name:
    /// `--weight my-lab=3` makes my-lab's rows together weigh three times another dataset's.
    #[arg(long, value_name = "NAME=W")]
    pub weight: Vec<String>,
    /// With --cv: a TSV of `object<TAB>category` for every training object and held-out
    /// mesh; each category is then held out whole in turn. meshgaze ships one for
    /// fixations-vr (models/fixations-vr-categories.tsv).
    #[arg(long, requires = "cv")]
    pub categories: Option<PathBuf>,
    /// With --cv: retrain every hold-out scheme without each feature group (placement,
    /// orientation, shape, views, classical) in turn; six times the training.
    #[arg(long, requires = "cv")]
    pub ablations: bool,
    /// Study output folders (`meshgaze study run`): each mesh with truth/<mesh>/density.csv
    /// trains, its top `--top-fraction` vertices by fixation density as positives.
    #[arg(long, num_args = 1..)]
    pub study: Vec<PathBuf>,
    /// Whether a dataset's truth maps give one value per vertex or per face. auto: per face
    /// when its rows number the mesh's triangles (and not its vertices); a per-face map is
    /// carried to vertices by the area-weighted mean of each vertex's faces (as `score`).
    #[arg(long, value_enum, default_value_t = TruthLayout::Auto)]
    pub truth_layout: TruthLayout,
    /// Fraction of a mesh's vertices taken as positives when its truth is a map.
    #[arg(long, default_value_t = 0.05)]
    pub top_fraction: f64,
    /// The model file to write (JSON).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Objects to leave out of training (names as in points/NAME.txt.gz), e.g. to score
    /// the model on them afterwards with `meshgaze score --model`.
    #[arg(long, value_delimiter = ',')]
    pub exclude: Vec<String>,
    /// Also run leave-one-object-out cross-validation over the datasets' meshes.
    #[arg(long)]
    pub cv: bool,
    /// The protocol whose up axis, front and hold views the features use (default: the
    /// built-in hu2020).
    #[arg(long)]
    pub protocol: Option<PathBuf>,
    /// The axis a dataset's mesh files hold as up, as its subjects saw them: `--up z` for every
    /// dataset, `--up my-lab=z` for one folder (repeatable; axes x, y, z, neg-x, neg-y,
    /// neg-z). The features read height, front and facing from the protocol's up axis, so a
    /// lab's +z-up meshes beside the +y-up VR ones need it (docs/gaze_model.md).
    #[arg(long, value_name = "[NAME=]AXIS")]
    pub up: Vec<String>,
    /// With --cv: write, per held-out mesh, DIR/NAME.png: the held-out model's map beside
    /// the human fixation time, from the protocol's first hold view (1st–99th percentile
    /// colour scale, blue to red).
    #[arg(long, requires = "cv")]
    pub figures: Option<PathBuf>,
    /// Points drawn from each training object.
    #[arg(long, default_value_t = 4000)]
    pub rows_per_object: usize,
    /// Seed of the draw.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Boosting rounds (trees).
    #[arg(long, default_value_t = 200)]
    pub rounds: usize,
    /// Depth of each tree.
    #[arg(long, default_value_t = 4)]
    pub max_depth: usize,
    /// Shrinkage of each tree.
    #[arg(long, default_value_t = 0.1)]
    pub learning_rate: f64,
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: TrainArgs) -> Result<()> {
    let (base, _, _) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let protocols = ProtocolPerDataset {
        base,
        up_axes: parse_up_axes(&args.up, &dataset_names(&args.dataset, &args.study)?)?,
    };
    let options = TrainOptions {
        params: BoostParams {
            rounds: args.rounds,
            max_depth: args.max_depth,
            learning_rate: args.learning_rate,
            ..BoostParams::default()
        },
        rows_per_object: args.rows_per_object,
        seed: args.seed,
        dataset_weights: parse_weights(&args.weight, &dataset_names(&args.dataset, &args.study)?)?,
    };
    let sources = training_sources(&args.dataset, &args.study, &args.exclude)?;
    let bars = Bars::new(args.quiet);
    let t = std::time::Instant::now();
    bars.start("features of the training objects", sources.len() as u64);
    let objects: Vec<TrainingObject> = sources
        .par_iter()
        .map(|s| {
            let protocol = protocols.for_dataset(&s.dataset());
            let o = s.object(&protocol, args.top_fraction, args.truth_layout);
            bars.advance(1);
            o
        })
        .collect::<Result<_, _>>()?;
    bars.finish();
    check_unique_names(&objects, &sources)?;
    let feature_s = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let all: Vec<&TrainingObject> = objects.iter().collect();
    let model = train_model(&all, &options, &protocols.name()).map_err(anyhow::Error::msg)?;
    let train_s = t.elapsed().as_secs_f64();
    std::fs::write(&args.output, model.to_json())
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    let rows: usize = model.training.objects.iter().map(|o| o.rows_used).sum();
    eprintln!(
        "trained on {} objects ({rows} rows) in {train_s:.1} s after {feature_s:.1} s of features: {}",
        objects.len(),
        args.output.display()
    );
    eprintln!("feature importance (share of split gain):");
    for (name, share) in model.importances().iter().take(12) {
        eprintln!("  {name:<24} {share:.3}");
    }
    if args.cv {
        run_cross_validation(&args, &objects, &options, &protocols, &bars)?;
    }
    Ok(())
}

/// `--cv`: leave each mesh with per-vertex truth out in turn; the table and the figures.
fn run_cross_validation(
    args: &TrainArgs,
    objects: &[TrainingObject],
    options: &TrainOptions,
    protocols: &ProtocolPerDataset,
    bars: &Bars,
) -> Result<()> {
    let meshes = evaluation_meshes(&args.dataset, args.truth_layout)?;
    let plan = CvPlan {
        categories: match &args.categories {
            Some(p) => Some(Categories::read(p)?),
            None => None,
        },
        ablations: args.ablations,
    };
    let cv = cross_validate(objects, &meshes, options, protocols, &plan, bars)
        .map_err(anyhow::Error::msg)?;
    let path = args.output.with_extension("cv.csv");
    write_cv_csv(&path, &cv.rows).with_context(|| format!("cannot write {}", path.display()))?;
    let held_path = args.output.with_extension("held-out.csv");
    write_held_out_csv(&held_path, &cv.held_out)
        .with_context(|| format!("cannot write {}", held_path.display()))?;
    print!("{}", cv_markdown(&cv.rows));
    print!("{}", held_out_markdown(&cv.held_out, &cv.rows));
    if let Some(dir) = &args.figures {
        write_cv_figures(dir, &meshes, &cv.held_out_maps, protocols).map_err(anyhow::Error::msg)?;
        eprintln!("figures: {}", dir.display());
    }
    eprintln!(
        "cross-validation tables: {} and {}",
        path.display(),
        held_path.display()
    );
    Ok(())
}

/// `--up [NAME=]AXIS` entries: an axis alone is every dataset's; NAME names one folder.
fn parse_up_axes(specs: &[String], names: &[String]) -> Result<Vec<(String, UpAxis)>> {
    use clap::ValueEnum;
    let axis_of = |spec: &str, text: &str| {
        UpAxis::from_str(text, true).map_err(|_| {
            anyhow::anyhow!("--up {spec}: `{text}` is not an axis (x, y, z, neg-x, neg-y, neg-z)")
        })
    };
    let mut out: Vec<(String, UpAxis)> = Vec::new();
    for spec in specs {
        let chosen: Vec<(String, UpAxis)> = match spec.split_once('=') {
            Some((name, text)) => {
                if !names.iter().any(|n| n == name) {
                    anyhow::bail!(
                        "--up {spec}: no --dataset or --study folder named `{name}` (the folders are named {})",
                        names.join(", ")
                    );
                }
                vec![(name.to_string(), axis_of(spec, text)?)]
            }
            None => {
                let axis = axis_of(spec, spec)?;
                names.iter().map(|n| (n.clone(), axis)).collect()
            }
        };
        for (name, axis) in chosen {
            if out.iter().any(|(n, _)| *n == name) {
                anyhow::bail!("--up gives the folder `{name}` an up axis twice");
            }
            out.push((name, axis));
        }
    }
    Ok(out)
}

/// `--weight NAME=W` entries, each naming one of the given folders.
fn parse_weights(specs: &[String], names: &[String]) -> Result<Vec<(String, f64)>> {
    let mut out: Vec<(String, f64)> = Vec::new();
    for spec in specs {
        let Some((name, w)) = spec.rsplit_once('=') else {
            anyhow::bail!("--weight {spec}: expected NAME=W, e.g. --weight my-lab=3");
        };
        let name = name.trim_end_matches('/');
        let name = std::path::Path::new(name)
            .file_name()
            .map_or(name.to_string(), |n| n.to_string_lossy().to_string());
        if !names.contains(&name) {
            anyhow::bail!(
                "--weight {spec}: no --dataset or --study folder named `{name}` (the folders are named {})",
                names.join(", ")
            );
        }
        let w: f64 = w
            .parse()
            .ok()
            .filter(|w: &f64| w.is_finite() && *w > 0.0)
            .with_context(|| format!("--weight {spec}: W must be a positive number"))?;
        if out.iter().any(|(n, _)| *n == name) {
            anyhow::bail!("--weight names `{name}` twice");
        }
        out.push((name, w));
    }
    Ok(out)
}

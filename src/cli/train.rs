use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;
use rayon::prelude::*;

use meshgaze::experiments::gaze_model_cross_validation::leave_one_object_out;
use meshgaze::gaze_model::boosted_trees::BoostParams;
use meshgaze::gaze_model::{train_model, TrainOptions, TrainingObject};
use meshgaze::pipeline::training_data::{check_unique_names, evaluation_meshes, training_sources};
use meshgaze::progress::Progress;
use meshgaze::protocol::Protocol;
use meshgaze::report::cross_validation_report::{cv_markdown, write_cv_csv, write_cv_figures};

use super::progress_bar::Bars;

/// Train the gaze model: boosted trees that predict which points people look at most, from
/// features needing no human input (multi-scale shape, height along the protocol's up axis,
/// placement towards its front, what its hold views show, openness).
///
/// Each DATASET folder holds `points/NAME.txt[.gz]` files, one line per surface point:
/// `x y z nx ny nz time flag` (flag 1 = among the most looked-at, as in
/// ../shared/data/fixations-vr/points). Every object weighs the same: `--rows-per-object`
/// points are drawn from each with `--seed`. The model (OUT) records the feature list, the
/// SHA-256 of every training file and the parameters; the same data and options give the
/// same bytes.
///
/// With `--cv`, every mesh of a dataset's `meshes/` + `truth/` (as `meshgaze score
/// --dataset` reads them) is held out in turn: a model trained on every other object
/// predicts it and is scored (AUC-Judd plain and with never-shown vertices left out of the
/// negatives, and LCC) beside mc, ms, sms, up, centre, up+mc and chance. The table goes to
/// stdout and to OUT with `.cv.csv` in place of `.json`.
///
/// Example: meshgaze train --dataset ../shared/data/fixations-vr -o gaze.json --cv
#[derive(Debug, Args)]
pub struct TrainArgs {
    /// Dataset folders with `points/` and/or `meshes/` + `truth/` (as `meshgaze score
    /// --dataset` reads them). A mesh with no points file of its name trains too, its
    /// top `--top-fraction` vertices by truth value as positives.
    #[arg(long, num_args = 1..)]
    pub dataset: Vec<PathBuf>,
    /// Study output folders (`meshgaze study run`): each mesh with truth/<mesh>/density.csv
    /// trains, its top `--top-fraction` vertices by fixation density as positives.
    #[arg(long, num_args = 1..)]
    pub study: Vec<PathBuf>,
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
    let (protocol, _, _) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let options = TrainOptions {
        params: BoostParams {
            rounds: args.rounds,
            max_depth: args.max_depth,
            learning_rate: args.learning_rate,
            ..BoostParams::default()
        },
        rows_per_object: args.rows_per_object,
        seed: args.seed,
    };
    let sources = training_sources(&args.dataset, &args.study, &args.exclude)?;
    let bars = Bars::new(args.quiet);
    let t = std::time::Instant::now();
    bars.start("features of the training objects", sources.len() as u64);
    let objects: Vec<TrainingObject> = sources
        .par_iter()
        .map(|s| {
            let o = s.object(&protocol, args.top_fraction);
            bars.advance(1);
            o
        })
        .collect::<Result<_, _>>()?;
    bars.finish();
    check_unique_names(&objects, &sources)?;
    let feature_s = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let all: Vec<&TrainingObject> = objects.iter().collect();
    let model = train_model(&all, &options, &protocol.name).map_err(anyhow::Error::msg)?;
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
        cross_validate(&args, &objects, &options, &protocol, &bars)?;
    }
    Ok(())
}

/// `--cv`: leave each mesh with per-vertex truth out in turn; the table and the figures.
fn cross_validate(
    args: &TrainArgs,
    objects: &[TrainingObject],
    options: &TrainOptions,
    protocol: &Protocol,
    bars: &Bars,
) -> Result<()> {
    let meshes = evaluation_meshes(&args.dataset)?;
    let cv = leave_one_object_out(objects, &meshes, options, protocol, bars)
        .map_err(anyhow::Error::msg)?;
    let path = args.output.with_extension("cv.csv");
    write_cv_csv(&path, &cv.rows).with_context(|| format!("cannot write {}", path.display()))?;
    print!("{}", cv_markdown(&cv.rows));
    if let Some(dir) = &args.figures {
        write_cv_figures(dir, &meshes, &cv.held_out_maps, protocol).map_err(anyhow::Error::msg)?;
        eprintln!("figures: {}", dir.display());
    }
    eprintln!("cross-validation table: {}", path.display());
    Ok(())
}

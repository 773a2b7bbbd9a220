use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use rayon::prelude::*;

use meshgaze::experiments::gaze_model_cross_validation::{
    leave_one_object_out, mean_rows, CvRow, EvaluationMesh,
};
use meshgaze::gaze_model::boosted_trees::BoostParams;
use meshgaze::gaze_model::{
    object_name, train_model, training_object, training_object_from_map, TrainOptions,
    TrainingObject,
};
use meshgaze::mesh::load_mesh;
use meshgaze::progress::Progress;
use meshgaze::protocol::Protocol;
use meshgaze::provenance::{sha256_hex, InputFile};
use meshgaze::report::html::thumbnail;
use meshgaze::report::map_render::render_map;
use meshgaze::scoring::dataset::dataset_pairs;
use meshgaze::stimulus::camera::CameraPlan;
use meshgaze::stimulus::load::load_stimulus;
use meshgaze::study::run::read_density;
use meshgaze::truth::{load_ground_truth, GroundTruth};

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
    if args.dataset.is_empty() && args.study.is_empty() {
        bail!("nothing to train on: give --dataset DIR (points/, or meshes/ + truth/) and/or --study OUT");
    }
    let files = point_files(&args.dataset)?;
    let mut sources: Vec<Source> = files.iter().cloned().map(Source::Points).collect();
    for d in &args.dataset {
        if !d.join("meshes").is_dir() {
            continue;
        }
        for (name, mesh, truth) in dataset_pairs(d)? {
            if !files.iter().any(|f| object_name(f) == name) {
                sources.push(Source::MeshTruth { name, mesh, truth });
            }
        }
    }
    for out in &args.study {
        sources.extend(study_sources(out)?);
    }
    for name in &args.exclude {
        let before = sources.len();
        sources.retain(|s| s.name() != *name);
        if sources.len() == before {
            bail!("--exclude {name}: no training object of that name");
        }
    }
    if sources.is_empty() {
        bail!("no training objects found in the given folders");
    }
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
        .collect::<Result<_>>()?;
    bars.finish();
    check_unique_names(&objects, &sources)?;
    let feature_s = t.elapsed().as_secs_f64();
    let t = std::time::Instant::now();
    let all: Vec<&TrainingObject> = objects.iter().collect();
    let model = train_model(&all, &options, &protocol.name).map_err(anyhow::Error::msg)?;
    let train_s = t.elapsed().as_secs_f64();
    std::fs::write(&args.output, model.to_json())
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    eprintln!(
        "trained on {} objects ({} rows) in {train_s:.1} s after {feature_s:.1} s of features: {}",
        objects.len(),
        model
            .training
            .objects
            .iter()
            .map(|o| o.rows_used)
            .sum::<usize>(),
        args.output.display()
    );
    eprintln!("feature importance (share of split gain):");
    for (name, share) in model.importances().iter().take(12) {
        eprintln!("  {name:<24} {share:.3}");
    }
    if args.cv {
        let meshes = evaluation_meshes(&args.dataset)?;
        let cv = leave_one_object_out(&objects, &meshes, &options, &protocol, &bars)
            .map_err(anyhow::Error::msg)?;
        let path = args.output.with_extension("cv.csv");
        write_cv_csv(&path, &cv.rows)?;
        print!("{}", cv_markdown(&cv.rows));
        if let Some(dir) = &args.figures {
            write_figures(dir, &meshes, &cv.held_out_maps, &protocol)?;
            eprintln!("figures: {}", dir.display());
        }
        eprintln!("cross-validation table: {}", path.display());
    }
    Ok(())
}

/// Every `points/*.txt[.gz]` of the datasets, sorted by dataset then name.
fn point_files(datasets: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for d in datasets {
        let dir = d.join("points");
        if !dir.exists() && d.join("meshes").is_dir() {
            continue;
        }
        let mut here: Vec<PathBuf> = std::fs::read_dir(&dir)
            .with_context(|| {
                format!(
                    "cannot read {} (a dataset needs a points/ folder)",
                    dir.display()
                )
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                let n = p
                    .file_name()
                    .unwrap_or_default()
                    .to_string_lossy()
                    .to_string();
                n.ends_with(".txt") || n.ends_with(".txt.gz")
            })
            .collect();
        if here.is_empty() {
            bail!("{}: no .txt or .txt.gz point files", dir.display());
        }
        here.sort();
        files.extend(here);
    }
    Ok(files)
}

fn check_unique_names(objects: &[TrainingObject], sources: &[Source]) -> Result<()> {
    for (i, a) in objects.iter().enumerate() {
        if let Some(j) = objects[..i].iter().position(|b| b.name == a.name) {
            bail!(
                "two training objects named `{}`: {} and {}; leave-one-object-out needs unique names",
                a.name,
                sources[j].describe(),
                sources[i].describe()
            );
        }
    }
    Ok(())
}

/// Where a training object comes from.
enum Source {
    /// A gaze-point file with a flag column.
    Points(PathBuf),
    /// A mesh and its per-vertex truth (a dataset's meshes/ + truth/).
    MeshTruth {
        name: String,
        mesh: PathBuf,
        truth: PathBuf,
    },
    /// A study's rendered mesh and its fixation density.
    StudyMesh {
        name: String,
        stimulus: PathBuf,
        density: PathBuf,
    },
}

impl Source {
    fn name(&self) -> String {
        match self {
            Source::Points(p) => object_name(p),
            Source::MeshTruth { name, .. } | Source::StudyMesh { name, .. } => name.clone(),
        }
    }

    fn describe(&self) -> String {
        match self {
            Source::Points(p) => p.display().to_string(),
            Source::MeshTruth { mesh, truth, .. } => {
                format!("{} with {}", mesh.display(), truth.display())
            }
            Source::StudyMesh { density, .. } => density.display().to_string(),
        }
    }

    fn object(&self, protocol: &Protocol, top_fraction: f64) -> Result<TrainingObject> {
        let hash = |p: &Path| -> Result<String> { Ok(InputFile::hash(p)?.sha256) };
        match self {
            Source::Points(p) => training_object(p, protocol).map_err(anyhow::Error::msg),
            Source::MeshTruth { name, mesh, truth } => {
                let (m, _) = load_mesh(mesh)?;
                let t = load_ground_truth(truth, m.positions.len(), top_fraction)?;
                let values: Vec<f64> = match t {
                    GroundTruth::VertexMap(map) => map.values,
                    GroundTruth::Fixations(f) => {
                        let mut counts = vec![0.0; m.positions.len()];
                        for x in &f.fixations {
                            counts[x.vertex] += 1.0;
                        }
                        counts
                    }
                };
                let sha = sha256_hex(format!("{} {}", hash(mesh)?, hash(truth)?).as_bytes());
                training_object_from_map(name, sha, &m, &values, top_fraction, protocol)
                    .map_err(anyhow::Error::msg)
            }
            Source::StudyMesh {
                name,
                stimulus,
                density,
            } => {
                let stim = load_stimulus(stimulus, None).map_err(anyhow::Error::msg)?;
                let values = read_density(density, stim.mesh.positions.len())?;
                let sha = sha256_hex(format!("{} {}", stim.mesh_sha256, hash(density)?).as_bytes());
                training_object_from_map(name, sha, &stim.mesh, &values, top_fraction, protocol)
                    .map_err(anyhow::Error::msg)
            }
        }
    }
}

/// Every mesh of a study output folder with a truth/<mesh>/density.csv, in name order.
fn study_sources(out: &Path) -> Result<Vec<Source>> {
    let truth = out.join("truth");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&truth)
        .with_context(|| {
            format!(
                "cannot read {} (is {} a study output folder?)",
                truth.display(),
                out.display()
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("density.csv").is_file())
        .collect();
    dirs.sort();
    if dirs.is_empty() {
        bail!(
            "{}: no truth/<mesh>/density.csv yet; run `meshgaze study run` first",
            out.display()
        );
    }
    Ok(dirs
        .into_iter()
        .map(|d| {
            let name = d
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string();
            Source::StudyMesh {
                stimulus: out.join("stimuli").join(&name),
                density: d.join("density.csv"),
                name,
            }
        })
        .collect())
}

/// The meshes with per-vertex truth of every dataset that has `meshes/` and `truth/`.
fn evaluation_meshes(datasets: &[PathBuf]) -> Result<Vec<EvaluationMesh>> {
    let mut out = Vec::new();
    for d in datasets {
        if !d.join("meshes").is_dir() {
            continue;
        }
        for (name, mesh_path, truth_path) in dataset_pairs(d)? {
            let (mesh, _) = load_mesh(&mesh_path)?;
            let truth = load_ground_truth(&truth_path, mesh.positions.len(), 0.05)?;
            let GroundTruth::VertexMap(map) = truth else {
                bail!(
                    "{}: --cv needs a per-vertex truth map",
                    truth_path.display()
                );
            };
            out.push(EvaluationMesh {
                name,
                mesh,
                values: map.values,
                positive: map.positive,
            });
        }
    }
    if out.is_empty() {
        bail!("--cv: no dataset has meshes/ and truth/ to hold out");
    }
    Ok(out)
}

/// DIR/NAME.png per mesh: predicted map (left) beside the human map (right).
fn write_figures(
    dir: &Path,
    meshes: &[EvaluationMesh],
    maps: &[(String, Vec<f64>)],
    protocol: &Protocol,
) -> Result<()> {
    meshgaze::file_bytes::create_output_dir(dir)?;
    for (m, (name, map)) in meshes.iter().zip(maps) {
        let plan = CameraPlan::new(&m.mesh, protocol).map_err(anyhow::Error::msg)?;
        let left = thumbnail(&render_map(&m.mesh, &plan, protocol, map, 0), 480);
        let right = thumbnail(&render_map(&m.mesh, &plan, protocol, &m.values, 0), 480);
        let mut both = image::RgbImage::new(left.width() + right.width(), left.height());
        image::imageops::replace(&mut both, &left, 0, 0);
        image::imageops::replace(&mut both, &right, left.width() as i64, 0);
        let path = dir.join(format!("{name}.png"));
        both.save(&path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(())
}

fn write_cv_csv(path: &Path, rows: &[CvRow]) -> Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("cannot write {}", path.display()))?;
    for r in rows.iter().chain(mean_rows(rows).iter()) {
        w.serialize(r)?;
    }
    w.flush()?;
    Ok(())
}

/// Objects down, methods across: AUC-Judd plain / visible-only.
pub fn cv_markdown(rows: &[CvRow]) -> String {
    let means = mean_rows(rows);
    let methods: Vec<&str> = means.iter().map(|r| r.method.as_str()).collect();
    let mut s = format!("| object | {} |\n", methods.join(" | "));
    s += &format!("|---|{}\n", "---|".repeat(methods.len()));
    let mut objects: Vec<&str> = Vec::new();
    for r in rows {
        if !objects.contains(&r.object.as_str()) {
            objects.push(&r.object);
        }
    }
    let all: Vec<&CvRow> = rows.iter().chain(means.iter()).collect();
    for o in objects.iter().copied().chain(std::iter::once("mean")) {
        s += &format!("| {o} |");
        for m in &methods {
            match all.iter().find(|r| r.object == o && r.method == *m) {
                Some(r) => s += &format!(" {:.3} / {:.3} |", r.auc_judd, r.auc_judd_visible),
                None => s += " |",
            }
        }
        s += "\n";
    }
    s += "\nAUC-Judd unblurred, plain / with never-shown vertices left out of the negatives.\n";
    s += &format!(
        "LCC mean: {}\n",
        means
            .iter()
            .map(|r| format!("{} {:.3}", r.method, r.lcc))
            .collect::<Vec<_>>()
            .join(", ")
    );
    s
}

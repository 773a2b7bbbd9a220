use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::ground_truth::{load_ground_truth, GroundTruth};
use meshgaze::mesh::{load_mesh, LoadReport, MeshFormat};
use meshgaze::metrics::surface_blur::BlurKernel;
use meshgaze::metrics::{gini_index, lorenz_curve};
use meshgaze::plot::{line_chart_png, Chart, Series, PALETTE};
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::saliency::{compute_saliency, Method, SmsParams};
use meshgaze::scoring::{
    score_mesh, MeshScore, MethodSummary, ScoreParams, Weighting, CHANCE, HUMAN,
};
use plotters::style::RGBColor;

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
}

#[derive(Serialize)]
struct MeshEntry {
    mesh: String,
    load: LoadReport,
    truth_kind: &'static str,
    positives: usize,
    fixations: usize,
    human_splits: usize,
    seconds_per_method: Vec<(String, f64)>,
    summaries: Vec<MethodSummary>,
}

#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    parameters: &'a ScoreParams,
    top_fraction: f64,
    meshes: Vec<MeshEntry>,
    mean: Vec<MethodSummary>,
}

/// σ_b from 0 to `max` in steps of `step` (rounded to 1e-9 so 0.07 prints as 0.07).
pub fn blur_grid(max: f64, step: f64) -> Result<Vec<f64>> {
    if !(step > 0.0 && max >= 0.0 && max / step <= 10_000.0) {
        bail!("--blur-step must be positive and --blur-max / --blur-step at most 10000");
    }
    let k = (max / step + 1e-9).floor() as usize;
    Ok((0..=k)
        .map(|i| (i as f64 * step * 1e9).round() / 1e9)
        .collect())
}

/// Pairs DIR/meshes/NAME.* with DIR/truth/NAME[_.]*.
fn dataset_pairs(dir: &Path) -> Result<Vec<(String, PathBuf, PathBuf)>> {
    let meshes_dir = dir.join("meshes");
    let truth_dir = dir.join("truth");
    let list = |d: &Path| -> Result<Vec<PathBuf>> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(d)
            .with_context(|| format!("cannot read {}", d.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        v.sort();
        Ok(v)
    };
    let truths = list(&truth_dir)?;
    let mut pairs = Vec::new();
    for mesh in list(&meshes_dir)? {
        if MeshFormat::from_path(&mesh).is_none() {
            continue;
        }
        let file = mesh
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .to_string();
        let name = file.split('.').next().unwrap_or(&file).to_string();
        let matches: Vec<&PathBuf> = truths
            .iter()
            .filter(|t| {
                let f = t.file_name().unwrap_or_default().to_string_lossy();
                f.starts_with(&format!("{name}_")) || f.starts_with(&format!("{name}."))
            })
            .collect();
        match matches.as_slice() {
            [t] => pairs.push((name, mesh.clone(), (*t).clone())),
            [] => bail!(
                "{}: no truth file named {name}_* or {name}.* in {}",
                mesh.display(),
                truth_dir.display()
            ),
            _ => bail!(
                "{}: several truth files match {name}: {matches:?}",
                mesh.display()
            ),
        }
    }
    if pairs.is_empty() {
        bail!("{}: no meshes found", meshes_dir.display());
    }
    Ok(pairs)
}

fn mean_summaries(entries: &[MeshEntry]) -> Vec<MethodSummary> {
    let Some(first) = entries.first() else {
        return Vec::new();
    };
    first
        .summaries
        .iter()
        .map(|s| {
            let all: Vec<&MethodSummary> = entries
                .iter()
                .filter_map(|e| e.summaries.iter().find(|x| x.method == s.method))
                .collect();
            let mean = |f: &dyn Fn(&MethodSummary) -> f64| {
                all.iter().map(|x| f(x)).sum::<f64>() / all.len() as f64
            };
            MethodSummary {
                method: s.method.clone(),
                auc_judd_unblurred: mean(&|x| x.auc_judd_unblurred),
                auc_judd_peak: mean(&|x| x.auc_judd_peak),
                auc_judd_peak_blur: mean(&|x| x.auc_judd_peak_blur),
                chance_auc_judd_at_peak: mean(&|x| x.chance_auc_judd_at_peak),
                lcc_unblurred: mean(&|x| x.lcc_unblurred),
                lcc_peak: mean(&|x| x.lcc_peak),
                lcc_peak_blur: mean(&|x| x.lcc_peak_blur),
                nss_unblurred: mean(&|x| x.nss_unblurred),
                gini_unblurred: mean(&|x| x.gini_unblurred),
            }
        })
        .collect()
}

pub fn run(args: ScoreArgs) -> Result<()> {
    let params = ScoreParams {
        blur_sigmas: blur_grid(args.blur_max, args.blur_step)?,
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
            let name = mesh.file_name().unwrap_or_default().to_string_lossy();
            let name = name.split('.').next().unwrap_or("mesh").to_string();
            vec![(name, mesh.clone(), truth.clone())]
        }
        _ => bail!("give --mesh and --truth, or --dataset DIR (see meshgaze score --help)"),
    };
    if args.method.is_empty() && args.saliency.is_empty() {
        bail!("nothing to score: give --method (e.g. sms,ms,mc) and/or --saliency FILE");
    }
    let bars = Bars::new(args.quiet);
    let mut inputs = Vec::new();
    let mut entries = Vec::new();
    let prefix = super::saliency::output_prefix(&args.output);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let csv_path = PathBuf::from(format!("{}.csv", prefix.display()));
    let mut csv = std::io::BufWriter::new(
        std::fs::File::create(&csv_path)
            .with_context(|| format!("cannot create {}", csv_path.display()))?,
    );
    writeln!(csv, "mesh,method,metric,blur,value")?;
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
            let out = compute_saliency(method, &mesh, &SmsParams::default(), &bars)
                .map_err(|e| anyhow::anyhow!("{}: {e}", mesh_path.display()))?;
            seconds.push((method.name().to_string(), out.seconds));
            maps.push((method.name().to_string(), out.values));
        }
        let score: MeshScore = score_mesh(&mesh, &truth, &maps, &params, &bars)
            .map_err(|e| anyhow::anyhow!("{}: {e}", mesh_path.display()))?;
        let plots = write_plots(&prefix, name, &maps, &score)?;
        for r in &score.rows {
            writeln!(
                csv,
                "{name},{},{},{},{}",
                r.method, r.metric, r.blur, r.value
            )?;
        }
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
            seconds_per_method: seconds,
            summaries: score.summaries,
        });
    }
    csv.flush()?;
    let mean = mean_summaries(&entries);
    print_table(&entries, &mean);
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

/// AUC-Judd over blur (methods, chance dashed, human ceiling in black) and Lorenz curves of
/// the unblurred maps with their Gini index.
pub fn write_plots(
    prefix: &Path,
    mesh: &str,
    maps: &[(String, Vec<f64>)],
    score: &MeshScore,
) -> Result<Vec<String>> {
    let curve = |method: &str, metric: &str| -> Vec<(f64, f64)> {
        score
            .rows
            .iter()
            .filter(|r| r.method == method && r.metric == metric && r.value.is_finite())
            .map(|r| (r.blur, r.value))
            .collect()
    };
    let mut series: Vec<Series> = maps
        .iter()
        .enumerate()
        .map(|(k, (name, _))| Series {
            name: name.clone(),
            points: curve(name, "auc_judd"),
            color: PALETTE[k % PALETTE.len()],
            dashed: false,
        })
        .collect();
    series.push(Series {
        name: "chance (random map)".into(),
        points: curve(CHANCE, "auc_judd"),
        color: RGBColor(128, 128, 128),
        dashed: true,
    });
    let human = curve(HUMAN, "auc_judd");
    if !human.is_empty() {
        series.push(Series {
            name: "human (split-half)".into(),
            points: human,
            color: RGBColor(0, 0, 0),
            dashed: false,
        });
    }
    let lowest = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.1))
        .fold(0.5f64, f64::min);
    let x_max = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| p.0))
        .fold(0.01f64, f64::max);
    let auc_path = PathBuf::from(format!("{}.{mesh}.auc.png", prefix.display()));
    line_chart_png(
        &auc_path,
        &Chart {
            title: &format!("{mesh}: AUC-Judd vs blur"),
            x_label: "blur σ_b (normalized units)",
            y_label: "AUC-Judd",
            x_range: (0.0, x_max),
            y_range: ((lowest - 0.05).max(0.0), 1.0),
        },
        &series,
    )
    .map_err(anyhow::Error::msg)?;
    let mut lorenz = vec![Series {
        name: "uniform (Gini 0)".into(),
        points: vec![(0.0, 0.0), (1.0, 1.0)],
        color: RGBColor(128, 128, 128),
        dashed: true,
    }];
    for (k, (name, values)) in maps.iter().enumerate() {
        let clipped: Vec<f64> = values.iter().map(|v| v.max(0.0)).collect();
        if let Some(points) = lorenz_curve(&clipped) {
            // At most ~500 points: enough for the eye.
            let step = (points.len() / 500).max(1);
            let mut thin: Vec<(f64, f64)> = points.iter().step_by(step).copied().collect();
            thin.push(*points.last().expect("non-empty"));
            lorenz.push(Series {
                name: format!("{name} (Gini {:.3})", gini_index(&clipped)),
                points: thin,
                color: PALETTE[k % PALETTE.len()],
                dashed: false,
            });
        }
    }
    let lorenz_path = PathBuf::from(format!("{}.{mesh}.lorenz.png", prefix.display()));
    line_chart_png(
        &lorenz_path,
        &Chart {
            title: &format!("{mesh}: Lorenz curves of the saliency maps"),
            x_label: "fraction of vertices, least salient first",
            y_label: "fraction of total saliency",
            x_range: (0.0, 1.0),
            y_range: (0.0, 1.0),
        },
        &lorenz,
    )
    .map_err(anyhow::Error::msg)?;
    Ok(vec![
        auc_path.display().to_string(),
        lorenz_path.display().to_string(),
    ])
}

fn print_table(entries: &[MeshEntry], mean: &[MethodSummary]) {
    println!("| mesh | method | AUC-Judd σ=0 | AUC-Judd peak (σ_b) | chance at that σ_b | LCC σ=0 | LCC peak (σ_b) |");
    println!("|---|---|---:|---:|---:|---:|---:|");
    let row = |mesh: &str, s: &MethodSummary| {
        println!(
            "| {mesh} | {} | {:.3} | {:.3} ({:.2}) | {:.3} | {:.3} | {:.3} ({:.2}) |",
            s.method,
            s.auc_judd_unblurred,
            s.auc_judd_peak,
            s.auc_judd_peak_blur,
            s.chance_auc_judd_at_peak,
            s.lcc_unblurred,
            s.lcc_peak,
            s.lcc_peak_blur
        )
    };
    for e in entries {
        for s in &e.summaries {
            row(&e.mesh, s);
        }
    }
    if entries.len() > 1 {
        for s in mean {
            row("**mean**", s);
        }
    }
}

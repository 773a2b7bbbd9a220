use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use plotters::style::RGBColor;
use serde::Serialize;

use meshgaze::experiments::features::evaluation_files::{
    alpha_sweep, separation_in_mesh_units, write_evaluation_csv, write_feature_points_csv,
    write_truth_points_csv, SeparationUnit,
};
use meshgaze::experiments::features::marks::parse_marks;
use meshgaze::experiments::features::{
    feature_points, voted_ground_truth, Evaluation, GeodesicGraph, TruthPoint,
};
use meshgaze::mesh::load_mesh;
use meshgaze::progress::Progress;
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::report::plot::{line_chart_png, Chart, Series, PALETTE};
use meshgaze::saliency::{compute_saliency_viewed, Method, RarityParams, SmsParams, Viewing};
use meshgaze::truth::{load_ground_truth, GroundTruth};

use super::progress_bar::Bars;

/// Feature points from a saliency map (the paper's §5.5), and their evaluation against human
/// marked points (Dutagaci et al. 2012, the paper's Fig. 9).
///
/// Feature points: local maxima over the 1-ring, kept above the mean of all local maxima,
/// sorted by saliency, accepted greedily when at least --separation from every accepted point
/// along the surface. The separation is in --unit normalized (default; the mesh scaled so half
/// its principal-axes bounding-box diagonal is 1, as SMS normalizes) or diameter (a fraction
/// of the geodesic diameter). Geodesics: Dijkstra on edges refined with --steiner points per
/// edge (about 1% error with 3; measured in tests/features.rs on a sphere).
///
/// With --marks (one file per subject: vertex indices, one per line; `#` comments and a
/// `vertex` header allowed): builds the voted ground truth for (--sigma, --min-subjects),
/// matches within α·d_M for α from 0 to --alpha-max, and reports FNE, FPE, WME, recall,
/// precision and F-measure. d_M is the double-sweep geodesic diameter (a lower bound).
///
/// Writes OUT.csv (rank, vertex, saliency, x, y, z), OUT.json (provenance, parameters),
/// and with marks OUT.truth.csv, OUT.eval.csv and OUT.eval.png.
#[derive(Debug, Args)]
pub struct FeaturesArgs {
    pub mesh: PathBuf,
    /// A per-vertex saliency map (vertex,saliency CSV, e.g. from `meshgaze saliency`).
    #[arg(long, conflicts_with = "method")]
    pub saliency: Option<PathBuf>,
    /// Compute this method's map instead.
    #[arg(long, value_enum)]
    pub method: Option<Method>,
    /// A parameter of sri, gr or mr as METHOD.NAME=VALUE (repeatable), as `saliency --set`.
    #[arg(long = "set", value_name = "METHOD.NAME=VALUE")]
    pub settings: Vec<String>,
    /// Output prefix.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, default_value_t = 0.15)]
    pub separation: f64,
    #[arg(long, value_enum, default_value_t = SeparationUnit::Normalized)]
    pub unit: SeparationUnit,
    /// Steiner points per edge for geodesics (0 = plain edge Dijkstra).
    #[arg(long, default_value_t = 3)]
    pub steiner: usize,
    /// Human-marked points, one file per subject.
    #[arg(long, num_args = 1..)]
    pub marks: Vec<PathBuf>,
    /// Ground-truth neighbourhood radius, fraction of the diameter.
    #[arg(long, default_value_t = 0.03)]
    pub sigma: f64,
    /// Subjects needed near a point for it to be ground truth.
    #[arg(long, default_value_t = 2)]
    pub min_subjects: usize,
    #[arg(long, default_value_t = 0.12)]
    pub alpha_max: f64,
    #[arg(long, default_value_t = 0.01)]
    pub alpha_step: f64,
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    saliency: String,
    separation: f64,
    unit: SeparationUnit,
    separation_in_mesh_units: f64,
    steiner_points_per_edge: usize,
    geodesic_diameter_double_sweep: f64,
    feature_points: usize,
    sigma: f64,
    min_subjects: usize,
    ground_truth: Option<&'a [TruthPoint]>,
    evaluation: Option<&'a [Evaluation]>,
}

/// Reads one subject's marked vertices.
pub fn read_marks(path: &Path, n_vertices: usize) -> Result<Vec<usize>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_marks(&text, &path.display().to_string(), n_vertices).map_err(anyhow::Error::msg)
}

pub fn run(args: FeaturesArgs) -> Result<()> {
    if args.separation.is_nan() || args.separation <= 0.0 {
        bail!("--separation must be positive");
    }
    let (mesh, _) = load_mesh(&args.mesh)?;
    let bars = Bars::new(args.quiet);
    let mut inputs = vec![InputFile::hash(&args.mesh)?];
    let (values, source) = match (&args.saliency, args.method) {
        (Some(f), _) => {
            let GroundTruth::VertexMap(m) = load_ground_truth(f, mesh.positions.len(), 0.05)?
            else {
                bail!(
                    "{}: expected a per-vertex map (vertex,saliency)",
                    f.display()
                );
            };
            inputs.push(InputFile::hash(f)?);
            (m.values, f.display().to_string())
        }
        (None, Some(m)) => (
            compute_saliency_viewed(
                m,
                &mesh,
                &SmsParams::default(),
                &Viewing {
                    rarity: RarityParams::default()
                        .with_settings(&args.settings)
                        .map_err(anyhow::Error::msg)?,
                    ..Viewing::builtin()
                },
                &bars,
            )
            .map_err(anyhow::Error::msg)?
            .values,
            if args.settings.is_empty() {
                format!("method {}", m.name())
            } else {
                format!(
                    "method {} with --set {}",
                    m.name(),
                    args.settings.join(" --set ")
                )
            },
        ),
        (None, None) => {
            bail!("give --saliency FILE or --method NAME (sms, mc, ms, si, sri, mr, gr, ...)")
        }
    };
    bars.start("geodesic graph", 0);
    let graph = GeodesicGraph::new(&mesh, args.steiner);
    bars.finish();
    bars.start("geodesic diameter (double sweep)", 0);
    let diameter = graph.diameter_double_sweep();
    bars.finish();
    let separation = separation_in_mesh_units(&mesh, args.separation, args.unit, diameter);
    let points = feature_points(&mesh, &values, &graph, separation);
    let prefix = meshgaze::saliency::map_file::output_prefix(&args.output);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let path = |ext: &str| PathBuf::from(format!("{}{ext}", prefix.display()));
    write_feature_points_csv(create(&path(".csv"))?, &mesh, &points)?;
    let mut truth = None;
    let mut evals = None;
    if !args.marks.is_empty() {
        let mut marks = Vec::new();
        for f in &args.marks {
            marks.push(read_marks(f, mesh.positions.len())?);
            inputs.push(InputFile::hash(f)?);
        }
        let t = voted_ground_truth(&graph, &marks, args.sigma, args.min_subjects, diameter);
        let detected: Vec<usize> = points.iter().map(|p| p.vertex).collect();
        let e = alpha_sweep(
            &graph,
            &t,
            &detected,
            args.alpha_max,
            args.alpha_step,
            diameter,
        )
        .map_err(anyhow::Error::msg)?;
        write_truth_points_csv(create(&path(".truth.csv"))?, &t)?;
        write_evaluation_csv(create(&path(".eval.csv"))?, &e)?;
        let series = |name: &str, color: RGBColor, f: fn(&Evaluation) -> f64| Series {
            name: name.into(),
            points: e
                .iter()
                .filter(|x| f(x).is_finite())
                .map(|x| (x.alpha, f(x)))
                .collect(),
            color,
            dashed: false,
            band: Vec::new(),
        };
        line_chart_png(
            &path(".eval.png"),
            &Chart {
                title: "Feature points against human marks (Dutagaci et al. 2012)",
                x_label: "tolerance α (fraction of the geodesic diameter)",
                y_label: "score",
                x_range: (0.0, args.alpha_max.max(1e-6)),
                y_range: (0.0, 1.0),
            },
            &[
                series("recall", PALETTE[0], |x| x.recall),
                series("precision", PALETTE[1], |x| x.precision),
                series("F-measure", PALETTE[2], |x| x.f_measure),
            ],
        )
        .map_err(anyhow::Error::msg)?;
        truth = Some(t);
        evals = Some(e);
    }
    let sidecar = Sidecar {
        provenance: Provenance::new(inputs),
        saliency: source,
        separation: args.separation,
        unit: args.unit,
        separation_in_mesh_units: separation,
        steiner_points_per_edge: args.steiner,
        geodesic_diameter_double_sweep: diameter,
        feature_points: points.len(),
        sigma: args.sigma,
        min_subjects: args.min_subjects,
        ground_truth: truth.as_deref(),
        evaluation: evals.as_deref(),
    };
    std::fs::write(
        path(".json"),
        serde_json::to_string_pretty(&sidecar)? + "\n",
    )?;
    if !args.quiet {
        eprintln!(
            "{} feature points at least {} {} apart ({separation:.4} in mesh units; geodesic diameter {diameter:.4})",
            points.len(),
            args.separation,
            match args.unit {
                SeparationUnit::Normalized => "normalized units",
                SeparationUnit::Diameter => "of the geodesic diameter",
            }
        );
        if let (Some(t), Some(e)) = (&truth, &evals) {
            eprintln!(
                "{} ground-truth points (σ {}, n {}); at α = {}: recall {:.3}, precision {:.3}, F {:.3}",
                t.len(),
                args.sigma,
                args.min_subjects,
                e.last().map_or(f64::NAN, |x| x.alpha),
                e.last().map_or(f64::NAN, |x| x.recall),
                e.last().map_or(f64::NAN, |x| x.precision),
                e.last().map_or(f64::NAN, |x| x.f_measure)
            );
        }
        eprintln!(
            "wrote {}.csv and .json{}",
            prefix.display(),
            if truth.is_some() {
                ", .truth.csv, .eval.csv, .eval.png"
            } else {
                ""
            }
        );
    }
    Ok(())
}

fn create(path: &Path) -> Result<std::io::BufWriter<std::fs::File>> {
    Ok(std::io::BufWriter::new(
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
    ))
}

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::Args;

use meshgaze::experiments::features::evaluation_files::SeparationUnit;
use meshgaze::mesh::{load_mesh, Mesh};
use meshgaze::pipeline::feature_points::{run_feature_points, FeatureParams};
use meshgaze::provenance::InputFile;
use meshgaze::saliency::map_file::read_map;
use meshgaze::saliency::{compute_saliency_viewed, Method, RarityParams, SmsParams, Viewing};

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

pub fn run(args: FeaturesArgs) -> Result<()> {
    let (mesh, _) = load_mesh(&args.mesh)?;
    let bars = Bars::new(args.quiet);
    let mut inputs = vec![InputFile::hash(&args.mesh)?];
    let (values, source) = saliency_values(&args, &mesh, &bars, &mut inputs)?;
    let params = FeatureParams {
        separation: args.separation,
        unit: args.unit,
        steiner: args.steiner,
        sigma: args.sigma,
        min_subjects: args.min_subjects,
        alpha_max: args.alpha_max,
        alpha_step: args.alpha_step,
    };
    let prefix = meshgaze::saliency::map_file::output_prefix(&args.output);
    let run = run_feature_points(
        &mesh,
        &values,
        &source,
        &args.marks,
        &params,
        inputs,
        &prefix,
        &bars,
    )?;
    if !args.quiet {
        let unit = match args.unit {
            SeparationUnit::Normalized => "normalized units",
            SeparationUnit::Diameter => "of the geodesic diameter",
        };
        eprintln!(
            "{} feature points at least {} {unit} apart ({:.4} in mesh units; geodesic diameter {:.4})",
            run.points, args.separation, run.separation_in_mesh_units, run.diameter
        );
        if let (Some(t), Some((alpha, recall, precision, f))) = (run.truth_points, run.last) {
            eprintln!(
                "{t} ground-truth points (σ {}, n {}); at α = {alpha}: recall {recall:.3}, precision {precision:.3}, F {f:.3}",
                args.sigma, args.min_subjects
            );
        }
        let extra = if run.truth_points.is_some() {
            ", .truth.csv, .eval.csv, .eval.png"
        } else {
            ""
        };
        eprintln!("wrote {}.csv and .json{extra}", prefix.display());
    }
    Ok(())
}

/// The map to pick feature points from: a --saliency file (hashed into `inputs`) or a
/// --method computed here, and its description.
fn saliency_values(
    args: &FeaturesArgs,
    mesh: &Mesh,
    bars: &Bars,
    inputs: &mut Vec<InputFile>,
) -> Result<(Vec<f64>, String)> {
    Ok(match (&args.saliency, args.method) {
        (Some(f), _) => {
            inputs.push(InputFile::hash(f)?);
            (read_map(f, mesh.positions.len())?, f.display().to_string())
        }
        (None, Some(m)) => {
            let viewing = Viewing {
                rarity: RarityParams::default()
                    .with_settings(&args.settings)
                    .map_err(anyhow::Error::msg)?,
                ..Viewing::builtin()
            };
            let out = compute_saliency_viewed(m, mesh, &SmsParams::default(), &viewing, bars)
                .map_err(anyhow::Error::msg)?;
            let settings = if args.settings.is_empty() {
                String::new()
            } else {
                format!(" with --set {}", args.settings.join(" --set "))
            };
            (out.values, format!("method {}{settings}", m.name()))
        }
        (None, None) => {
            bail!("give --saliency FILE or --method NAME (sms, mc, ms, si, sri, mr, gr, ...)")
        }
    })
}

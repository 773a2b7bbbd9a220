use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, Subcommand};

use meshgaze::experiments::robustness::{robustness, RobustnessParams};
use meshgaze::mesh::load_mesh;
use meshgaze::saliency::{Method, SmsParams};

use super::progress_bar::Bars;
use meshgaze::report::robustness_report::write_robustness;

/// Rerun the paper's experiments on your own meshes.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    #[command(subcommand)]
    pub which: Experiment,
}

#[derive(Debug, Subcommand)]
pub enum Experiment {
    Robustness(RobustnessArgs),
}

/// Robustness to noise, simplification and holes (the paper's Fig. 8).
///
/// Damages the mesh three ways: Gaussian noise along vertex normals (--noise, a fraction of
/// the mean edge length; paper 20%), quadric-edge-collapse simplification (--simplify-to,
/// paper 5k vertices) and holes (--holes patches of --hole-radius normalized units). Computes
/// each method's map on the clean mesh and on every copy, carries each copy's map back to the
/// original vertices from the nearest surface point, and reports its agreement with the
/// method's clean map: Pearson correlation, and the AUC of the carried-back map at finding
/// the clean map's top --top-fraction vertices. Writes OUT.csv, OUT.md (table), OUT.json
/// (provenance) and OUT.png (rows: methods; columns: clean, noise, simplified, holes, each
/// copy shown with its own map).
#[derive(Debug, Args)]
pub struct RobustnessArgs {
    pub mesh: PathBuf,
    /// Output prefix.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, value_delimiter = ',', default_value = "sms,mc,ms,si,sri,mr,gr")]
    pub method: Vec<Method>,
    /// A parameter of sri, gr or mr as METHOD.NAME=VALUE (repeatable), as `saliency --set`.
    #[arg(long = "set", value_name = "METHOD.NAME=VALUE")]
    pub settings: Vec<String>,
    #[arg(long, default_value_t = 0.2)]
    pub noise: f64,
    #[arg(long, default_value_t = 5000)]
    pub simplify_to: usize,
    #[arg(long, default_value_t = 5)]
    pub holes: usize,
    #[arg(long, default_value_t = 0.05)]
    pub hole_radius: f64,
    #[arg(long, default_value_t = 0.1)]
    pub top_fraction: f64,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: ExperimentArgs) -> Result<()> {
    match args.which {
        Experiment::Robustness(a) => run_robustness(a),
    }
}

fn run_robustness(args: RobustnessArgs) -> Result<()> {
    if !(args.noise >= 0.0
        && args.hole_radius > 0.0
        && args.top_fraction > 0.0
        && args.top_fraction <= 1.0)
    {
        bail!("--noise must be >= 0, --hole-radius > 0, --top-fraction in (0, 1]");
    }
    if args.method.is_empty() {
        bail!("--method: give at least one method");
    }
    let (mesh, _) = load_mesh(&args.mesh)?;
    let params = RobustnessParams {
        noise_fraction: args.noise,
        simplify_to: args.simplify_to,
        holes: args.holes,
        hole_radius: args.hole_radius,
        top_fraction: args.top_fraction,
        seed: args.seed,
        rarity: meshgaze::saliency::RarityParams::default()
            .with_settings(&args.settings)
            .map_err(anyhow::Error::msg)?,
    };
    let bars = Bars::new(args.quiet);
    let result = robustness(&mesh, &args.method, &SmsParams::default(), &params, &bars)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.mesh.display()))?;
    let prefix = meshgaze::saliency::map_file::output_prefix(&args.output);
    let md = write_robustness(&args.mesh, &mesh, &args.method, &params, &result, &prefix)?;
    print!("{md}");
    if !args.quiet {
        eprintln!(
            "wrote {}.csv, .md, .json, .png (rows: {}; columns: clean, noise, simplified, holes)",
            prefix.display(),
            args.method
                .iter()
                .map(|m| m.name())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(())
}

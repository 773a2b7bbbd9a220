use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use image::RgbImage;
use serde::Serialize;

use meshgaze::experiments::robustness::{robustness, AgreementRow, RobustnessParams};
use meshgaze::mesh::load_mesh;
use meshgaze::protocol::Protocol;
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::saliency::{Method, SmsParams};
use meshgaze::stimulus::camera::CameraPlan;

use super::progress_bar::Bars;
use meshgaze::report::map_render::render_map;

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

#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    parameters: &'a RobustnessParams,
    corruptions: Vec<(&'static str, String, usize, usize)>,
    rows: &'a [AgreementRow],
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
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let path = |ext: &str| PathBuf::from(format!("{}.{ext}", prefix.display()));
    let mut csv = std::io::BufWriter::new(std::fs::File::create(path("csv"))?);
    writeln!(csv, "mesh,method,corruption,pearson,auc_top,seconds")?;
    let name = args
        .mesh
        .file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .to_string();
    for r in &result.rows {
        writeln!(
            csv,
            "{name},{},{},{},{},{}",
            r.method, r.corruption, r.pearson, r.auc_top, r.seconds
        )?;
    }
    csv.flush()?;
    let mut md = format!(
        "Robustness on {name} ({} vertices): agreement with each method's map on the clean mesh, Pearson / AUC of finding the clean top {:.0}%.\n\n| method | noise | simplified | holes |\n|---|---:|---:|---:|\n",
        mesh.positions.len(),
        100.0 * args.top_fraction
    );
    for m in &args.method {
        md += &format!("| {} |", m.name());
        for c in ["noise", "simplified", "holes"] {
            let r = result
                .rows
                .iter()
                .find(|r| r.method == m.name() && r.corruption == c)
                .expect("row per pair");
            md += &format!(" {:.3} / {:.3} |", r.pearson, r.auc_top);
        }
        md += "\n";
    }
    md += "\n";
    for c in &result.corrupted {
        md += &format!("- {}: {}\n", c.name, c.description);
    }
    std::fs::write(path("md"), &md)?;
    // Figure: one row per method, clean then the three copies, each with its own map.
    let text = include_str!("../../protocols/hu2020.toml")
        .replace("width_px = 1680", "width_px = 400")
        .replace("height_px = 1050", "height_px = 400");
    let protocol = Protocol::from_toml(&text, "hu2020.toml (400x400)")?;
    let plan = CameraPlan::new(&mesh, &protocol).map_err(anyhow::Error::msg)?;
    let (w, h) = (400u32, 400u32);
    let cols = 1 + result.corrupted.len() as u32;
    let mut fig = RgbImage::from_pixel(
        w * cols,
        h * result.maps.len() as u32,
        image::Rgb([255, 255, 255]),
    );
    for (row, (_, clean, own)) in result.maps.iter().enumerate() {
        let mut tiles = vec![render_map(&mesh, &plan, &protocol, clean, 0)];
        for (c, values) in result.corrupted.iter().zip(own) {
            tiles.push(render_map(&c.mesh, &plan, &protocol, values, 0));
        }
        for (col, tile) in tiles.iter().enumerate() {
            image::imageops::overlay(
                &mut fig,
                tile,
                (col as u32 * w) as i64,
                (row as u32 * h) as i64,
            );
        }
    }
    fig.save(path("png"))
        .with_context(|| format!("cannot write {}", path("png").display()))?;
    let sidecar = Sidecar {
        provenance: Provenance::new(vec![InputFile::hash(&args.mesh)?]),
        parameters: &params,
        corruptions: result
            .corrupted
            .iter()
            .map(|c| {
                (
                    c.name,
                    c.description.clone(),
                    c.mesh.positions.len(),
                    c.mesh.triangles.len(),
                )
            })
            .collect(),
        rows: &result.rows,
    };
    std::fs::write(path("json"), serde_json::to_string_pretty(&sidecar)? + "\n")?;
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

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use meshgaze::projection::{fate_counts_by_name, fate_table_text};
use meshgaze::scoring::surface_blur::BlurKernel;
use meshgaze::stimulus::load::load_stimulus;
use meshgaze::truth::{build_truth, projected_file, read_projections, write_truth, TruthParams};

use super::progress_bar::Bars;

/// Build a mesh's ground truth from projected fixations of several subjects.
///
/// Reads projected.csv files (or folders holding one) written by `meshgaze project` for the
/// stimulus, checks their project.json names the same mesh, and writes:
/// OUT/truth.csv (every fixation with its fate, vertex and surface point: the fixation-set
/// format `meshgaze score --truth` reads), OUT/density.csv (vertex, fixation count, density
/// blurred with σ_b = --blur in normalized units, and the cone density when the projections
/// used --cone-deg), OUT/truth.ply (density as quality and colour; MeshLab: Render > Color >
/// Per Vertex), OUT/human.csv (the split-half human ceiling over blur: every split of the
/// subjects into halves, both directions, when there are at most 8) and OUT/truth.json
/// (provenance, fates per subject, on-mesh fixations per subject against the protocol's
/// expected count).
#[derive(Debug, Args)]
pub struct TruthArgs {
    /// The stimulus (manifest.json or its folder).
    #[arg(long)]
    pub stimulus: PathBuf,
    /// projected.csv files, or folders holding one.
    #[arg(required = true)]
    pub projected: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Blur σ_b of the density map, normalized units (half principal-axes box diagonal = 1).
    #[arg(long, default_value_t = 0.02)]
    pub blur: f64,
    /// Largest blur of the human-ceiling sweep.
    #[arg(long, default_value_t = 0.2)]
    pub blur_max: f64,
    /// Step of the human-ceiling sweep.
    #[arg(long, default_value_t = 0.01)]
    pub blur_step: f64,
    /// Blur kernel: Euclidean (fast) or heat diffusion (along the surface).
    #[arg(long, value_enum, default_value_t = BlurKernel::Euclidean)]
    pub kernel: BlurKernel,
    /// The mesh, if it moved since rendering.
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    #[arg(short, long)]
    pub quiet: bool,
}

impl TruthArgs {
    pub fn params(&self) -> TruthParams {
        TruthParams {
            blur: self.blur,
            blur_max: self.blur_max,
            blur_step: self.blur_step,
            kernel: self.kernel,
        }
    }
}

pub fn run(args: TruthArgs) -> Result<()> {
    let bars = Bars::new(args.quiet);
    let stim = load_stimulus(&args.stimulus, args.mesh.as_deref()).map_err(anyhow::Error::msg)?;
    let files: Vec<PathBuf> = args.projected.iter().map(|p| projected_file(p)).collect();
    let projections = read_projections(&stim, &files)?;
    let r = build_truth(&stim, projections, &args.params(), &bars)?;
    write_truth(&args.output, &stim, &r)?;
    if !args.quiet {
        let fates: BTreeMap<String, BTreeMap<&'static str, usize>> = r
            .sidecar
            .subjects
            .iter()
            .map(|(s, t)| (s.clone(), t.fates.clone()))
            .collect();
        eprint!("{}", fate_table_text(&fates, &fate_counts_by_name(&r.rows)));
        for w in &r.sidecar.warnings {
            eprintln!("warning: {w}");
        }
        eprintln!(
            "{} fixations on the mesh from {} subjects ({} vertices fixated); human ceiling AUC-Judd {:.3} unblurred, {:.3} at σ_b = {} ({} splits)",
            r.sidecar.fixations_on_mesh,
            r.sidecar.subjects.len(),
            r.sidecar.fixated_vertices,
            r.sidecar.human_auc_judd_unblurred,
            r.sidecar.human_auc_judd_peak,
            r.sidecar.human_auc_judd_peak_blur,
            r.sidecar.human_splits
        );
        eprintln!(
            "wrote truth.csv, density.csv, truth.ply, human.csv, truth.json to {}",
            args.output.display()
        );
    }
    Ok(())
}

use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use meshgaze::mesh::geometry::BoundingBox;
use meshgaze::mesh::{load_mesh, LoadReport, Mesh};
use meshgaze::provenance::InputFile;
use meshgaze::saliency::map_file::{compute_and_write_map, output_prefix, MapOutputs};
use meshgaze::saliency::sms::descriptors::{
    DescriptorNormalization, DescriptorParams, GridParams, ShellWeight,
};
use meshgaze::saliency::sms::gaussian_interpolation::InterpolationKind;
use meshgaze::saliency::sms::truncated_power::PowerParams;
use meshgaze::saliency::{FieldKind, Method, SmsParams};

use super::progress_bar::Bars;

/// Compute a per-vertex saliency map of a mesh.
///
/// Writes OUT.csv (`vertex,saliency`, input vertex order, values in [0,1]), OUT.ply (the mesh
/// with a per-vertex `quality` and a blue→red colour ramp; in MeshLab use
/// Render > Color > Per Vertex) and OUT.json (provenance: version, parameters, seed, input
/// SHA-256, timings, Gini index). Reads OBJ, PLY (ascii/binary, tristrips) and OFF, each
/// optionally gzipped.
///
/// Methods: sms (sparse metric-based saliency, Hu et al., Neurocomputing 2020; the default),
/// ms (Lee et al. 2005 mesh saliency), mc (magnitude of mean curvature). SMS defaults are the
/// paper's; choices the paper leaves open have flags too (docs/sms.md). The --per-sample,
/// --per-scale and --dense outputs exist for sms only.
#[derive(Debug, Args)]
pub struct SaliencyArgs {
    /// The mesh (.obj, .ply, .off, optionally .gz).
    pub mesh: PathBuf,
    /// Output prefix: writes PREFIX.csv, PREFIX.ply and PREFIX.json.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, value_enum, default_value_t = Method::Sms)]
    pub method: Method,
    #[command(flatten)]
    pub sms: SmsArgs,
    /// Also write PREFIX.samples.csv: sample positions and their sparse saliency.
    #[arg(long)]
    pub per_sample: bool,
    /// Also write one map per scale, each from that scale's metric alone (paper Fig. 3).
    #[arg(long)]
    pub per_scale: bool,
    /// Also write the map without sparsity, μ = 1 (paper Fig. 2).
    #[arg(long)]
    pub dense: bool,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

/// Parameters of the sparse metric-based method. Defaults follow the paper.
#[derive(Debug, Clone, Args)]
pub struct SmsArgs {
    /// Random surface samples n.
    #[arg(long, default_value_t = 5000)]
    pub samples: usize,
    /// Seed of the surface sampling; same mesh + parameters + seed = same output bytes.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Ball radii of the multi-scale descriptors, normalized units (half bbox diagonal = 1).
    #[arg(long, value_delimiter = ',', default_values_t = vec![0.02, 0.04, 0.06, 0.08, 0.10])]
    pub scales: Vec<f64>,
    /// Fraction μ of samples allowed non-zero saliency.
    #[arg(long, default_value_t = 0.2)]
    pub mu: f64,
    /// Gaussian σ of the sample-to-vertex interpolation, normalized units (radius 3σ).
    #[arg(long, default_value_t = 0.02)]
    pub sigma: f64,
    /// Voxels per side of the Gaussian distance field.
    #[arg(long, default_value_t = 256)]
    pub grid: usize,
    /// Width of the distance field's Gaussian, in voxels [not in the paper; ShapeSPH: √8].
    #[arg(long, default_value_t = 8f64.sqrt())]
    pub gedt_sigma_voxels: f64,
    /// Concentric shells per ball.
    #[arg(long, default_value_t = 8)]
    pub shells: usize,
    /// Spherical-harmonic bands per shell.
    #[arg(long, default_value_t = 8)]
    pub bands: usize,
    /// Gauss–Legendre rings of the sphere quadrature, twice as many longitudes [not in the
    /// paper; 24 keeps the rotation error of descriptors under 1e-3].
    #[arg(long, default_value_t = 24)]
    pub quadrature_rings: usize,
    /// Shell weighting before the transform [not in the paper; ShapeSPH: area].
    #[arg(long, value_enum, default_value_t = ShellWeight::Area)]
    pub shell_weight: ShellWeight,
    /// Per-scale descriptor normalization [not in the paper].
    #[arg(long, value_enum, default_value_t = DescriptorNormalization::Raw)]
    pub descriptor_norm: DescriptorNormalization,
    /// Sample-to-vertex interpolation: weighted mean (Eq. 2) or plain sum.
    #[arg(long, value_enum, default_value_t = InterpolationKind::Normalized)]
    pub interpolation: InterpolationKind,
    /// Box whose half diagonal is scaled to 1: oriented (principal axes; rotation invariant)
    /// or axis-aligned.
    #[arg(long, value_enum, default_value_t = BoundingBox::Oriented)]
    pub bbox: BoundingBox,
    /// Distance field: grid (fast) or exact (brute force, small meshes only; for validation).
    #[arg(long, value_enum, default_value_t = FieldKind::Grid)]
    pub field: FieldKind,
    /// Iteration cap of the power and truncated power methods.
    #[arg(long, default_value_t = 1000)]
    pub max_iterations: usize,
    /// Relative convergence tolerance of the power and truncated power methods.
    #[arg(long, default_value_t = 1e-12)]
    pub tolerance: f64,
}

impl SmsArgs {
    pub fn params(&self) -> SmsParams {
        SmsParams {
            samples: self.samples,
            seed: self.seed,
            descriptor: DescriptorParams {
                scales: self.scales.clone(),
                shells: self.shells,
                bands: self.bands,
                quadrature_rings: self.quadrature_rings,
                shell_weight: self.shell_weight,
                normalization: self.descriptor_norm,
            },
            field: self.field,
            grid: GridParams {
                resolution: self.grid,
                sigma_voxels: self.gedt_sigma_voxels,
            },
            mu: self.mu,
            sigma: self.sigma,
            interpolation: self.interpolation,
            bounding_box: self.bbox,
            power: PowerParams {
                max_iterations: self.max_iterations,
                tolerance: self.tolerance,
            },
        }
    }
}

impl SaliencyArgs {
    fn outputs(&self) -> MapOutputs {
        MapOutputs {
            per_sample: self.per_sample,
            per_scale: self.per_scale,
            dense: self.dense,
        }
    }
}

/// Computes and writes one map, then says what it did.
fn compute_and_report(
    mesh_path: &Path,
    mesh: &Mesh,
    load: &LoadReport,
    input: InputFile,
    args: &SaliencyArgs,
) -> Result<()> {
    let bars = Bars::new(args.quiet);
    let r = compute_and_write_map(
        mesh_path,
        mesh,
        load,
        input,
        args.method,
        &args.sms.params(),
        args.outputs(),
        &output_prefix(&args.output),
        &bars,
    )?;
    if args.quiet {
        return Ok(());
    }
    eprintln!(
        "{}: {} vertices, {} triangles; {} in {:.2} s; Gini {:.3}",
        mesh_path.display(),
        mesh.positions.len(),
        mesh.triangles.len(),
        args.method.name(),
        r.seconds,
        r.gini
    );
    if let Some(r) = &r.sms {
        let t = &r.report.timings;
        eprintln!(
            "  steps: A metric {:.2} s, B saliency {:.2} s, C interpolation {:.2} s",
            t.a_metric_s, t.b_saliency_s, t.c_interpolation_s
        );
        if !r.report.truncated_power.converged {
            eprintln!(
                "  warning: the truncated power method stopped at the iteration cap ({}) before converging",
                r.report.truncated_power.iterations
            );
        }
    }
    let skipped = load.faces_with_repeated_vertex + load.zero_area_faces;
    if skipped > 0 || load.unreferenced_vertices > 0 {
        eprintln!(
            "  note: skipped {} degenerate faces ({} repeated vertex, {} zero area); {} unreferenced vertices (kept, valued by position)",
            skipped, load.faces_with_repeated_vertex, load.zero_area_faces, load.unreferenced_vertices
        );
    }
    eprintln!("wrote {}", r.outputs.join(", "));
    Ok(())
}

pub fn run(args: SaliencyArgs) -> Result<()> {
    if !args.mesh.exists() {
        bail!("{}: no such file", args.mesh.display());
    }
    let (mesh, load) = load_mesh(&args.mesh)?;
    let input = InputFile::hash(&args.mesh)
        .with_context(|| format!("cannot read {}", args.mesh.display()))?;
    compute_and_report(&args.mesh, &mesh, &load, input, &args)?;
    Ok(())
}

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::descriptors::{DescriptorNormalization, DescriptorParams, GridParams, ShellWeight};
use meshgaze::geometry::BoundingBox;
use meshgaze::mesh::{load_mesh, write_ply_with_quality, LoadReport, Mesh};
use meshgaze::metrics::gini_index;
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::saliency::gaussian_interpolation::InterpolationKind;
use meshgaze::saliency::truncated_power::PowerParams;
use meshgaze::saliency::{
    compute_saliency, sparse_metric_saliency, FieldKind, Method, SmsExtras, SmsParams,
};

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

/// The JSON sidecar of a saliency map.
#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    method: Method,
    /// SMS parameters (for sms only; other methods report theirs in `report`).
    parameters: Option<&'a SmsParams>,
    mesh: &'a LoadReport,
    report: serde_json::Value,
    gini_index: f64,
    seconds: f64,
    extra_maps: Vec<(String, f64)>,
    outputs: Vec<String>,
}

/// What one run produced, for callers that summarize.
pub struct SaliencyRun {
    pub gini: f64,
    pub seconds: f64,
    pub values: Vec<f64>,
}

/// `PREFIX` without a trailing .csv/.ply/.json, so `-o out.csv` means prefix `out`.
pub fn output_prefix(p: &Path) -> PathBuf {
    match p.extension().and_then(|e| e.to_str()) {
        Some("csv" | "ply" | "json") => p.with_extension(""),
        _ => p.to_path_buf(),
    }
}

fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_os_string();
    s.push(suffix);
    PathBuf::from(s)
}

pub fn write_map_csv(path: &Path, values: &[f64]) -> Result<()> {
    let mut out = std::io::BufWriter::new(
        std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?,
    );
    writeln!(out, "vertex,saliency")?;
    for (i, v) in values.iter().enumerate() {
        // `{}` prints the shortest text that reads back to the same f64: exact and stable.
        writeln!(out, "{i},{v}")?;
    }
    out.flush()?;
    Ok(())
}

/// Computes and writes everything for one mesh; returns the map for callers that report.
pub fn compute_and_write(
    mesh_path: &Path,
    mesh: &Mesh,
    load: &LoadReport,
    input: InputFile,
    args: &SaliencyArgs,
) -> Result<SaliencyRun> {
    let params = args.sms.params();
    let bars = Bars::new(args.quiet);
    let fail = |e: String| anyhow::anyhow!("{}: {e}", mesh_path.display());
    let wants_extras = args.per_sample || args.per_scale || args.dense;
    if wants_extras && args.method != Method::Sms {
        bail!("--per-sample, --per-scale and --dense apply to --method sms only");
    }
    let (values, report, seconds, sms_result) = if args.method == Method::Sms {
        let extras = SmsExtras {
            per_scale: args.per_scale,
            dense: args.dense,
        };
        let r = sparse_metric_saliency(mesh, &params, extras, &bars).map_err(fail)?;
        let report = serde_json::to_value(&r.report)?;
        (
            r.vertex_saliency.clone(),
            report,
            r.report.timings.total_s,
            Some(r),
        )
    } else {
        let out = compute_saliency(args.method, mesh, &params, &bars).map_err(fail)?;
        (out.values, out.report, out.seconds, None)
    };
    let gini = gini_index(&values);
    let prefix = output_prefix(&args.output);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create output folder {}", dir.display()))?;
    }
    let mut outputs = Vec::new();
    let csv = with_suffix(&prefix, ".csv");
    write_map_csv(&csv, &values)?;
    outputs.push(csv.display().to_string());
    let comments = vec![
        format!(
            "meshgaze {} {} saliency of {}",
            env!("CARGO_PKG_VERSION"),
            args.method.name(),
            mesh_path.display()
        ),
        format!("input sha256 {}", input.sha256),
        "quality = saliency in [0,1]; colour ramp blue (low) to red (high)".to_string(),
    ];
    let ply = with_suffix(&prefix, ".ply");
    write_ply_with_quality(&ply, mesh, &values, &comments)
        .with_context(|| format!("cannot write {}", ply.display()))?;
    outputs.push(ply.display().to_string());
    let mut extra_maps = Vec::new();
    if let Some(result) = &sms_result {
        if args.per_sample {
            let path = with_suffix(&prefix, ".samples.csv");
            let mut out = std::io::BufWriter::new(std::fs::File::create(&path)?);
            writeln!(out, "sample,x,y,z,saliency")?;
            for (i, (p, s)) in result
                .sample_points
                .iter()
                .zip(&result.sample_saliency)
                .enumerate()
            {
                writeln!(out, "{i},{},{},{},{s}", p.x, p.y, p.z)?;
            }
            out.flush()?;
            outputs.push(path.display().to_string());
        }
        for extra in &result.extras {
            let base = with_suffix(&prefix, &format!(".{}", extra.name));
            let c = with_suffix(&base, ".csv");
            write_map_csv(&c, &extra.vertex_saliency)?;
            let p = with_suffix(&base, ".ply");
            write_ply_with_quality(&p, mesh, &extra.vertex_saliency, &comments)?;
            outputs.push(c.display().to_string());
            outputs.push(p.display().to_string());
            extra_maps.push((extra.name.clone(), extra.gini));
        }
    }
    let json = with_suffix(&prefix, ".json");
    outputs.push(json.display().to_string());
    let sidecar = Sidecar {
        provenance: Provenance::new(vec![input]),
        method: args.method,
        parameters: (args.method == Method::Sms).then_some(&params),
        mesh: load,
        report,
        gini_index: gini,
        seconds,
        extra_maps,
        outputs,
    };
    std::fs::write(&json, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("cannot write {}", json.display()))?;
    if !args.quiet {
        eprintln!(
            "{}: {} vertices, {} triangles; {} in {:.2} s; Gini {:.3}",
            mesh_path.display(),
            mesh.positions.len(),
            mesh.triangles.len(),
            args.method.name(),
            seconds,
            gini
        );
        if let Some(r) = &sms_result {
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
        eprintln!("wrote {}", sidecar.outputs.join(", "));
    }
    Ok(SaliencyRun {
        gini,
        seconds,
        values,
    })
}

pub fn run(args: SaliencyArgs) -> Result<()> {
    if !args.mesh.exists() {
        bail!("{}: no such file", args.mesh.display());
    }
    let (mesh, load) = load_mesh(&args.mesh)?;
    let input = InputFile::hash(&args.mesh)
        .with_context(|| format!("cannot read {}", args.mesh.display()))?;
    compute_and_write(&args.mesh, &mesh, &load, input, &args)?;
    Ok(())
}

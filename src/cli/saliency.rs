use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::Args;

use meshgaze::gaze_model::surface_points::read_gaze_points;
use meshgaze::gaze_model::GazeModel;
use meshgaze::mesh::geometry::BoundingBox;
use meshgaze::mesh::sampling::Sampling;
use meshgaze::mesh::{load_mesh, LoadReport, Mesh};
use meshgaze::protocol::{Protocol, UpAxis};
use meshgaze::provenance::InputFile;
use meshgaze::saliency::map_file::{compute_and_write_map, output_prefix, MapOutputs};
use meshgaze::saliency::point_cloud::point_cloud_saliency;
use meshgaze::saliency::sms::descriptors::{
    DescriptorNormalization, DescriptorParams, GridParams, QuadratureRule, ShellWeight,
};
use meshgaze::saliency::sms::gaussian_interpolation::InterpolationKind;
use meshgaze::saliency::sms::truncated_power::PowerParams;
use meshgaze::saliency::{FieldKind, Method, RarityParams, SmsParams, Viewing};

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
/// ms (Lee et al. 2005 mesh saliency), mc (magnitude of mean curvature), si (Song et al.
/// 2014), the global-rarity methods sri (Leifman et al. 2012), gr (Wu et al. 2013) and mr
/// (Tao et al. 2015) with --set for their parameters (docs/baselines.md), and three that know how the mesh is shown: up (height along the protocol's up
/// axis), centre (closeness to the screen centre over the hold views that show a vertex) and
/// gaze (the learned gaze model: built-in, or --model from `meshgaze train`; docs/gaze_model.md).
/// SMS defaults are the paper's; choices the paper leaves open have flags too (docs/sms.md).
/// The --per-sample, --per-scale and --dense outputs exist for sms only.
///
/// What the built-in gaze model is: boosted trees trained on ONE experiment, the VR
/// eye-tracking data of ../shared/data/fixations-vr (32 observers in a headset, 44 objects
/// of the 3DVA benchmark). It learned that experiment's viewing habits and is not a general
/// predictor of where people look: on another lab's meshes it has scored at chance where
/// curvature did better. Before trusting it on your meshes, score it beside the classical
/// methods on a few of your own with truth, and train on your own data:
///   meshgaze score --dataset MY_LAB --method gaze,mr,sms,mc -o check
///   meshgaze train --dataset ../shared/data/fixations-vr MY_LAB -o mine.json --cv
#[derive(Debug, Args)]
pub struct SaliencyArgs {
    /// The mesh (.obj, .ply, .off, optionally .gz), or a point cloud with normals
    /// (.txt / .xyz / .pts: `x y z nx ny nz` per line) for --method gaze, up or centre.
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
    /// The protocol whose up axis and hold views the `up`, `centre` and `gaze` methods use
    /// (default: the built-in hu2020).
    #[arg(long)]
    pub protocol: Option<PathBuf>,
    /// The axis the mesh files hold as up, as the subjects saw them (default: the protocol's,
    /// +y in the built-in one). The `up`, `centre` and `gaze` methods depend on it: the
    /// built-in gaze model on 15 VR meshes turned from +y-up to +z-up falls from AUC-Judd
    /// 0.87 to 0.57 with the default, and is 0.87 again with `--up z` (docs/gaze_model.md).
    #[arg(long, value_enum)]
    pub up: Option<UpAxis>,
    /// A gaze model from `meshgaze train` for `--method gaze` (default: the built-in one,
    /// trained on ../shared/data/fixations-vr).
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Set a parameter of sri, gr or mr as METHOD.NAME=VALUE (repeatable), e.g.
    /// `--set sri.most_similar=32 --set gr.radii=[0.1,0.2]`; docs/baselines.md lists every
    /// parameter, its default and why.
    #[arg(long = "set", value_name = "METHOD.NAME=VALUE")]
    pub settings: Vec<String>,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

impl SaliencyArgs {
    fn viewing(&self) -> Result<Viewing> {
        let (protocol, _, _) = Protocol::load_or_builtin(self.protocol.as_deref())?;
        let protocol = match self.up {
            Some(axis) => protocol.with_up_axis(axis),
            None => protocol,
        };
        let model = match &self.model {
            Some(path) => {
                if self.method != Method::Gaze {
                    bail!("--model is for --method gaze");
                }
                Some(GazeModel::load(path).map_err(anyhow::Error::msg)?)
            }
            None => None,
        };
        let rarity = RarityParams::default()
            .with_settings(&self.settings)
            .map_err(anyhow::Error::msg)?;
        Ok(Viewing {
            protocol,
            model,
            rarity,
        })
    }
}

/// Parameters of the sparse metric-based method. Defaults follow the paper.
#[derive(Debug, Clone, Args)]
pub struct SmsArgs {
    /// Random surface samples n.
    #[arg(long, default_value_t = 5000)]
    pub samples: usize,
    /// Sample placement: uniform random points by area (the paper, §3.2) or Poisson-disk
    /// (4n uniform candidates thinned to n by weighted sample elimination, Yuksel 2015; the
    /// paper's future work) [not in the paper].
    #[arg(long, value_enum, default_value_t = Sampling::Uniform)]
    pub sampling: Sampling,
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
    /// Rings per shell: adaptive (as many as a shell of that radius can carry detail on the
    /// grid, at most --quadrature-rings; docs/sms.md gives the measured error) or fixed
    /// (--quadrature-rings on every shell) [not in the paper].
    #[arg(long, value_enum, default_value_t = QuadratureRule::Adaptive)]
    pub quadrature: QuadratureRule,
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
            sampling: self.sampling,
            samples: self.samples,
            seed: self.seed,
            descriptor: DescriptorParams {
                scales: self.scales.clone(),
                shells: self.shells,
                bands: self.bands,
                quadrature_rings: self.quadrature_rings,
                quadrature: self.quadrature,
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
        &args.viewing()?,
        args.outputs(),
        &output_prefix(&args.output),
        &bars,
    )?;
    if let Some(object) = &r.training_object {
        eprintln!(
            "warning: {}: this mesh is the gaze model's training object `{object}` (its surface holds the points the model keeps of it): the map is a training-set prediction, not evidence of how the model does on new meshes",
            mesh_path.display()
        );
    }
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
    if is_point_file(&args.mesh) {
        return write_point_cloud_saliency(&args);
    }
    let (mesh, load) = load_mesh(&args.mesh)?;
    let input = InputFile::hash(&args.mesh)
        .with_context(|| format!("cannot read {}", args.mesh.display()))?;
    compute_and_report(&args.mesh, &mesh, &load, input, &args)?;
    Ok(())
}

/// `.txt`, `.xyz` or `.pts` (optionally `.gz`): oriented points, `x y z nx ny nz ...` per line.
fn is_point_file(path: &Path) -> bool {
    let name = path
        .file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    [".txt", ".xyz", ".pts"].iter().any(|e| name.ends_with(e))
}

/// The methods that need no connectivity, on a point cloud with normals: one value per input
/// point, in input order (OUT.csv `point,saliency`, OUT.json with provenance).
fn write_point_cloud_saliency(args: &SaliencyArgs) -> Result<()> {
    let points = read_gaze_points(&args.mesh)
        .map_err(anyhow::Error::msg)?
        .points;
    let viewing = args.viewing()?;
    let t = std::time::Instant::now();
    let values = point_cloud_saliency(&points, args.method, &viewing)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.mesh.display()))?;
    let seconds = t.elapsed().as_secs_f64();
    let prefix = output_prefix(&args.output);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        meshgaze::file_bytes::create_output_dir(dir)?;
    }
    let csv = PathBuf::from(format!("{}.csv", prefix.display()));
    let mut text = String::from("point,saliency\n");
    for (i, v) in values.iter().enumerate() {
        text += &format!("{i},{v}\n");
    }
    std::fs::write(&csv, text).with_context(|| format!("cannot write {}", csv.display()))?;
    let json = PathBuf::from(format!("{}.json", prefix.display()));
    let sidecar = serde_json::json!({
        "provenance": meshgaze::provenance::Provenance::new(vec![InputFile::hash(&args.mesh)?]),
        "method": args.method,
        "input": "point cloud",
        "points": points.len(),
        "protocol": viewing.protocol.name,
        "seconds": seconds,
        "outputs": [csv.display().to_string()],
    });
    std::fs::write(&json, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("cannot write {}", json.display()))?;
    if !args.quiet {
        eprintln!(
            "{}: {} points; {} in {seconds:.2} s\nwrote {}, {}",
            args.mesh.display(),
            points.len(),
            args.method.name(),
            csv.display(),
            json.display()
        );
    }
    Ok(())
}

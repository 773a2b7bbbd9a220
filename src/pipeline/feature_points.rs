//! `meshgaze features`: feature points of a saliency map (the paper's §5.5) and, with human
//! marks, their evaluation (Dutagaci et al. 2012, the paper's Fig. 9), written as OUT.csv,
//! OUT.json and with marks OUT.truth.csv, OUT.eval.csv and OUT.eval.png.
use std::path::{Path, PathBuf};

use plotters::style::RGBColor;
use serde::Serialize;

use super::PipelineError;
use crate::experiments::features::evaluation_files::{
    alpha_sweep, separation_in_mesh_units, write_evaluation_csv, write_feature_points_csv,
    write_truth_points_csv, SeparationUnit,
};
use crate::experiments::features::marks::parse_marks;
use crate::experiments::features::{
    feature_points, voted_ground_truth, Evaluation, GeodesicGraph, TruthPoint,
};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::provenance::{InputFile, Provenance};
use crate::report::plot::{line_chart_png, Chart, Series, PALETTE};

/// The parameters of feature-point detection and of the evaluation against marks.
#[derive(Debug, Clone, Serialize)]
pub struct FeatureParams {
    /// Least geodesic separation of two accepted points, in `unit`.
    pub separation: f64,
    /// What `separation` is measured in.
    pub unit: SeparationUnit,
    /// Steiner points per edge for geodesics (0 = plain edge Dijkstra).
    pub steiner: usize,
    /// Ground-truth neighbourhood radius, fraction of the diameter.
    pub sigma: f64,
    /// Subjects needed near a point for it to be ground truth.
    pub min_subjects: usize,
    /// Largest tolerance α of the evaluation, fraction of the diameter.
    pub alpha_max: f64,
    /// Step of α.
    pub alpha_step: f64,
}

/// What was found and written.
pub struct FeatureRun {
    /// Feature points found.
    pub points: usize,
    /// The separation, in mesh units.
    pub separation_in_mesh_units: f64,
    /// The geodesic diameter (double sweep), mesh units.
    pub diameter: f64,
    /// Ground-truth points from the human marks, when given.
    pub truth_points: Option<usize>,
    /// The evaluation at the largest tolerance: (α, recall, precision, F).
    pub last: Option<(f64, f64, f64, f64)>,
    /// Where the files were written (PREFIX.csv, .json, ...).
    pub prefix: PathBuf,
}

#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    saliency: &'a str,
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
pub fn read_marks(path: &Path, n_vertices: usize) -> Result<Vec<usize>, PipelineError> {
    let text = std::fs::read_to_string(path).map_err(PipelineError::io(path))?;
    parse_marks(&text, &path.display().to_string(), n_vertices)
        .map_err(|e| PipelineError::Stage(e.to_string()))
}

/// Writes a table to `path` with `rows`, the I/O error naming the file.
fn write_table(
    path: &Path,
    rows: impl FnOnce(std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), PipelineError> {
    let file = std::fs::File::create(path).map_err(PipelineError::io(path))?;
    rows(std::io::BufWriter::new(file)).map_err(PipelineError::io(path))
}

/// The recall / precision / F-measure chart over the tolerance α.
fn write_evaluation_chart(
    path: &Path,
    e: &[Evaluation],
    alpha_max: f64,
) -> Result<(), PipelineError> {
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
        path,
        &Chart {
            title: "Feature points against human marks (Dutagaci et al. 2012)",
            x_label: "tolerance α (fraction of the geodesic diameter)",
            y_label: "score",
            x_range: (0.0, alpha_max.max(1e-6)),
            y_range: (0.0, 1.0),
        },
        &[
            series("recall", PALETTE[0], |x| x.recall),
            series("precision", PALETTE[1], |x| x.precision),
            series("F-measure", PALETTE[2], |x| x.f_measure),
        ],
    )
    .map_err(PipelineError::stage)
}

/// Feature points of `values` on `mesh`, evaluated against the `marks` files when there are
/// any; `inputs` are the mesh's (and map's) hashes, to which the marks are added; `source`
/// says where the map came from.
#[allow(clippy::too_many_arguments)]
pub fn run_feature_points(
    mesh: &Mesh,
    values: &[f64],
    source: &str,
    marks: &[PathBuf],
    params: &FeatureParams,
    mut inputs: Vec<InputFile>,
    prefix: &Path,
    progress: &dyn Progress,
) -> Result<FeatureRun, PipelineError> {
    if params.separation.is_nan() || params.separation <= 0.0 {
        return Err(PipelineError::Invalid(
            "--separation must be positive".into(),
        ));
    }
    progress.start("geodesic graph", 0);
    let graph = GeodesicGraph::new(mesh, params.steiner);
    progress.finish();
    progress.start("geodesic diameter (double sweep)", 0);
    let diameter = graph.diameter_double_sweep();
    progress.finish();
    let separation = separation_in_mesh_units(mesh, params.separation, params.unit, diameter);
    let points = feature_points(mesh, values, &graph, separation);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(PipelineError::io(dir))?;
    }
    let path = |ext: &str| PathBuf::from(format!("{}{ext}", prefix.display()));
    write_table(&path(".csv"), |w| {
        write_feature_points_csv(w, mesh, &points)
    })?;
    let mut truth = None;
    let mut evals = None;
    if !marks.is_empty() {
        let mut marked = Vec::new();
        for f in marks {
            marked.push(read_marks(f, mesh.positions.len())?);
            inputs.push(InputFile::hash(f).map_err(PipelineError::io(f))?);
        }
        let t = voted_ground_truth(&graph, &marked, params.sigma, params.min_subjects, diameter);
        let detected: Vec<usize> = points.iter().map(|p| p.vertex).collect();
        let e = alpha_sweep(
            &graph,
            &t,
            &detected,
            params.alpha_max,
            params.alpha_step,
            diameter,
        )
        .map_err(|e| PipelineError::Invalid(e.to_string()))?;
        write_table(&path(".truth.csv"), |w| write_truth_points_csv(w, &t))?;
        write_table(&path(".eval.csv"), |w| write_evaluation_csv(w, &e))?;
        write_evaluation_chart(&path(".eval.png"), &e, params.alpha_max)?;
        truth = Some(t);
        evals = Some(e);
    }
    let sidecar = Sidecar {
        provenance: Provenance::new(inputs),
        saliency: source,
        separation: params.separation,
        unit: params.unit,
        separation_in_mesh_units: separation,
        steiner_points_per_edge: params.steiner,
        geodesic_diameter_double_sweep: diameter,
        feature_points: points.len(),
        sigma: params.sigma,
        min_subjects: params.min_subjects,
        ground_truth: truth.as_deref(),
        evaluation: evals.as_deref(),
    };
    let json = serde_json::to_string_pretty(&sidecar).map_err(PipelineError::stage)? + "\n";
    std::fs::write(path(".json"), json).map_err(PipelineError::io(path(".json")))?;
    Ok(FeatureRun {
        points: points.len(),
        separation_in_mesh_units: separation,
        diameter,
        truth_points: truth.as_ref().map(Vec::len),
        last: evals
            .as_ref()
            .and_then(|e| e.last())
            .map(|x| (x.alpha, x.recall, x.precision, x.f_measure)),
        prefix: prefix.to_path_buf(),
    })
}

//! A saliency map on disk: PREFIX.csv (`vertex,saliency`), PREFIX.ply (the mesh coloured by
//! the map) and PREFIX.json (provenance), as `meshgaze saliency` writes and every later stage
//! reads.
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{
    compute_saliency_viewed, sparse_metric_saliency, Method, SmsExtras, SmsParams, SmsResult,
    Viewing,
};
use crate::mesh::{write_ply_with_quality, LoadReport, Mesh};
use crate::progress::Progress;
use crate::provenance::{InputFile, Provenance};
use crate::scoring::gini_index;
use crate::truth::{load_ground_truth, GroundTruth};

use super::SaliencyError;

type Result<T, E = SaliencyError> = std::result::Result<T, E>;

/// `PREFIX` without a trailing .csv/.ply/.json, so `-o out.csv` means prefix `out`.
pub fn output_prefix(p: &Path) -> PathBuf {
    match p.extension().and_then(|e| e.to_str()) {
        Some("csv" | "ply" | "json") => p.with_extension(""),
        _ => p.to_path_buf(),
    }
}

/// `prefix` with `suffix` appended to its last component (`out` + `.csv` = `out.csv`).
pub fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_os_string();
    s.push(suffix);
    PathBuf::from(s)
}

/// Writes `vertex,saliency`, one row per vertex in input order.
pub fn write_map_csv(path: &Path, values: &[f64]) -> Result<()> {
    let mut out = std::io::BufWriter::new(
        std::fs::File::create(path).map_err(SaliencyError::io("create", path))?,
    );
    let mut rows = || -> std::io::Result<()> {
        writeln!(out, "vertex,saliency")?;
        for (i, v) in values.iter().enumerate() {
            // `{}` prints the shortest text that reads back to the same f64: exact and stable.
            writeln!(out, "{i},{v}")?;
        }
        out.flush()
    };
    rows().map_err(SaliencyError::io("write", path))
}

/// Reads a per-vertex map (`vertex,saliency` CSV, or any per-vertex format the truth reader
/// takes) of a mesh with `n_vertices` vertices.
pub fn read_map(path: &Path, n_vertices: usize) -> Result<Vec<f64>> {
    match load_ground_truth(path, n_vertices, 0.05)
        .map_err(|e| SaliencyError::Map(e.to_string()))?
    {
        GroundTruth::VertexMap(m) => Ok(m.values),
        GroundTruth::Fixations(_) => Err(SaliencyError::Map(format!(
            "{}: expected a per-vertex map (vertex,saliency), found a fixation set",
            path.display()
        ))),
    }
}

/// Which optional SMS outputs to write beside the map.
#[derive(Debug, Clone, Copy, Default)]
pub struct MapOutputs {
    /// PREFIX.samples.csv: sample positions and their sparse saliency.
    pub per_sample: bool,
    /// One map per scale (paper Fig. 3).
    pub per_scale: bool,
    /// The map without sparsity, μ = 1 (paper Fig. 2).
    pub dense: bool,
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

/// What one map computation produced.
pub struct SaliencyRun {
    /// The map's Gini index.
    pub gini: f64,
    /// Seconds the method took.
    pub seconds: f64,
    /// The map, one value per vertex.
    pub values: Vec<f64>,
    /// Every file written.
    pub outputs: Vec<String>,
    /// The SMS result (steps, convergence), for --method sms.
    pub sms: Option<SmsResult>,
    /// For --method gaze: the model's training object this mesh is (by its surface), whose
    /// map is then a training-set prediction.
    pub training_object: Option<String>,
}

/// Computes `method`'s map of `mesh` and writes PREFIX.csv, .ply, .json (and the SMS extras
/// asked for).
#[allow(clippy::too_many_arguments)]
pub fn compute_and_write_map(
    mesh_path: &Path,
    mesh: &Mesh,
    load: &LoadReport,
    input: InputFile,
    method: Method,
    params: &SmsParams,
    viewing: &Viewing,
    extras: MapOutputs,
    prefix: &Path,
    progress: &dyn Progress,
) -> Result<SaliencyRun> {
    let fail =
        |e: &dyn std::fmt::Display| SaliencyError::Compute(format!("{}: {e}", mesh_path.display()));
    let wants_extras = extras.per_sample || extras.per_scale || extras.dense;
    if wants_extras && method != Method::Sms {
        return Err(SaliencyError::Invalid(
            "--per-sample, --per-scale and --dense apply to --method sms only".into(),
        ));
    }
    let (values, report, seconds, sms_result) = if method == Method::Sms {
        let wanted = SmsExtras {
            per_scale: extras.per_scale,
            dense: extras.dense,
        };
        let r = sparse_metric_saliency(mesh, params, wanted, progress).map_err(|e| fail(&e))?;
        let report = serde_json::to_value(&r.report).map_err(|e| fail(&e))?;
        (
            r.vertex_saliency.clone(),
            report,
            r.report.timings.total_s,
            Some(r),
        )
    } else {
        let out = compute_saliency_viewed(method, mesh, params, viewing, progress)
            .map_err(|e| fail(&e))?;
        (out.values, out.report, out.seconds, None)
    };
    let gini = gini_index(&values);
    let training_object = report
        .get("mesh_is_training_object")
        .and_then(|v| v.as_str())
        .map(str::to_string);
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        crate::file_bytes::create_output_dir(dir).map_err(SaliencyError::io("create", dir))?;
    }
    let mut outputs = Vec::new();
    let csv = with_suffix(prefix, ".csv");
    write_map_csv(&csv, &values)?;
    outputs.push(csv.display().to_string());
    let comments = vec![
        format!(
            "meshgaze {} {} saliency of {}",
            env!("CARGO_PKG_VERSION"),
            method.name(),
            mesh_path.display()
        ),
        format!("input sha256 {}", input.sha256),
        "quality = saliency in [0,1]; colour ramp blue (low) to red (high)".to_string(),
    ];
    let ply = with_suffix(prefix, ".ply");
    write_ply_with_quality(&ply, mesh, &values, &comments)
        .map_err(|e| SaliencyError::Compute(format!("cannot write {}: {e}", ply.display())))?;
    outputs.push(ply.display().to_string());
    let mut extra_maps = Vec::new();
    if let Some(result) = &sms_result {
        if extras.per_sample {
            outputs.push(write_samples_csv(prefix, result)?);
        }
        for extra in &result.extras {
            let base = with_suffix(prefix, &format!(".{}", extra.name));
            let c = with_suffix(&base, ".csv");
            write_map_csv(&c, &extra.vertex_saliency)?;
            let p = with_suffix(&base, ".ply");
            write_ply_with_quality(&p, mesh, &extra.vertex_saliency, &comments).map_err(|e| {
                SaliencyError::Compute(format!("cannot write {}: {e}", p.display()))
            })?;
            outputs.push(c.display().to_string());
            outputs.push(p.display().to_string());
            extra_maps.push((extra.name.clone(), extra.gini));
        }
    }
    let json = with_suffix(prefix, ".json");
    outputs.push(json.display().to_string());
    let sidecar = Sidecar {
        provenance: Provenance::new(vec![input]),
        method,
        parameters: (method == Method::Sms).then_some(params),
        mesh: load,
        report,
        gini_index: gini,
        seconds,
        extra_maps,
        outputs: outputs.clone(),
    };
    let text = serde_json::to_string_pretty(&sidecar).map_err(|e| fail(&e))? + "\n";
    std::fs::write(&json, text).map_err(SaliencyError::io("write", &json))?;
    Ok(SaliencyRun {
        gini,
        seconds,
        values,
        outputs,
        sms: sms_result,
        training_object,
    })
}

fn write_samples_csv(prefix: &Path, result: &SmsResult) -> Result<String> {
    let path = with_suffix(prefix, ".samples.csv");
    let mut out = std::io::BufWriter::new(
        std::fs::File::create(&path).map_err(SaliencyError::io("create", &path))?,
    );
    let mut rows = || -> std::io::Result<()> {
        writeln!(out, "sample,x,y,z,saliency")?;
        for (i, (p, s)) in result
            .sample_points
            .iter()
            .zip(&result.sample_saliency)
            .enumerate()
        {
            writeln!(out, "{i},{},{},{},{s}", p.x, p.y, p.z)?;
        }
        out.flush()
    };
    rows().map_err(SaliencyError::io("write", &path))?;
    Ok(path.display().to_string())
}

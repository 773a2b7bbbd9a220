//! The compiled half of the `meshgaze` Python package: each function is a thin call into the
//! meshgaze library, with the GIL released while it computes. The pure-Python half
//! (python/meshgaze/__init__.py) turns the CSV text and rows returned here into pandas
//! DataFrames, so Python and the command line read the same bytes.
mod stages;

use std::path::{Path, PathBuf};

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use glam::DVec3;
use meshgaze::gaze::ingest::{ingest_files, ingest_tables, write_samples_csv, IngestParams};
use meshgaze::gaze::recording::GazeFormat;
use meshgaze::gaze_model::GazeModel;
use meshgaze::progress::Progress;
use meshgaze::protocol::UpAxis;
use meshgaze::saliency::{compute_saliency_viewed, Method, RarityParams, SmsParams, Viewing};
use meshgaze::scoring::surface_blur::BlurKernel;
use meshgaze::scoring::{score_mesh, ScoreParams, Weighting};
use meshgaze::stimulus::hold_views::hold_view_exposure;
use meshgaze::truth::{load_ground_truth_on, vertex_truth_from_values, GroundTruth, TruthLayout};
use meshgaze::Protocol;

pyo3::create_exception!(
    _meshgaze,
    MeshgazeError,
    pyo3::exceptions::PyException,
    "An input meshgaze cannot use; the message is the command line's (file, line, column)."
);

pub(crate) fn fail(e: impl std::fmt::Display) -> PyErr {
    MeshgazeError::new_err(e.to_string())
}

/// A triangle mesh: vertex positions and triangles, in file order.
#[pyclass(module = "meshgaze._meshgaze", frozen)]
pub(crate) struct Mesh {
    pub(crate) inner: meshgaze::Mesh,
    /// The file it was read from (None for a mesh from arrays): the stimulus manifest hashes it.
    pub(crate) path: Option<PathBuf>,
    /// What the reader skipped (degenerate faces, unreferenced vertices), as JSON.
    load_report: Option<String>,
}

#[pymethods]
impl Mesh {
    /// Mesh(vertices, faces): vertices an (n, 3) float64 array, faces an (m, 3) int64 array
    /// of vertex indices (trimesh's `mesh.vertices` and `mesh.faces` as they are).
    #[new]
    fn new(vertices: PyReadonlyArray2<f64>, faces: PyReadonlyArray2<i64>) -> PyResult<Mesh> {
        let v = vertices.as_array();
        let f = faces.as_array();
        if v.ncols() != 3 {
            return Err(PyValueError::new_err(format!(
                "vertices must have shape (n, 3), not {:?}",
                v.shape()
            )));
        }
        if f.ncols() != 3 && f.nrows() > 0 {
            return Err(PyValueError::new_err(format!(
                "faces must have shape (m, 3) (triangles), not {:?}",
                f.shape()
            )));
        }
        let mut positions = Vec::with_capacity(v.nrows());
        for (i, row) in v.rows().into_iter().enumerate() {
            let p = DVec3::new(row[0], row[1], row[2]);
            if !p.is_finite() {
                return Err(PyValueError::new_err(format!(
                    "vertex {i} is not finite: {p:?}"
                )));
            }
            positions.push(p);
        }
        let n = positions.len() as i64;
        let mut triangles = Vec::with_capacity(f.nrows());
        for (t, row) in f.rows().into_iter().enumerate() {
            let mut tri = [0u32; 3];
            for k in 0..3 {
                let i = row[k];
                if i < 0 || i >= n {
                    return Err(PyValueError::new_err(format!(
                        "face {t} refers to vertex {i}, outside 0..{n}"
                    )));
                }
                tri[k] = i as u32;
            }
            triangles.push(tri);
        }
        Ok(Mesh {
            inner: meshgaze::Mesh {
                positions,
                triangles,
            },
            path: None,
            load_report: None,
        })
    }

    /// (n, 3) float64 vertex positions.
    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows_of_three(py, self.inner.positions.iter().map(|p| [p.x, p.y, p.z]))
    }

    /// (m, 3) int64 triangles (vertex indices).
    #[getter]
    fn faces<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<i64>> {
        rows_of_three(py, self.inner.triangles.iter().map(|t| t.map(i64::from)))
    }

    /// The file the mesh was read from, or None for a mesh from arrays.
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    /// What the file reader found and left out (JSON text), or None for a mesh from arrays.
    #[getter]
    fn load_report_json(&self) -> Option<String> {
        self.load_report.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Mesh({} vertices, {} triangles)",
            self.inner.positions.len(),
            self.inner.triangles.len()
        )
    }
}

/// An (n, 3) numpy array of n rows.
fn rows_of_three<'py, T: numpy::Element>(
    py: Python<'py>,
    rows: impl ExactSizeIterator<Item = [T; 3]>,
) -> Bound<'py, PyArray2<T>> {
    let n = rows.len();
    let flat: Vec<T> = rows.flatten().collect();
    flat.into_pyarray(py)
        .reshape([n, 3])
        .expect("n*3 values reshape to (n, 3)")
}

/// read_mesh(path) -> Mesh: OBJ, PLY (ASCII or binary) or OFF, optionally gzipped.
#[pyfunction]
fn read_mesh(py: Python<'_>, path: PathBuf) -> PyResult<Mesh> {
    let (mesh, report) = py.detach(|| meshgaze::load_mesh(&path)).map_err(fail)?;
    Ok(Mesh {
        inner: mesh,
        path: Some(path),
        load_report: serde_json::to_string(&report).ok(),
    })
}

/// Progress as plain lines on stderr, only when asked for.
struct StderrProgress;

impl Progress for StderrProgress {
    fn start(&self, step: &str, total: u64) {
        if total > 0 {
            eprintln!("meshgaze: {step} ({total} steps)");
        } else {
            eprintln!("meshgaze: {step}");
        }
    }
    fn advance(&self, _: u64) {}
    fn finish(&self) {}
}

pub(crate) fn progress_of(show: bool) -> &'static dyn Progress {
    if show {
        &StderrProgress
    } else {
        &meshgaze::Silent
    }
}

/// The viewing (protocol, model, method settings) `meshgaze saliency` builds from its flags.
fn viewing(
    protocol: Option<&Path>,
    up: Option<UpAxis>,
    model: Option<&Path>,
    settings: &[String],
) -> Result<Viewing, String> {
    let (protocol, _, _) = Protocol::load_or_builtin(protocol).map_err(|e| e.to_string())?;
    let protocol = match up {
        Some(axis) => protocol.with_up_axis(axis),
        None => protocol,
    };
    let model = model
        .map(GazeModel::load)
        .transpose()
        .map_err(|e| e.to_string())?;
    let rarity = RarityParams::default()
        .with_settings(settings)
        .map_err(|e| e.to_string())?;
    Ok(Viewing {
        protocol,
        model,
        rarity,
    })
}

/// The SMS parameters `meshgaze saliency` takes as flags, from keyword arguments; every other
/// keyword is an error naming the accepted ones.
fn sms_params(seed: u64, params: Option<&Bound<'_, PyDict>>) -> PyResult<SmsParams> {
    let mut p = SmsParams {
        seed,
        ..SmsParams::default()
    };
    let Some(params) = params else {
        return Ok(p);
    };
    for (key, value) in params.iter() {
        let key: String = key.extract()?;
        match key.as_str() {
            "samples" => p.samples = value.extract()?,
            "mu" => p.mu = value.extract()?,
            "sigma" => p.sigma = value.extract()?,
            "scales" => p.descriptor.scales = value.extract()?,
            "shells" => p.descriptor.shells = value.extract()?,
            "bands" => p.descriptor.bands = value.extract()?,
            "quadrature_rings" => p.descriptor.quadrature_rings = value.extract()?,
            "grid" => p.grid.resolution = value.extract()?,
            "gedt_sigma_voxels" => p.grid.sigma_voxels = value.extract()?,
            "max_iterations" => p.power.max_iterations = value.extract()?,
            "tolerance" => p.power.tolerance = value.extract()?,
            other => {
                return Err(PyTypeError::new_err(format!(
                    "saliency() got an unexpected keyword `{other}`: SMS takes samples, mu, sigma, scales, shells, bands, quadrature_rings, grid, gedt_sigma_voxels, max_iterations, tolerance; sri, gr and mr take settings=[\"sri.most_similar=32\", ...]"
                )))
            }
        }
    }
    Ok(p)
}

/// saliency(mesh, method, seed, settings, protocol, up, model, progress, **params) -> (n,) array.
#[pyfunction]
#[pyo3(signature = (mesh, method="sms", seed=1, settings=Vec::new(), protocol=None, up=None, model=None, progress=false, **params))]
#[allow(clippy::too_many_arguments)]
fn saliency<'py>(
    py: Python<'py>,
    mesh: &Mesh,
    method: &str,
    seed: u64,
    settings: Vec<String>,
    protocol: Option<PathBuf>,
    up: Option<String>,
    model: Option<PathBuf>,
    progress: bool,
    params: Option<&Bound<'py, PyDict>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let method = Method::from_name(method).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let up: Option<UpAxis> = up
        .map(|u| parse_name("up (x, y, z, neg-x, neg-y, neg-z)", &u))
        .transpose()?;
    if model.is_some() && method != Method::Gaze {
        return Err(PyValueError::new_err("model= is for method=\"gaze\""));
    }
    if method != Method::Sms {
        if let Some(key) = params.and_then(|p| p.keys().iter().next()) {
            return Err(PyTypeError::new_err(format!(
                "saliency() keyword `{key}` is an SMS parameter; method \"{}\" does not take it",
                method.name()
            )));
        }
    }
    let sms = sms_params(seed, params)?;
    let mesh = &mesh.inner;
    let values = py
        .detach(|| {
            let viewing = viewing(protocol.as_deref(), up, model.as_deref(), &settings)?;
            compute_saliency_viewed(method, mesh, &sms, &viewing, progress_of(progress))
                .map_err(|e| e.to_string())
        })
        .map_err(fail)?
        .values;
    Ok(values.into_pyarray(py))
}

pub(crate) fn parse_name<T: serde::de::DeserializeOwned>(what: &str, name: &str) -> PyResult<T> {
    serde_json::from_value(serde_json::Value::String(name.to_string()))
        .map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

/// read_gaze(paths, ...) -> dict of CSV texts (fixations, messages, quality, samples) and
/// per-file notes; meshgaze.read_gaze makes DataFrames of them.
#[pyfunction]
#[pyo3(signature = (paths, protocol=None, format=None, detector=None, eye="best", validity="auto", subject=None, screen=None, stimulus_pattern=None, stimulus_end_pattern=None, max_dispersion_px=None, min_duration_ms=None, max_velocity_deg_s=None, samples=false))]
#[allow(clippy::too_many_arguments)]
fn read_gaze<'py>(
    py: Python<'py>,
    paths: Vec<PathBuf>,
    protocol: Option<PathBuf>,
    format: Option<&str>,
    detector: Option<&str>,
    eye: &str,
    validity: &str,
    subject: Option<String>,
    screen: Option<(f64, f64)>,
    stimulus_pattern: Option<String>,
    stimulus_end_pattern: Option<String>,
    max_dispersion_px: Option<f64>,
    min_duration_ms: Option<f64>,
    max_velocity_deg_s: Option<f64>,
    samples: bool,
) -> PyResult<Bound<'py, PyDict>> {
    if stimulus_end_pattern.is_some() && stimulus_pattern.is_none() {
        return Err(PyValueError::new_err(
            "stimulus_end_pattern needs stimulus_pattern",
        ));
    }
    let (protocol, _, _) = Protocol::load_or_builtin(protocol.as_deref()).map_err(fail)?;
    let pattern = stimulus_pattern
        .as_deref()
        .map(|p| (p, stimulus_end_pattern.as_deref()));
    let mut params = IngestParams::from_protocol(&protocol, pattern).map_err(fail)?;
    params.format = format
        .map(GazeFormat::from_short_name)
        .transpose()
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    params.detector = detector.map(|d| parse_name("detector", d)).transpose()?;
    params.eye = parse_name("eye", eye)?;
    params.validity = parse_name("validity", validity)?;
    params.subject = subject;
    if let Some((w, h)) = screen {
        params.screen_px = Some([w, h]);
    }
    let d = &mut params.detector_params;
    if let Some(v) = max_dispersion_px {
        d.max_dispersion_px = v;
    }
    if let Some(v) = min_duration_ms {
        d.min_duration_ms = v;
    }
    if let Some(v) = max_velocity_deg_s {
        d.max_velocity_px_s = v * protocol.display.pixels_per_degree();
    }
    let (tables, sample_text, notes) = py
        .detach(|| {
            let (files, _) = ingest_files(&paths, &params).map_err(|e| e.to_string())?;
            let tables = ingest_tables(&files).map_err(|e| e.to_string())?;
            let sample_text = if samples {
                let mut out = Vec::new();
                write_samples_csv(&mut out, &files).map_err(|e| e.to_string())?;
                Some(String::from_utf8(out).map_err(|e| e.to_string())?)
            } else {
                None
            };
            let notes: Vec<(String, String, usize, Vec<String>)> = files
                .iter()
                .map(|f| {
                    let mut notes = f.recording.notes.clone();
                    notes.extend(f.warnings.iter().cloned());
                    (
                        f.path.display().to_string(),
                        f.subject.clone(),
                        f.fixations.len(),
                        notes,
                    )
                })
                .collect();
            Ok::<_, String>((tables, sample_text, notes))
        })
        .map_err(fail)?;
    let out = PyDict::new(py);
    out.set_item("fixations", tables.fixations)?;
    out.set_item("messages", tables.messages)?;
    out.set_item("quality", tables.quality)?;
    out.set_item("samples", sample_text)?;
    out.set_item("files", notes)?;
    Ok(out)
}

/// score(mesh, maps, truth_values | truth_path, ...) -> (rows, summaries JSON): rows are
/// (method, metric, blur, value) as `meshgaze score` writes them.
#[pyfunction]
#[pyo3(signature = (mesh, maps, truth_values=None, truth_path=None, truth=None, blur=None, seed=1, kernel="euclidean", weighting="vertex", top_fraction=0.05, borji_splits=100, protocol=None, truth_layout="auto", progress=false))]
#[allow(clippy::too_many_arguments)]
#[allow(clippy::type_complexity)]
fn score(
    py: Python<'_>,
    mesh: &Mesh,
    maps: Vec<(String, PyReadonlyArray1<f64>)>,
    truth_values: Option<PyReadonlyArray1<f64>>,
    truth_path: Option<PathBuf>,
    truth: Option<PyRef<'_, stages::Truth>>,
    blur: Option<Vec<f64>>,
    seed: u64,
    kernel: &str,
    weighting: &str,
    top_fraction: f64,
    borji_splits: usize,
    protocol: Option<PathBuf>,
    truth_layout: &str,
    progress: bool,
) -> PyResult<(Vec<(String, String, f64, f64)>, String)> {
    let layout = parse_name::<TruthLayout>("truth_layout", truth_layout)?;
    let n = mesh.inner.positions.len();
    let mut named = Vec::with_capacity(maps.len());
    for (name, values) in maps {
        let values = values.as_array().to_vec();
        if values.len() != n {
            return Err(PyValueError::new_err(format!(
                "map `{name}` has {} values; the mesh has {n} vertices",
                values.len()
            )));
        }
        named.push((name, values));
    }
    let truth = match (truth_values, truth_path, truth) {
        (None, None, Some(t)) => {
            let truth_n = t.vertex_count();
            if truth_n != n {
                return Err(PyValueError::new_err(format!(
                    "the truth was built on a mesh of {truth_n} vertices; this one has {n}"
                )));
            }
            t.truth.clone()
        }
        (Some(v), None, None) => {
            let v = v.as_array().to_vec();
            if v.len() != n {
                return Err(PyValueError::new_err(format!(
                    "truth has {} values; the mesh has {n} vertices",
                    v.len()
                )));
            }
            GroundTruth::VertexMap(vertex_truth_from_values(v, top_fraction).map_err(fail)?)
        }
        (None, Some(p), None) => {
            load_ground_truth_on(&p, &mesh.inner, top_fraction, layout).map_err(fail)?
        }
        _ => {
            return Err(PyValueError::new_err(
                "give the truth once: as values (one per vertex), as a file or as a Truth",
            ))
        }
    };
    let defaults = ScoreParams::default();
    let params = ScoreParams {
        blur_sigmas: blur.unwrap_or(defaults.blur_sigmas.clone()),
        kernel: parse_name::<BlurKernel>("kernel", kernel)?,
        weighting: parse_name::<Weighting>("weighting", weighting)?,
        seed,
        borji_splits,
        ..defaults
    };
    if let Some(s) = params
        .blur_sigmas
        .iter()
        .find(|s| !(s.is_finite() && **s >= 0.0))
    {
        return Err(PyValueError::new_err(format!(
            "blur scales must be finite and ≥ 0, not {s}"
        )));
    }
    let mesh = &mesh.inner;
    // `auc_judd_visible` counts only the vertices the protocol's hold views ever show, as
    // `meshgaze score` does with its --protocol (the built-in one when unset).
    let (protocol, _, _) = Protocol::load_or_builtin(protocol.as_deref()).map_err(fail)?;
    let result = py
        .detach(|| {
            let seen = hold_view_exposure(mesh, &protocol)
                .map_err(|e| e.to_string())?
                .seen();
            score_mesh(
                mesh,
                &truth,
                &named,
                &params,
                Some(&seen),
                progress_of(progress),
            )
            .map_err(|e| e.to_string())
        })
        .map_err(fail)?;
    let rows = result
        .rows
        .iter()
        .map(|r| (r.method.clone(), r.metric.to_string(), r.blur, r.value))
        .collect();
    let summary = serde_json::json!({
        "summaries": result.summaries,
        "human_splits": result.human_splits,
        "positives": result.positives,
        "fixations": result.fixations,
        "truth": truth,
    });
    Ok((rows, summary.to_string()))
}

/// The meshgaze library's version, as in every output's provenance.
#[pyfunction]
fn version() -> &'static str {
    meshgaze::provenance::Provenance::new(Vec::new()).version
}

#[pymodule]
fn _meshgaze(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("MeshgazeError", m.py().get_type::<MeshgazeError>())?;
    m.add_class::<Mesh>()?;
    m.add_function(wrap_pyfunction!(read_mesh, m)?)?;
    m.add_function(wrap_pyfunction!(saliency, m)?)?;
    m.add_function(wrap_pyfunction!(read_gaze, m)?)?;
    m.add_function(wrap_pyfunction!(score, m)?)?;
    m.add_function(wrap_pyfunction!(version, m)?)?;
    m.add_class::<stages::Truth>()?;
    m.add_class::<stages::Study>()?;
    m.add_function(wrap_pyfunction!(stages::render_stimulus, m)?)?;
    m.add_function(wrap_pyfunction!(stages::project, m)?)?;
    m.add_function(wrap_pyfunction!(stages::build_truth, m)?)?;
    m.add_function(wrap_pyfunction!(stages::view_html, m)?)?;
    Ok(())
}

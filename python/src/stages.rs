//! The file-based pipeline stages: stimulus rendering, projection, ground truth and whole
//! studies. Each writes the same files as its command (`meshgaze stimulus`, `project`,
//! `truth`, `study run`) by calling the same library function, and hands Python the tables it
//! wrote as CSV text, so a DataFrame here and a CSV there hold the same bytes.
use std::path::PathBuf;

use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

use meshgaze::mesh::write_obj;
use meshgaze::projection::project_file::{project_files, write_projection, ProjectOptions};
use meshgaze::projection::table::write_projected_csv;
use meshgaze::protocol::DuringMove;
use meshgaze::scoring::surface_blur::BlurKernel;
use meshgaze::stimulus::load::load_stimulus;
use meshgaze::stimulus::{render_stimulus as render, FrameImages, StimulusOptions};
use meshgaze::study::{merge_study, run_study, RunOptions, Study as StudyConfig};
use meshgaze::truth::{build_truth as build, projected_file, read_projections, write_truth};
use meshgaze::truth::{GroundTruth, TruthParams};
use meshgaze::Protocol;

use crate::{fail, parse_name, progress_of, Mesh};

fn frames_of(name: &str) -> PyResult<FrameImages> {
    match name {
        "none" => Ok(FrameImages::None),
        "keyframes" => Ok(FrameImages::Keyframes),
        "all" => Ok(FrameImages::All),
        other => Err(PyValueError::new_err(format!(
            "frames must be none, keyframes or all, not `{other}`"
        ))),
    }
}

/// render_stimulus(mesh, out_dir, protocol=None, frames="none", id_buffer=False,
/// verify=False, progress=False) -> manifest JSON text. Writes OUT/stimulus.mp4,
/// timeline.csv and manifest.json as `meshgaze stimulus` does. A mesh made from arrays is
/// first written to OUT/mesh.obj (exact coordinates), the file the manifest then hashes.
#[pyfunction]
#[pyo3(signature = (mesh, out_dir, protocol=None, frames="none", id_buffer=false, verify=false, progress=false))]
#[allow(clippy::too_many_arguments)]
pub fn render_stimulus(
    py: Python<'_>,
    mesh: &Mesh,
    out_dir: PathBuf,
    protocol: Option<PathBuf>,
    frames: &str,
    id_buffer: bool,
    verify: bool,
    progress: bool,
) -> PyResult<String> {
    let options = StimulusOptions {
        frames: frames_of(frames)?,
        id_buffer,
        verify,
    };
    let (protocol, text, name) = Protocol::load_or_builtin(protocol.as_deref()).map_err(fail)?;
    let manifest = py
        .detach(|| {
            let mesh_file = match &mesh.path {
                Some(p) => p.clone(),
                None => {
                    std::fs::create_dir_all(&out_dir)
                        .map_err(|e| format!("{}: {e}", out_dir.display()))?;
                    let p = out_dir.join("mesh.obj");
                    let note = format!(
                        "meshgaze {} (Python): mesh from arrays",
                        meshgaze::provenance::Provenance::new(Vec::new()).version
                    );
                    write_obj(&p, &mesh.inner, &[note])
                        .map_err(|e| format!("cannot write {}: {e}", p.display()))?;
                    p
                }
            };
            render(
                &mesh_file,
                &mesh.inner,
                &protocol,
                &text,
                &name,
                &out_dir,
                &options,
                progress_of(progress),
            )
            .map_err(|e| e.to_string())
        })
        .map_err(fail)?;
    serde_json::to_string(&manifest).map_err(fail)
}

fn during_move_of(name: Option<&str>) -> PyResult<Option<DuringMove>> {
    name.map(|n| parse_name::<DuringMove>("during_move", n))
        .transpose()
}

/// project(stimulus, fixations, out_dir=None, ...) -> (projected CSV text, project.json
/// text): the fixations of `meshgaze ingest`'s fixations.csv files projected onto the
/// stimulus's mesh, as `meshgaze project` does; with out_dir, also its files.
#[pyfunction]
#[pyo3(signature = (stimulus, fixations, out_dir=None, stimulus_name=None, onset_us=None, screen=None, during_move=None, snap=false, snap_deg=None, cone_deg=None, mesh=None, targets=None, self_check=true, progress=false))]
#[allow(clippy::too_many_arguments)]
pub fn project(
    py: Python<'_>,
    stimulus: PathBuf,
    fixations: Vec<PathBuf>,
    out_dir: Option<PathBuf>,
    stimulus_name: Option<String>,
    onset_us: Option<i64>,
    screen: Option<(f64, f64)>,
    during_move: Option<&str>,
    snap: bool,
    snap_deg: Option<f64>,
    cone_deg: Option<f64>,
    mesh: Option<PathBuf>,
    targets: Option<PathBuf>,
    self_check: bool,
    progress: bool,
) -> PyResult<(String, String)> {
    if fixations.is_empty() {
        return Err(PyValueError::new_err("give at least one fixations.csv"));
    }
    let during_move = during_move_of(during_move)?;
    py.detach(|| {
        let stim = load_stimulus(&stimulus, mesh.as_deref()).map_err(|e| e.to_string())?;
        let options = ProjectOptions {
            stimulus_name,
            onset_us,
            screen,
            during_move,
            snap_deg: snap_deg.or(snap.then_some(stim.protocol.fixations.tracker_accuracy_deg)),
            cone_deg,
            targets,
            self_check,
        };
        let run = project_files(&stim, &fixations, &options, progress_of(progress))
            .map_err(|e| format!("{e:#}"))?;
        if let Some(out) = &out_dir {
            write_projection(out, &run).map_err(|e| format!("{e:#}"))?;
        }
        let mut csv = Vec::new();
        write_projected_csv(&mut csv, &run.rows).map_err(|e| e.to_string())?;
        let csv = String::from_utf8(csv).map_err(|e| e.to_string())?;
        let sidecar = serde_json::to_string(&run.sidecar).map_err(|e| e.to_string())?;
        Ok::<_, String>((csv, sidecar))
    })
    .map_err(fail)
}

/// A mesh's ground truth, as `build_truth` computed it: pass it to `score` as the truth.
#[pyclass(module = "meshgaze._meshgaze", frozen)]
pub struct Truth {
    pub(crate) truth: GroundTruth,
    fixations_csv: String,
    counts: Vec<f64>,
    density: Vec<f64>,
    cone: Option<Vec<f64>>,
    human: Vec<(f64, String, f64)>,
    summary_json: String,
}

impl Truth {
    /// The vertices of the mesh it was built on.
    pub(crate) fn vertex_count(&self) -> usize {
        self.counts.len()
    }
}

#[pymethods]
impl Truth {
    /// truth.csv's text: every fixation with its fate, vertex and surface point.
    #[getter]
    fn fixations_csv(&self) -> &str {
        &self.fixations_csv
    }
    /// Fixations per vertex.
    #[getter]
    fn counts<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.counts.clone().into_pyarray(py)
    }
    /// The blurred fixation density per vertex (density.csv's `density`).
    #[getter]
    fn density<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.density.clone().into_pyarray(py)
    }
    /// The cone density, when the projections used cone_deg.
    #[getter]
    fn cone<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.cone.clone().map(|c| c.into_pyarray(py))
    }
    /// (blur, metric, value) rows of the split-half human ceiling (human.csv).
    #[getter]
    fn human(&self) -> Vec<(f64, String, f64)> {
        self.human.clone()
    }
    /// truth.json's text: provenance, fates per subject, the human ceiling's summary.
    #[getter]
    fn summary_json(&self) -> &str {
        &self.summary_json
    }
}

/// build_truth(stimulus, projected, out_dir=None, blur=0.02, blur_max=0.2, blur_step=0.01,
/// kernel="euclidean", mesh=None, progress=False) -> Truth, as `meshgaze truth` builds it
/// from projected.csv files (or folders holding one); with out_dir, also its files.
#[pyfunction]
#[pyo3(signature = (stimulus, projected, out_dir=None, blur=0.02, blur_max=0.2, blur_step=0.01, kernel="euclidean", mesh=None, progress=false))]
#[allow(clippy::too_many_arguments)]
pub fn build_truth(
    py: Python<'_>,
    stimulus: PathBuf,
    projected: Vec<PathBuf>,
    out_dir: Option<PathBuf>,
    blur: f64,
    blur_max: f64,
    blur_step: f64,
    kernel: &str,
    mesh: Option<PathBuf>,
    progress: bool,
) -> PyResult<Truth> {
    if projected.is_empty() {
        return Err(PyValueError::new_err("give at least one projected.csv"));
    }
    for (name, v) in [("blur", blur), ("blur_max", blur_max)] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(PyValueError::new_err(format!(
                "{name} must be finite and ≥ 0, not {v}"
            )));
        }
    }
    if !(blur_step.is_finite() && blur_step > 0.0) {
        return Err(PyValueError::new_err(format!(
            "blur_step must be finite and > 0, not {blur_step}"
        )));
    }
    let params = TruthParams {
        blur,
        blur_max,
        blur_step,
        kernel: parse_name::<BlurKernel>("kernel", kernel)?,
    };
    py.detach(|| {
        let stim = load_stimulus(&stimulus, mesh.as_deref()).map_err(|e| e.to_string())?;
        let files: Vec<PathBuf> = projected.iter().map(|p| projected_file(p)).collect();
        let projections = read_projections(&stim, &files).map_err(|e| format!("{e:#}"))?;
        let r = build(&stim, projections, &params, progress_of(progress))
            .map_err(|e| format!("{e:#}"))?;
        if let Some(out) = &out_dir {
            write_truth(out, &stim, &r).map_err(|e| format!("{e:#}"))?;
        }
        let mut csv = Vec::new();
        write_projected_csv(&mut csv, &r.rows).map_err(|e| e.to_string())?;
        Ok::<_, String>(Truth {
            fixations_csv: String::from_utf8(csv).map_err(|e| e.to_string())?,
            summary_json: serde_json::to_string(&r.sidecar).map_err(|e| e.to_string())?,
            human: r
                .human
                .iter()
                .map(|(b, m, v)| (*b, m.to_string(), *v))
                .collect(),
            truth: r.truth,
            counts: r.counts,
            density: r.density,
            cone: r.cone,
        })
    })
    .map_err(fail)
}

/// A study file (study.toml): the meshes, recordings and methods it names.
#[pyclass(module = "meshgaze._meshgaze", frozen)]
pub struct Study {
    file: PathBuf,
    /// As read at construction, for the properties; `run` and `merge` read the file again,
    /// because its globs match recordings made since (as each `meshgaze study run` does).
    config: StudyConfig,
}

fn load_study(py: Python<'_>, file: &std::path::Path) -> PyResult<StudyConfig> {
    py.detach(|| StudyConfig::load(file))
        .map_err(|e| fail(format!("{e:#}")))
}

#[pymethods]
impl Study {
    /// Study(path): reads and checks study.toml (or the folder holding it), as `study run` does.
    #[new]
    fn new(py: Python<'_>, path: PathBuf) -> PyResult<Study> {
        let file = if path.is_dir() {
            path.join("study.toml")
        } else {
            path
        };
        let config = load_study(py, &file)?;
        Ok(Study { file, config })
    }

    /// The study's output folder.
    #[getter]
    fn output(&self) -> PathBuf {
        self.config.output.clone()
    }
    /// The meshes' names, sorted.
    #[getter]
    fn meshes(&self) -> Vec<String> {
        self.config.meshes.iter().map(|m| m.name.clone()).collect()
    }
    /// The recordings, sorted.
    #[getter]
    fn recordings(&self) -> Vec<PathBuf> {
        self.config.recordings.clone()
    }
    /// The saliency methods it scores.
    #[getter]
    fn methods(&self) -> Vec<&'static str> {
        self.config.methods.iter().map(|m| m.name()).collect()
    }

    /// run(jobs=1, shard=None, progress=False) -> the run's account as JSON text (study.json),
    /// with study.toml read again first:
    /// renders, ingests, projects, builds truth, computes and scores every step not up to
    /// date, exactly as `meshgaze study run`. shard=(i, n) runs the i-th of n shares.
    #[pyo3(signature = (jobs=1, shard=None, progress=false))]
    fn run(
        &self,
        py: Python<'_>,
        jobs: usize,
        shard: Option<(usize, usize)>,
        progress: bool,
    ) -> PyResult<String> {
        if jobs == 0 {
            return Err(PyValueError::new_err("jobs must be at least 1"));
        }
        if let Some((i, n)) = shard {
            if n == 0 || i == 0 || i > n {
                return Err(PyValueError::new_err(format!(
                    "shard must be (i, n) with 1 ≤ i ≤ n, not ({i}, {n})"
                )));
            }
        }
        let options = RunOptions { shard, jobs };
        let config = load_study(py, &self.file)?;
        let run = py
            .detach(|| run_study(&config, &options, progress_of(progress)))
            .map_err(|e| fail(format!("{e:#}")))?;
        serde_json::to_string(&run).map_err(fail)
    }

    /// merge() -> (meshes merged, report path): joins sharded runs' scores into scores.csv
    /// and writes the study report, as `meshgaze study merge`.
    fn merge(&self, py: Python<'_>) -> PyResult<(usize, PathBuf)> {
        let config = load_study(py, &self.file)?;
        py.detach(|| merge_study(&config))
            .map_err(|e| fail(format!("{e:#}")))
    }

    fn __repr__(&self) -> String {
        format!(
            "Study({}: {} meshes, {} recordings)",
            self.config.file.display(),
            self.config.meshes.len(),
            self.config.recordings.len()
        )
    }
}

/// view_html(mesh, maps, density=None, blur=nan, fixations_csv=[], stimulus=None,
/// max_triangles=500000) -> the `meshgaze view` page: maps as (name, values), the truth
/// density per vertex, fixations as projected.csv texts, the stimulus folder for its cameras.
#[pyfunction]
#[pyo3(signature = (mesh, maps, density=None, blur=f64::NAN, fixations_csv=Vec::new(), stimulus=None, max_triangles=500_000, title=None))]
#[allow(clippy::too_many_arguments)]
pub fn view_html(
    py: Python<'_>,
    mesh: &Mesh,
    maps: Vec<(String, numpy::PyReadonlyArray1<f64>)>,
    density: Option<numpy::PyReadonlyArray1<f64>>,
    blur: f64,
    fixations_csv: Vec<String>,
    stimulus: Option<PathBuf>,
    max_triangles: usize,
    title: Option<String>,
) -> PyResult<String> {
    let maps: Vec<(String, Vec<f64>)> = maps
        .into_iter()
        .map(|(n, v)| (n, v.as_array().to_vec()))
        .collect();
    let density = density.map(|d| d.as_array().to_vec());
    let title = title.unwrap_or_else(|| {
        mesh.path
            .as_ref()
            .and_then(|p| p.file_name())
            .map(|n| {
                n.to_string_lossy()
                    .split('.')
                    .next()
                    .unwrap_or("")
                    .to_string()
            })
            .unwrap_or_else(|| "mesh".to_string())
    });
    py.detach(|| {
        let mut fixations = Vec::new();
        for (i, text) in fixations_csv.iter().enumerate() {
            fixations.extend(
                meshgaze::projection::table::parse_projected_csv(
                    text.as_bytes(),
                    &format!("fixation table {}", i + 1),
                )
                .map_err(|e| e.to_string())?,
            );
        }
        let stim = stimulus
            .as_ref()
            .map(|s| load_stimulus(s, None).map_err(|e| e.to_string()))
            .transpose()?;
        if let Some(s) = &stim {
            if s.mesh.positions != mesh.inner.positions || s.mesh.triangles != mesh.inner.triangles
            {
                return Err(format!(
                    "the stimulus {} was rendered from another mesh ({} vertices) than this one ({})",
                    s.manifest_path.display(),
                    s.mesh.positions.len(),
                    mesh.inner.positions.len()
                ));
            }
        }
        let input = meshgaze::report::viewer::ViewerInput {
            title,
            mesh: &mesh.inner,
            maps,
            truth_density: density.map(|d| (d, blur)),
            fixations,
            stimulus: stim.as_ref().map(|s| (&s.plan, s.fps)),
        };
        meshgaze::report::viewer::viewer_page(
            &input,
            &meshgaze::report::viewer::ViewerLimits {
                max_triangles: max_triangles.max(1000),
            },
        )
        .map_err(|e| e.to_string())
    })
    .map_err(fail)
}

//! SMS and its competitors timed at the paper's settings, each case beside the paper's Table 3
//! row nearest in size.
use std::ffi::OsStr;
use std::path::Path;
use std::process::Command;

use serde::{Deserialize, Serialize};

use super::{peak_rss_mb, TimingError};
use crate::mesh::{load_mesh, subdivide_midpoint, Mesh};
use crate::progress::Silent;
use crate::saliency::{
    compute_saliency, sparse_metric_saliency, Method, SmsExtras, SmsParams, PAPER_METHODS,
};

/// A bench case and the row of the paper's Table 3 it is compared with.
#[derive(Debug, Clone, Copy)]
pub struct PaperCase {
    /// The case's name (`--case`).
    pub name: &'static str,
    /// The paper's mesh nearest in vertex count.
    pub paper_row: &'static str,
    /// The paper's SMS seconds on that mesh.
    pub paper_sms_s: f64,
    /// The paper's seconds for each method of [`COMPETITORS`], in that order.
    pub paper_competitors_s: [f64; 6],
}

/// The cases: the 35,947-vertex Stanford bunny, the 48k Cyberware horse, the 134k igea, and
/// the 50k armadillo subdivided twice (about 800k vertices).
pub const PAPER_CASES: [PaperCase; 4] = [
    PaperCase {
        name: "bunny-35k",
        paper_row: "Bunny 35k",
        paper_sms_s: 43.5,
        paper_competitors_s: [0.5, 12.2, 13.7, 56.9, 35.8, 43.4],
    },
    PaperCase {
        name: "horse-48k",
        paper_row: "Dinosaur 56k",
        paper_sms_s: 45.2,
        paper_competitors_s: [1.8, 28.2, 23.6, 100.2, 67.3, 86.3],
    },
    PaperCase {
        name: "igea-134k",
        paper_row: "Armadillo 172k",
        paper_sms_s: 44.3,
        paper_competitors_s: [2.3, 56.1, 36.5, 245.8, 221.3, 276.2],
    },
    PaperCase {
        name: "armadillo-subdivided",
        paper_row: "Lucy 604k",
        paper_sms_s: 48.9,
        paper_competitors_s: [7.3, 448.0, 67.4, 1178.2, 912.5, 1264.0],
    },
];

/// The competitors of the paper's Table 3, in its column order after SMS.
pub const COMPETITORS: &[Method] = PAPER_METHODS.split_at(1).1;

/// The case called `name`.
pub fn paper_case(name: &str) -> Result<&'static PaperCase, TimingError> {
    PAPER_CASES
        .iter()
        .find(|c| c.name == name)
        .ok_or_else(|| TimingError::UnknownCase(name.to_string()))
}

/// One case's timings: SMS's steps (NaN where SMS did not run) and each other method's total.
#[derive(Debug, Serialize, Deserialize)]
pub struct CaseResult {
    /// The case's name.
    pub name: String,
    /// Its vertex count.
    pub vertices: usize,
    /// SMS step A (descriptors and the metric), seconds.
    #[serde(deserialize_with = "nan_if_null")]
    pub a_s: f64,
    /// Of step A, the harmonic field solves, seconds.
    #[serde(deserialize_with = "nan_if_null")]
    pub field_s: f64,
    /// SMS step B (the sparse eigenvector), seconds.
    #[serde(deserialize_with = "nan_if_null")]
    pub b_s: f64,
    /// SMS step C (interpolation to vertices), seconds.
    #[serde(deserialize_with = "nan_if_null")]
    pub c_s: f64,
    /// SMS in all, seconds (the fastest of the repeats).
    #[serde(deserialize_with = "nan_if_null")]
    pub total_s: f64,
    /// Loading the mesh (not counted in any total), seconds.
    pub load_s: f64,
    /// The process's peak resident memory after SMS (or after the one method asked for), MB.
    pub peak_rss_mb: f64,
    /// The paper's SMS seconds on the compared row.
    #[serde(deserialize_with = "nan_if_null")]
    pub paper_total_s: f64,
    /// The paper's Table 3 row this case is compared with.
    pub paper_row: String,
    /// Other methods' totals: (name, seconds, paper seconds, peak RSS MB of their process).
    pub baselines: Vec<(String, f64, f64, f64)>,
}

/// JSON writes NaN (a column the case did not measure) as null; read it back as NaN.
fn nan_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The mesh of case `name`, from the shared data folder `data`.
pub fn load_case(name: &str, data: &Path) -> Result<Mesh, TimingError> {
    let load = |relative: &str| {
        let path = data.join(relative);
        load_mesh(&path)
            .map(|(mesh, _)| mesh)
            .map_err(|e| TimingError::Input {
                path,
                message: e.to_string(),
            })
    };
    Ok(match paper_case(name)?.name {
        "bunny-35k" => load("meshes/classic/stanford_bunny/bun_zipper.ply")?,
        "horse-48k" => load("meshes/classic/cyberware/horse.ply")?,
        "igea-134k" => load("meshes/classic/cyberware/igea.ply")?,
        _ => {
            let m = load("meshes/classic/decimated_profactor_50k/armadillo.obj")?;
            subdivide_midpoint(&subdivide_midpoint(&m))
        }
    })
}

fn step_error(step: &str) -> impl Fn(String) -> TimingError + '_ {
    move |message| TimingError::Step {
        step: step.to_string(),
        message,
    }
}

/// Times case `name` in this process: SMS `repeat` times keeping the fastest (unless `only`
/// names another method), then each competitor (or only `only`), fastest of `repeat`.
pub fn run_case(
    name: &str,
    data: &Path,
    repeat: usize,
    only: Option<Method>,
) -> Result<CaseResult, TimingError> {
    let case = paper_case(name)?;
    let t = std::time::Instant::now();
    let mesh = load_case(name, data)?;
    let load_s = t.elapsed().as_secs_f64();
    let params = SmsParams::default();
    let mut result = CaseResult {
        name: name.to_string(),
        vertices: mesh.positions.len(),
        a_s: f64::NAN,
        field_s: f64::NAN,
        b_s: f64::NAN,
        c_s: f64::NAN,
        total_s: f64::NAN,
        load_s,
        peak_rss_mb: 0.0,
        paper_total_s: case.paper_sms_s,
        paper_row: case.paper_row.to_string(),
        baselines: Vec::new(),
    };
    if only.is_none_or(|m| m == Method::Sms) {
        time_sms(&mesh, &params, repeat, &mut result)?;
    }
    for (method, paper) in COMPETITORS
        .iter()
        .copied()
        .zip(case.paper_competitors_s)
        .filter(|(m, _)| only.is_none_or(|o| o == *m))
    {
        let mut fastest = f64::INFINITY;
        for _ in 0..repeat.max(1) {
            let out = compute_saliency(method, &mesh, &params, &Silent)
                .map_err(|e| step_error(name)(e.to_string()))?;
            fastest = fastest.min(out.seconds);
        }
        result
            .baselines
            .push((method.name().to_string(), fastest, paper, peak_rss_mb()));
    }
    if !result.total_s.is_finite() {
        // With --method, the one method this process ran.
        result.peak_rss_mb = peak_rss_mb();
    }
    Ok(result)
}

/// SMS's step timings into `result`, the fastest total of `repeat` runs, and SMS's own peak
/// memory (before any other method runs in this process).
fn time_sms(
    mesh: &Mesh,
    params: &SmsParams,
    repeat: usize,
    result: &mut CaseResult,
) -> Result<(), TimingError> {
    for _ in 0..repeat.max(1) {
        let r = sparse_metric_saliency(mesh, params, SmsExtras::default(), &Silent)
            .map_err(|e| step_error("sms")(e.to_string()))?;
        let tm = &r.report.timings;
        if result.total_s.is_nan() || tm.total_s < result.total_s {
            result.a_s = tm.a_metric_s;
            result.field_s = tm.a_field_s;
            result.b_s = tm.b_saliency_s;
            result.c_s = tm.c_interpolation_s;
            result.total_s = tm.total_s;
        }
    }
    result.peak_rss_mb = peak_rss_mb();
    Ok(())
}

/// Runs `exe` with `args` (a `bench --child` call) and reads the one JSON value it prints:
/// one measurement in a process of its own. `what` names the cell in errors.
pub fn run_cell_in_child<T: serde::de::DeserializeOwned>(
    exe: &Path,
    args: &[&OsStr],
    what: &str,
) -> Result<T, TimingError> {
    let child_error = |message: String| TimingError::Child {
        what: what.to_string(),
        message,
    };
    let out = Command::new(exe)
        .args(args)
        .output()
        .map_err(|e| child_error(format!("cannot run {}: {e}", exe.display())))?;
    if !out.status.success() {
        return Err(child_error(format!(
            "failed: {}",
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    serde_json::from_str(String::from_utf8_lossy(&out.stdout).trim())
        .map_err(|e| child_error(format!("printed no result: {e}")))
}

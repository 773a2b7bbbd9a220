//! A mesh's ground truth from the projected fixations of several subjects: read and check the
//! projections, count fixations per vertex, blur them into a density, and compute the
//! split-half human ceiling. `write_truth` puts it on disk in the formats `score` reads.
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{fixation_truth_from_rows, GroundTruth};
use crate::mesh::geometry::{BoundingBox, Normalization};
use crate::mesh::write_ply_with_quality;
use crate::progress::Progress;
use crate::projection::table::{read_projected_csv, write_projected_csv, ProjectedRow};
use crate::projection::{fate_counts_by_name, ProjectionFate};
use crate::provenance::{InputFile, Provenance};
use crate::scoring::surface_blur::{blur_on_mesh, BlurKernel};
use crate::scoring::{blur_grid, peak_over_blur, score_mesh, ScoreParams, HUMAN};
use crate::stimulus::load::LoadedStimulus;

/// Why a truth could not be built or written (reading a truth file has `TruthError`).
#[derive(Debug, thiserror::Error)]
pub enum TruthBuildError {
    /// The projections do not make one truth (another mesh, a subject twice, a vertex out of
    /// range, a malformed cone.csv); the message names the file and why.
    #[error("{0}")]
    Invalid(String),
    /// A projected.csv could not be read or truth.csv written (its reader names file, line,
    /// column).
    #[error("{0}")]
    Table(String),
    /// Blurring or scoring failed (the blur grid, the heat kernel).
    #[error("{0}")]
    Score(#[from] crate::scoring::ScoreError),
    /// A file could not be read, created or written.
    #[error("{action} {}: {cause}", path.display())]
    Io {
        /// `cannot read`, `cannot create`, `cannot write`.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
    },
}

type Result<T> = std::result::Result<T, TruthBuildError>;

/// An I/O error at `path` as a [`TruthBuildError`], for `map_err`.
fn io_at<'a>(
    action: &'static str,
    path: &'a Path,
) -> impl Fn(std::io::Error) -> TruthBuildError + 'a {
    move |cause| TruthBuildError::Io {
        action,
        path: path.to_path_buf(),
        cause,
    }
}

/// The SHA-256 of an input, or which input could not be read.
fn hash(path: &Path) -> Result<InputFile> {
    InputFile::hash(path).map_err(io_at("cannot read", path))
}

/// How the truth is blurred and how far the human-ceiling sweep goes.
#[derive(Debug, Clone, Copy)]
pub struct TruthParams {
    /// σ_b of the density map, normalized units (half principal-axes box diagonal = 1).
    pub blur: f64,
    /// Largest blur of the human-ceiling sweep.
    pub blur_max: f64,
    /// Step of the human-ceiling sweep.
    pub blur_step: f64,
    /// How the density and the human maps are blurred.
    pub kernel: BlurKernel,
}

impl Default for TruthParams {
    fn default() -> Self {
        TruthParams {
            blur: 0.02,
            blur_max: 0.2,
            blur_step: 0.01,
            kernel: BlurKernel::Euclidean,
        }
    }
}

#[derive(Serialize)]
pub struct SubjectTruth {
    pub fates: BTreeMap<&'static str, usize>,
    pub on_mesh: usize,
}

#[derive(Serialize)]
pub struct TruthSidecar {
    pub provenance: Provenance,
    pub mesh_sha256: String,
    pub blur: f64,
    pub kernel: BlurKernel,
    pub subjects: BTreeMap<String, SubjectTruth>,
    /// The protocol's fixations per subject (keep_longest).
    pub expected_per_subject: usize,
    pub fixations_on_mesh: usize,
    pub fixated_vertices: usize,
    pub human_splits: usize,
    pub human_auc_judd_unblurred: f64,
    pub human_auc_judd_peak: f64,
    pub human_auc_judd_peak_blur: f64,
    pub warnings: Vec<String>,
}

/// What `build_truth` computed.
pub struct TruthResult {
    /// Every subject's projected fixations, whatever their fate (truth.csv).
    pub rows: Vec<ProjectedRow>,
    /// The fixation set.
    pub truth: GroundTruth,
    /// Fixations per vertex.
    pub counts: Vec<f64>,
    /// The blurred fixation density, one value per vertex (density.csv).
    pub density: Vec<f64>,
    /// The cone density, when the projections carried one (cone.csv beside projected.csv).
    pub cone: Option<Vec<f64>>,
    /// (blur, metric, value) of the split-half human ceiling.
    pub human: Vec<(f64, &'static str, f64)>,
    /// truth.json.
    pub sidecar: TruthSidecar,
}

/// Projected fixations of several subjects, read and checked against one mesh.
pub struct Projections {
    /// Sorted by subject, then fixation.
    pub rows: Vec<ProjectedRow>,
    /// The cone density summed over the files that carry a cone.csv (None when none does).
    pub cone: Option<Vec<f64>>,
    /// The manifest, each projected.csv and each cone.csv, hashed.
    pub inputs: Vec<InputFile>,
    /// Things a user should know (printed by the CLI).
    pub warnings: Vec<String>,
}

/// `p`, or `p/projected.csv` when `p` is a folder.
pub fn projected_file(p: &Path) -> PathBuf {
    if p.is_dir() {
        p.join("projected.csv")
    } else {
        p.to_path_buf()
    }
}

/// Reads projected.csv files, checking that the project.json beside each names this mesh and
/// that no subject's fixation appears twice (the same subject given twice).
pub fn read_projections(stim: &LoadedStimulus, files: &[PathBuf]) -> Result<Projections> {
    let n = stim.mesh.positions.len();
    let mut inputs = vec![hash(&stim.manifest_path)?];
    let mut rows: Vec<ProjectedRow> = Vec::new();
    let mut cone: Option<Vec<f64>> = None;
    let mut warnings = Vec::new();
    for f in files {
        let dir = f.parent().unwrap_or(Path::new("."));
        check_projected_onto(stim, f, &dir.join("project.json"), &mut warnings)?;
        let part = read_projected_csv(f).map_err(|e| TruthBuildError::Table(e.to_string()))?;
        if let Some(bad) = part.iter().filter_map(|r| r.vertex).find(|&v| v >= n) {
            return Err(TruthBuildError::Invalid(format!(
                "{}: vertex {bad} is out of range: the mesh has {n} vertices",
                f.display()
            )));
        }
        rows.extend(part);
        inputs.push(hash(f)?);
        let cone_file = dir.join("cone.csv");
        if cone_file.exists() {
            add_cone_csv(&cone_file, cone.get_or_insert_with(|| vec![0.0; n]))?;
            inputs.push(hash(&cone_file)?);
        }
    }
    rows.sort_by(|a, b| a.subject.cmp(&b.subject).then(a.fixation.cmp(&b.fixation)));
    let dup = rows
        .windows(2)
        .find(|w| w[0].subject == w[1].subject && w[0].fixation == w[1].fixation);
    if let Some(w) = dup {
        return Err(TruthBuildError::Invalid(format!(
            "subject {} fixation {} appears twice: the same subject was given twice",
            w[0].subject, w[0].fixation
        )));
    }
    Ok(Projections {
        rows,
        cone,
        inputs,
        warnings,
    })
}

fn check_projected_onto(
    stim: &LoadedStimulus,
    projected: &Path,
    sidecar: &Path,
    warnings: &mut Vec<String>,
) -> Result<()> {
    match std::fs::read(sidecar) {
        Ok(b) => {
            let v: serde_json::Value = serde_json::from_slice(&b).map_err(|e| {
                TruthBuildError::Invalid(format!("{}: not JSON: {e}", sidecar.display()))
            })?;
            if v.get("mesh_sha256").and_then(|x| x.as_str()) != Some(stim.mesh_sha256.as_str()) {
                return Err(TruthBuildError::Invalid(format!(
                    "{} was projected onto another mesh than {} (SHA-256 differs)",
                    projected.display(),
                    stim.mesh_path.display()
                )));
            }
        }
        Err(_) => warnings.push(format!(
            "{}: no project.json beside it; cannot confirm it was projected onto this mesh",
            projected.display()
        )),
    }
    Ok(())
}

/// Adds the per-vertex weights of a cone.csv (`…,…,vertex,weight`) into `cone`.
fn add_cone_csv(path: &Path, cone: &mut [f64]) -> Result<()> {
    let n = cone.len();
    let bad = |what: String| TruthBuildError::Invalid(format!("{}{what}", path.display()));
    let mut r = csv::Reader::from_path(path)
        .map_err(|e| TruthBuildError::Invalid(format!("cannot read {}: {e}", path.display())))?;
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.map_err(|e| bad(format!(":{line}: {e}")))?;
        let v: usize = rec
            .get(2)
            .unwrap_or("")
            .parse()
            .map_err(|e| bad(format!(":{line}: column `vertex`: {e}")))?;
        let w: f64 = rec
            .get(3)
            .unwrap_or("")
            .parse()
            .map_err(|e| bad(format!(":{line}: column `weight`: {e}")))?;
        if v >= n {
            return Err(bad(format!(":{line}: vertex {v} out of range")));
        }
        cone[v] += w;
    }
    Ok(())
}

/// Builds a mesh's ground truth from checked projections (see `meshgaze truth --help`).
pub fn build_truth(
    stim: &LoadedStimulus,
    projections: Projections,
    params: &TruthParams,
    progress: &dyn Progress,
) -> Result<TruthResult> {
    let mesh = &stim.mesh;
    let n = mesh.positions.len();
    let Projections {
        rows,
        cone,
        inputs,
        mut warnings,
    } = projections;
    let fixation_truth = fixation_truth_from_rows(&rows);
    let mut counts = vec![0.0; n];
    for f in &fixation_truth.fixations {
        counts[f.vertex] += 1.0;
    }
    let normalized = Normalization::of_mesh(mesh, BoundingBox::Oriented).normalized_mesh(mesh);
    let density = blur_on_mesh(&normalized, params.kernel, &[&counts], params.blur)
        .map_err(TruthBuildError::Score)?
        .remove(0);
    let expected = stim.protocol.fixations.keep_longest;
    let subjects = subject_truths(&rows, expected, &mut warnings);
    let truth = GroundTruth::Fixations(fixation_truth.clone());
    let score_params = ScoreParams {
        blur_sigmas: blur_grid(params.blur_max, params.blur_step)
            .map_err(TruthBuildError::Score)?,
        kernel: params.kernel,
        borji_splits: 10,
        // Only the human rows are kept, and they do not depend on the chance band: one random
        // map (the fewest score_mesh takes) instead of 20 blurred at every σ for nothing.
        chance_maps: 1,
        ..ScoreParams::default()
    };
    let score = score_mesh(mesh, &truth, &[], &score_params, None, progress)
        .map_err(TruthBuildError::Score)?;
    let human: Vec<(f64, &'static str, f64)> = score
        .rows
        .iter()
        .filter(|r| r.method == HUMAN)
        .map(|r| (r.blur, r.metric, r.value))
        .collect();
    let auc: Vec<(f64, f64)> = human
        .iter()
        .filter(|h| h.1 == "auc_judd")
        .map(|h| (h.0, h.2))
        .collect();
    let (peak_blur, peak) = peak_over_blur(&auc);
    let sidecar = TruthSidecar {
        provenance: Provenance::new(inputs),
        mesh_sha256: stim.mesh_sha256.clone(),
        blur: params.blur,
        kernel: params.kernel,
        subjects,
        expected_per_subject: expected,
        fixations_on_mesh: fixation_truth.fixations.len(),
        fixated_vertices: counts.iter().filter(|c| **c > 0.0).count(),
        human_splits: score.human_splits,
        human_auc_judd_unblurred: auc.first().map_or(f64::NAN, |x| x.1),
        human_auc_judd_peak: peak,
        human_auc_judd_peak_blur: peak_blur,
        warnings,
    };
    Ok(TruthResult {
        rows,
        truth,
        counts,
        density,
        cone,
        human,
        sidecar,
    })
}

/// Fates per subject, with a warning for each subject with fewer on-mesh fixations than the
/// protocol keeps.
fn subject_truths(
    rows: &[ProjectedRow],
    expected: usize,
    warnings: &mut Vec<String>,
) -> BTreeMap<String, SubjectTruth> {
    let mut subjects = BTreeMap::new();
    let mut names: Vec<&str> = rows.iter().map(|r| r.subject.as_str()).collect();
    names.dedup();
    for s in names {
        let fates = fate_counts_by_name(rows.iter().filter(|r| r.subject == s));
        let on_mesh = fates[ProjectionFate::Hit.name()] + fates[ProjectionFate::Snapped.name()];
        if on_mesh < expected {
            warnings.push(format!(
                "subject {s}: {on_mesh} fixations on the mesh, the protocol keeps {expected}"
            ));
        }
        subjects.insert(s.to_string(), SubjectTruth { fates, on_mesh });
    }
    subjects
}

/// Writes truth.csv, density.csv, truth.ply, human.csv and truth.json into `out`.
pub fn write_truth(out: &Path, stim: &LoadedStimulus, r: &TruthResult) -> Result<()> {
    crate::file_bytes::create_output_dir(out).map_err(io_at("cannot create", out))?;
    let tp = out.join("truth.csv");
    write_projected_csv(
        std::io::BufWriter::new(std::fs::File::create(&tp).map_err(io_at("cannot create", &tp))?),
        &r.rows,
    )
    .map_err(|e| TruthBuildError::Table(format!("cannot write {}: {e}", tp.display())))?;
    let dp = out.join("density.csv");
    let dp_err = io_at("cannot write", &dp);
    let mut w =
        std::io::BufWriter::new(std::fs::File::create(&dp).map_err(io_at("cannot create", &dp))?);
    writeln!(
        w,
        "vertex,fixations,density{}",
        if r.cone.is_some() { ",cone" } else { "" }
    )
    .map_err(&dp_err)?;
    for v in 0..r.counts.len() {
        match &r.cone {
            Some(cone) => writeln!(w, "{v},{},{},{}", r.counts[v], r.density[v], cone[v]),
            None => writeln!(w, "{v},{},{}", r.counts[v], r.density[v]),
        }
        .map_err(&dp_err)?;
    }
    w.flush().map_err(&dp_err)?;
    let max = r.density.iter().cloned().fold(0.0f64, f64::max);
    let quality: Vec<f64> = r
        .density
        .iter()
        .map(|d| if max > 0.0 { d / max } else { 0.0 })
        .collect();
    let (fixations, subjects) = match &r.truth {
        GroundTruth::Fixations(f) => (f.fixations.len(), f.subjects.len()),
        GroundTruth::VertexMap(_) => (0, 0),
    };
    let ply = out.join("truth.ply");
    write_ply_with_quality(
        &ply,
        &stim.mesh,
        &quality,
        &[
            format!(
                "meshgaze {} truth: fixation density, blur {}",
                env!("CARGO_PKG_VERSION"),
                r.sidecar.blur
            ),
            format!("{fixations} fixations from {subjects} subjects"),
        ],
    )
    .map_err(io_at("cannot write", &ply))?;
    let hp = out.join("human.csv");
    let hp_err = io_at("cannot write", &hp);
    let mut w =
        std::io::BufWriter::new(std::fs::File::create(&hp).map_err(io_at("cannot create", &hp))?);
    writeln!(w, "blur,metric,value").map_err(&hp_err)?;
    for (b, m, v) in &r.human {
        writeln!(w, "{b},{m},{v}").map_err(&hp_err)?;
    }
    w.flush().map_err(&hp_err)?;
    let jp = out.join("truth.json");
    let json = serde_json::to_string_pretty(&r.sidecar).expect("the sidecar serializes") + "\n";
    std::fs::write(&jp, json).map_err(io_at("cannot write", &jp))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bad_cone_file_is_named_with_its_line() {
        let dir = std::env::temp_dir().join(format!("meshgaze-cone-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cone.csv");
        let mut cone = vec![0.0; 3];
        std::fs::write(
            &path,
            "subject,fixation,vertex,weight\ns1,0,1,0.5\ns1,1,2,0.25\n",
        )
        .unwrap();
        add_cone_csv(&path, &mut cone).unwrap();
        assert_eq!(cone, [0.0, 0.5, 0.25]);
        std::fs::write(
            &path,
            "subject,fixation,vertex,weight\ns1,0,1,0.5\ns1,1,x,0.25\n",
        )
        .unwrap();
        let e = add_cone_csv(&path, &mut cone).unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}:3: column `vertex`: ", path.display())),
            "{e}"
        );
        std::fs::write(&path, "subject,fixation,vertex,weight\ns1,0,9,0.5\n").unwrap();
        let e = add_cone_csv(&path, &mut cone).unwrap_err().to_string();
        assert_eq!(e, format!("{}:2: vertex 9 out of range", path.display()));
        let _ = std::fs::remove_dir_all(&dir);
        let e = hash(&dir.join("projected.csv")).unwrap_err().to_string();
        assert!(e.starts_with("cannot read "), "{e}");
    }
}

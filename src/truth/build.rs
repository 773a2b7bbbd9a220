//! A mesh's ground truth from the projected fixations of several subjects: read and check the
//! projections, count fixations per vertex, blur them into a density, and compute the
//! split-half human ceiling. `write_truth` puts it on disk in the formats `score` reads.
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
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

/// How the truth is blurred and how far the human-ceiling sweep goes.
#[derive(Debug, Clone, Copy)]
pub struct TruthParams {
    /// σ_b of the density map, normalized units (half principal-axes box diagonal = 1).
    pub blur: f64,
    /// Largest blur of the human-ceiling sweep.
    pub blur_max: f64,
    /// Step of the human-ceiling sweep.
    pub blur_step: f64,
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
    pub rows: Vec<ProjectedRow>,
    pub truth: GroundTruth,
    /// Fixations per vertex.
    pub counts: Vec<f64>,
    pub density: Vec<f64>,
    /// The cone density, when the projections carried one (cone.csv beside projected.csv).
    pub cone: Option<Vec<f64>>,
    /// (blur, metric, value) of the split-half human ceiling.
    pub human: Vec<(f64, &'static str, f64)>,
    pub sidecar: TruthSidecar,
}

/// Projected fixations of several subjects, read and checked against one mesh.
pub struct Projections {
    /// Sorted by subject, then fixation.
    pub rows: Vec<ProjectedRow>,
    pub cone: Option<Vec<f64>>,
    /// The manifest, each projected.csv and each cone.csv, hashed.
    pub inputs: Vec<InputFile>,
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
    let mut inputs = vec![InputFile::hash(&stim.manifest_path)?];
    let mut rows: Vec<ProjectedRow> = Vec::new();
    let mut cone: Option<Vec<f64>> = None;
    let mut warnings = Vec::new();
    for f in files {
        let dir = f.parent().unwrap_or(Path::new("."));
        check_projected_onto(stim, f, &dir.join("project.json"), &mut warnings)?;
        let part = read_projected_csv(f).map_err(anyhow::Error::msg)?;
        if let Some(bad) = part.iter().filter_map(|r| r.vertex).find(|&v| v >= n) {
            bail!(
                "{}: vertex {bad} is out of range: the mesh has {n} vertices",
                f.display()
            );
        }
        rows.extend(part);
        inputs.push(InputFile::hash(f)?);
        let cone_file = dir.join("cone.csv");
        if cone_file.exists() {
            add_cone_csv(&cone_file, cone.get_or_insert_with(|| vec![0.0; n]))?;
            inputs.push(InputFile::hash(&cone_file)?);
        }
    }
    rows.sort_by(|a, b| a.subject.cmp(&b.subject).then(a.fixation.cmp(&b.fixation)));
    let dup = rows
        .windows(2)
        .find(|w| w[0].subject == w[1].subject && w[0].fixation == w[1].fixation);
    if let Some(w) = dup {
        bail!(
            "subject {} fixation {} appears twice: the same subject was given twice",
            w[0].subject,
            w[0].fixation
        );
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
            let v: serde_json::Value = serde_json::from_slice(&b)
                .with_context(|| format!("{}: not JSON", sidecar.display()))?;
            if v.get("mesh_sha256").and_then(|x| x.as_str()) != Some(stim.mesh_sha256.as_str()) {
                bail!(
                    "{} was projected onto another mesh than {} (SHA-256 differs)",
                    projected.display(),
                    stim.mesh_path.display()
                );
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
    let mut r =
        csv::Reader::from_path(path).with_context(|| format!("cannot read {}", path.display()))?;
    for (i, rec) in r.records().enumerate() {
        let line = i + 2;
        let rec = rec.with_context(|| format!("{}:{line}", path.display()))?;
        let v: usize = rec
            .get(2)
            .unwrap_or("")
            .parse()
            .with_context(|| format!("{}:{line}: column `vertex`", path.display()))?;
        let w: f64 = rec
            .get(3)
            .unwrap_or("")
            .parse()
            .with_context(|| format!("{}:{line}: column `weight`", path.display()))?;
        if v >= n {
            bail!("{}:{line}: vertex {v} out of range", path.display());
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
        .map_err(anyhow::Error::msg)?
        .remove(0);
    let expected = stim.protocol.fixations.keep_longest;
    let subjects = subject_truths(&rows, expected, &mut warnings);
    let truth = GroundTruth::Fixations(fixation_truth.clone());
    let score_params = ScoreParams {
        blur_sigmas: blur_grid(params.blur_max, params.blur_step).map_err(anyhow::Error::msg)?,
        kernel: params.kernel,
        borji_splits: 10,
        ..ScoreParams::default()
    };
    let score =
        score_mesh(mesh, &truth, &[], &score_params, None, progress).map_err(anyhow::Error::msg)?;
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
    crate::file_bytes::create_output_dir(out)?;
    let tp = out.join("truth.csv");
    write_projected_csv(
        std::io::BufWriter::new(
            std::fs::File::create(&tp)
                .with_context(|| format!("cannot create {}", tp.display()))?,
        ),
        &r.rows,
    )
    .map_err(anyhow::Error::msg)?;
    let dp = out.join("density.csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&dp).with_context(|| format!("cannot create {}", dp.display()))?,
    );
    writeln!(
        w,
        "vertex,fixations,density{}",
        if r.cone.is_some() { ",cone" } else { "" }
    )?;
    for v in 0..r.counts.len() {
        match &r.cone {
            Some(cone) => writeln!(w, "{v},{},{},{}", r.counts[v], r.density[v], cone[v])?,
            None => writeln!(w, "{v},{},{}", r.counts[v], r.density[v])?,
        }
    }
    w.flush()?;
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
    write_ply_with_quality(
        &out.join("truth.ply"),
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
    .with_context(|| format!("cannot write {}", out.join("truth.ply").display()))?;
    let hp = out.join("human.csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&hp).with_context(|| format!("cannot create {}", hp.display()))?,
    );
    writeln!(w, "blur,metric,value")?;
    for (b, m, v) in &r.human {
        writeln!(w, "{b},{m},{v}")?;
    }
    w.flush()?;
    let jp = out.join("truth.json");
    std::fs::write(&jp, serde_json::to_string_pretty(&r.sidecar)? + "\n")
        .with_context(|| format!("cannot write {}", jp.display()))?;
    Ok(())
}

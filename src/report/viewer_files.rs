//! `meshgaze view`'s inputs read from the files the other commands write.
use std::path::{Path, PathBuf};

use super::viewer::{viewer_page, ViewerInput, ViewerLimits};
use super::ReportError;
use crate::file_bytes::stem_of;
use crate::mesh::load_mesh;
use crate::projection::table::{read_projected_csv, ProjectedRow};
use crate::saliency::map_file::read_map;
use crate::stimulus::load::load_stimulus;
use crate::truth::read_density;

/// What to show, as paths.
#[derive(Debug, Clone, Default)]
pub struct ViewFiles {
    /// The mesh file.
    pub mesh: PathBuf,
    /// Per-vertex maps (`vertex,saliency` CSV or any per-vertex format), named by file stem,
    /// or `NAME=PATH`.
    pub saliency: Vec<String>,
    /// A truth folder (`meshgaze truth` output: density.csv, truth.json, truth.csv) or its
    /// density.csv.
    pub truth: Option<PathBuf>,
    /// projected.csv files or folders holding one; empty with a truth folder: its truth.csv.
    pub fixations: Vec<PathBuf>,
    /// A stimulus folder (or manifest.json) rendered from this mesh.
    pub stimulus: Option<PathBuf>,
    /// Above which size the mesh is shown simplified.
    pub limits: ViewerLimits,
}

fn csv_in(p: &Path, name: &str) -> PathBuf {
    if p.is_dir() {
        p.join(name)
    } else {
        p.to_path_buf()
    }
}

/// Reads every input and returns the viewer page, with a one-line account of what it holds.
pub fn view_page_from_files(files: &ViewFiles) -> Result<(String, String), ReportError> {
    let (mesh, _) = load_mesh(&files.mesh).map_err(ReportError::stage)?;
    let n = mesh.positions.len();
    let mut maps = Vec::new();
    for spec in &files.saliency {
        let (name, path) = match spec.split_once('=') {
            Some((name, path)) if !name.is_empty() && !Path::new(spec).exists() => {
                (name.to_string(), PathBuf::from(path))
            }
            _ => (stem_of(Path::new(spec)), PathBuf::from(spec)),
        };
        if maps.iter().any(|(m, _): &(String, Vec<f64>)| *m == name) {
            return Err(ReportError::Invalid(format!(
                "two maps are named `{name}`: name them with NAME=PATH"
            )));
        }
        let values = read_map(&path, n).map_err(ReportError::stage)?;
        maps.push((name, values));
    }
    let mut truth_density = None;
    let mut fixation_files: Vec<PathBuf> = files
        .fixations
        .iter()
        .map(|p| csv_in(p, "projected.csv"))
        .collect();
    if let Some(t) = &files.truth {
        let density_path = csv_in(t, "density.csv");
        let density = read_density(&density_path, n).map_err(ReportError::stage)?;
        if density.len() != n {
            return Err(ReportError::Invalid(format!(
                "{}: {} rows; the mesh has {n} vertices",
                density_path.display(),
                density.len()
            )));
        }
        let dir = density_path.parent().unwrap_or(Path::new("."));
        let blur = std::fs::read(dir.join("truth.json"))
            .ok()
            .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
            .and_then(|v| v.get("blur").and_then(|b| b.as_f64()));
        truth_density = Some((density, blur.unwrap_or(f64::NAN)));
        if fixation_files.is_empty() && dir.join("truth.csv").exists() {
            fixation_files.push(dir.join("truth.csv"));
        }
    }
    let mut fixations: Vec<ProjectedRow> = Vec::new();
    for f in &fixation_files {
        fixations.extend(read_projected_csv(f).map_err(|e| ReportError::Stage(e.to_string()))?);
    }
    let stim = files
        .stimulus
        .as_ref()
        .map(|s| load_stimulus(s, Some(&files.mesh)))
        .transpose()
        .map_err(|e| {
            ReportError::Invalid(format!("the stimulus must be rendered from this mesh: {e}"))
        })?;
    let input = ViewerInput {
        title: stem_of(&files.mesh),
        mesh: &mesh,
        maps,
        truth_density,
        fixations,
        stimulus: stim.as_ref().map(|s| (&s.plan, s.fps)),
    };
    let page = viewer_page(&input, &files.limits)?;
    let on_mesh = input.fixations.iter().filter(|r| r.x.is_some()).count();
    let account = format!(
        "{}: {n} vertices, {} maps{}, {} fixations ({on_mesh} on the surface){}",
        files.mesh.display(),
        input.maps.len(),
        if input.truth_density.is_some() {
            " + truth"
        } else {
            ""
        },
        input.fixations.len(),
        if stim.is_some() {
            ", the stimulus cameras"
        } else {
            ""
        }
    );
    Ok((page, account))
}

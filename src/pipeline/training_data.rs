//! What `meshgaze train` learns from: gaze-point files, datasets of meshes with per-vertex
//! truth, and the meshes of finished studies, each turned into a training object.
use std::path::{Path, PathBuf};

use super::PipelineError;
use crate::experiments::gaze_model_cross_validation::EvaluationMesh;
use crate::gaze_model::{object_name, training_object, training_object_from_map, TrainingObject};
use crate::mesh::load_mesh;
use crate::protocol::Protocol;
use crate::provenance::{sha256_hex, InputFile};
use crate::scoring::dataset::dataset_pairs;
use crate::stimulus::load::load_stimulus;
use crate::truth::{load_ground_truth_on, read_density, GroundTruth, TruthLayout};

/// Where a training object comes from.
#[derive(Debug, Clone)]
pub enum TrainingSource {
    /// A gaze-point file with a flag column.
    Points(PathBuf),
    /// A mesh and its per-vertex truth (a dataset's meshes/ + truth/).
    MeshTruth {
        /// The object's name.
        name: String,
        /// The mesh file.
        mesh: PathBuf,
        /// Its truth file.
        truth: PathBuf,
    },
    /// A study's rendered mesh and its fixation density.
    StudyMesh {
        /// The mesh's name in the study.
        name: String,
        /// Its stimulus folder.
        stimulus: PathBuf,
        /// Its `truth/<mesh>/density.csv`.
        density: PathBuf,
    },
}

impl TrainingSource {
    /// The training object's name (what leave-one-object-out holds out).
    pub fn name(&self) -> String {
        match self {
            TrainingSource::Points(p) => object_name(p),
            TrainingSource::MeshTruth { name, .. } | TrainingSource::StudyMesh { name, .. } => {
                name.clone()
            }
        }
    }

    /// The dataset (or study output folder) it belongs to, by folder name: what training
    /// balances and `train --weight NAME=W` names.
    pub fn dataset(&self) -> String {
        let folder = match self {
            TrainingSource::Points(p) => p.parent().and_then(Path::parent),
            TrainingSource::MeshTruth { mesh, .. } => mesh.parent().and_then(Path::parent),
            TrainingSource::StudyMesh { density, .. } => density
                .parent()
                .and_then(Path::parent)
                .and_then(Path::parent),
        };
        folder_name(folder)
    }

    /// The files it comes from, for messages.
    pub fn describe(&self) -> String {
        match self {
            TrainingSource::Points(p) => p.display().to_string(),
            TrainingSource::MeshTruth { mesh, truth, .. } => {
                format!("{} with {}", mesh.display(), truth.display())
            }
            TrainingSource::StudyMesh { density, .. } => density.display().to_string(),
        }
    }

    /// Its features and labels: positives are the top `top_fraction` of its map; `layout`
    /// says whether a dataset's truth map is per vertex or per face (carried to vertices).
    pub fn object(
        &self,
        protocol: &Protocol,
        top_fraction: f64,
        layout: TruthLayout,
    ) -> Result<TrainingObject, PipelineError> {
        let hash = |p: &Path| {
            InputFile::hash(p)
                .map(|f| f.sha256)
                .map_err(PipelineError::io(p))
        };
        match self {
            TrainingSource::Points(p) => {
                training_object(p, &self.dataset(), protocol).map_err(PipelineError::stage)
            }
            TrainingSource::MeshTruth { name, mesh, truth } => {
                let (m, _) = load_mesh(mesh).map_err(PipelineError::stage)?;
                let t = load_ground_truth_on(truth, &m, top_fraction, layout)
                    .map_err(PipelineError::stage)?;
                let values = vertex_values(t, m.positions.len());
                let sha = sha256_hex(format!("{} {}", hash(mesh)?, hash(truth)?).as_bytes());
                let dataset = self.dataset();
                training_object_from_map(name, &dataset, sha, &m, &values, top_fraction, protocol)
                    .map_err(PipelineError::stage)
            }
            TrainingSource::StudyMesh {
                name,
                stimulus,
                density,
            } => {
                let stim = load_stimulus(stimulus, None).map_err(PipelineError::stage)?;
                let values = read_density(density, stim.mesh.positions.len())
                    .map_err(PipelineError::stage)?;
                let sha = sha256_hex(format!("{} {}", stim.mesh_sha256, hash(density)?).as_bytes());
                training_object_from_map(
                    name,
                    &self.dataset(),
                    sha,
                    &stim.mesh,
                    &values,
                    top_fraction,
                    protocol,
                )
                .map_err(PipelineError::stage)
            }
        }
    }
}

/// A folder's last component; `.` and `..` are resolved first so `--dataset .` is named after
/// the folder it means (only `/` stays unnamed: `dataset`).
fn folder_name(folder: Option<&Path>) -> String {
    let Some(folder) = folder else {
        return "dataset".to_string();
    };
    let resolved;
    let folder = if folder.file_name().is_none() || folder.ends_with("..") {
        let here = if folder.as_os_str().is_empty() {
            Path::new(".")
        } else {
            folder
        };
        resolved = std::fs::canonicalize(here).unwrap_or_else(|_| folder.to_path_buf());
        resolved.as_path()
    } else {
        folder
    };
    folder.file_name().map_or_else(
        || "dataset".to_string(),
        |n| n.to_string_lossy().to_string(),
    )
}

/// The name training gives each folder (its last component), refusing two folders of the
/// same name: their weights could not be told apart.
pub fn dataset_names(
    datasets: &[PathBuf],
    studies: &[PathBuf],
) -> Result<Vec<String>, PipelineError> {
    let mut names: Vec<(String, &PathBuf)> = Vec::new();
    for d in datasets.iter().chain(studies) {
        let name = folder_name(Some(d.as_path()));
        if let Some((_, other)) = names.iter().find(|(n, _)| *n == name) {
            return Err(PipelineError::Invalid(format!(
                "{} and {} are both named `{name}`; training tells datasets apart by folder name, so rename or link one",
                other.display(),
                d.display()
            )));
        }
        names.push((name, d));
    }
    Ok(names.into_iter().map(|(n, _)| n).collect())
}

/// One value per vertex: the map itself, or a fixation set's count per vertex.
fn vertex_values(truth: GroundTruth, n: usize) -> Vec<f64> {
    match truth {
        GroundTruth::VertexMap(map) => map.values,
        GroundTruth::Fixations(f) => {
            let mut counts = vec![0.0; n];
            for x in &f.fixations {
                counts[x.vertex] += 1.0;
            }
            counts
        }
    }
}

/// Every training source of the datasets (points/ files, then meshes/ + truth/ pairs without
/// a points file of the same name) and of the study output folders, less `exclude`d names.
pub fn training_sources(
    datasets: &[PathBuf],
    studies: &[PathBuf],
    exclude: &[String],
) -> Result<Vec<TrainingSource>, PipelineError> {
    if datasets.is_empty() && studies.is_empty() {
        return Err(PipelineError::Invalid("nothing to train on: give --dataset DIR (points/, or meshes/ + truth/) and/or --study OUT".to_string()));
    }
    let files = point_files(datasets)?;
    let mut sources: Vec<TrainingSource> =
        files.iter().cloned().map(TrainingSource::Points).collect();
    for d in datasets.iter().filter(|d| d.join("meshes").is_dir()) {
        let pairs = dataset_pairs(d).map_err(|e| PipelineError::stage(format!("{e:#}")))?;
        for (name, mesh, truth) in pairs {
            if !files.iter().any(|f| object_name(f) == name) {
                sources.push(TrainingSource::MeshTruth { name, mesh, truth });
            }
        }
    }
    for out in studies {
        sources.extend(study_sources(out)?);
    }
    for name in exclude {
        let before = sources.len();
        sources.retain(|s| s.name() != *name);
        if sources.len() == before {
            return Err(PipelineError::Invalid(format!(
                "--exclude {name}: no training object of that name"
            )));
        }
    }
    if sources.is_empty() {
        return Err(PipelineError::Invalid(
            "no training objects found in the given folders".to_string(),
        ));
    }
    Ok(sources)
}

/// Every `points/*.txt[.gz]` of the datasets, sorted by dataset then name.
fn point_files(datasets: &[PathBuf]) -> Result<Vec<PathBuf>, PipelineError> {
    let mut files = Vec::new();
    for d in datasets {
        let dir = d.join("points");
        if !dir.exists() && d.join("meshes").is_dir() {
            continue;
        }
        let mut here: Vec<PathBuf> = std::fs::read_dir(&dir)
            .map_err(|e| {
                PipelineError::input(
                    &dir,
                    format!("cannot read it ({e}); a dataset needs a points/ folder"),
                )
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| {
                let n = p.file_name().unwrap_or_default().to_string_lossy();
                n.ends_with(".txt") || n.ends_with(".txt.gz")
            })
            .collect();
        if here.is_empty() {
            return Err(PipelineError::input(&dir, "no .txt or .txt.gz point files"));
        }
        here.sort();
        files.extend(here);
    }
    Ok(files)
}

/// Every mesh of a study output folder with a truth/<mesh>/density.csv, in name order.
fn study_sources(out: &Path) -> Result<Vec<TrainingSource>, PipelineError> {
    let truth = out.join("truth");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&truth)
        .map_err(|e| {
            PipelineError::input(
                &truth,
                format!(
                    "cannot read it ({e}); is {} a study output folder?",
                    out.display()
                ),
            )
        })?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("density.csv").is_file())
        .collect();
    dirs.sort();
    if dirs.is_empty() {
        return Err(PipelineError::input(
            out,
            "no truth/<mesh>/density.csv yet; run `meshgaze study run` first",
        ));
    }
    Ok(dirs
        .into_iter()
        .map(|d| {
            let name = d
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string();
            TrainingSource::StudyMesh {
                stimulus: out.join("stimuli").join(&name),
                density: d.join("density.csv"),
                name,
            }
        })
        .collect())
}

/// An error when two training objects share a name (leave-one-object-out holds out by name).
pub fn check_unique_names(
    objects: &[TrainingObject],
    sources: &[TrainingSource],
) -> Result<(), PipelineError> {
    for (i, a) in objects.iter().enumerate() {
        if let Some(j) = objects[..i].iter().position(|b| b.name == a.name) {
            return Err(PipelineError::Invalid(format!(
                "two training objects named `{}`: {} and {}; leave-one-object-out needs unique names",
                a.name,
                sources[j].describe(),
                sources[i].describe()
            )));
        }
    }
    Ok(())
}

/// The meshes with per-vertex truth of every dataset that has `meshes/` and `truth/`: what
/// `train --cv` holds out one at a time, their truth read with `layout`.
pub fn evaluation_meshes(
    datasets: &[PathBuf],
    layout: TruthLayout,
) -> Result<Vec<EvaluationMesh>, PipelineError> {
    let mut out = Vec::new();
    for d in datasets.iter().filter(|d| d.join("meshes").is_dir()) {
        let pairs = dataset_pairs(d).map_err(|e| PipelineError::stage(format!("{e:#}")))?;
        for (name, mesh_path, truth_path) in pairs {
            let (mesh, _) = load_mesh(&mesh_path).map_err(PipelineError::stage)?;
            let truth = load_ground_truth_on(&truth_path, &mesh, 0.05, layout)
                .map_err(PipelineError::stage)?;
            let GroundTruth::VertexMap(map) = truth else {
                return Err(PipelineError::input(
                    &truth_path,
                    "--cv needs a per-vertex truth map",
                ));
            };
            out.push(EvaluationMesh {
                name,
                dataset: folder_name(Some(d.as_path())),
                mesh,
                values: map.values,
                positive: map.positive,
            });
        }
    }
    if out.is_empty() {
        return Err(PipelineError::Invalid(
            "--cv: no dataset has meshes/ and truth/ to hold out".to_string(),
        ));
    }
    Ok(out)
}

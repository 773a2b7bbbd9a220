//! Scoring a set of meshes against their human truth: maps read from files and/or computed
//! by the methods, each mesh scored over the blur grid with its chance band and human ceiling,
//! the rows in one score CSV, plots per mesh, and the summary JSON with the mean over meshes.
//! What `meshgaze score` runs, for one mesh or a `--dataset` folder.
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::PipelineError;
use crate::gaze_model::object_fingerprint::training_object_in;
use crate::mesh::load_mesh;
use crate::progress::Progress;
use crate::provenance::{InputFile, Provenance};
use crate::report::score_plots::write_score_plots;
use crate::saliency::{compute_saliency_side_by_side, Method, SmsParams, Viewing};
use crate::scoring::dataset::{mean_summaries, write_score_rows, MeshEntry, SCORE_CSV_HEADER};
use crate::scoring::{score_mesh, MeshScore, MethodSummary, ScoreParams};
use crate::stimulus::hold_views::hold_view_exposure;
use crate::truth::{load_ground_truth, load_ground_truth_on, GroundTruth, TruthLayout};

/// What to score, and how.
pub struct ScoreRequest<'a> {
    /// (name, mesh file, truth file) per mesh.
    pub pairs: &'a [(String, PathBuf, PathBuf)],
    /// Map files to score beside the methods (named by their file stem; one mesh only).
    pub saliency_files: &'a [PathBuf],
    /// Methods computed on each mesh and scored.
    pub methods: &'a [Method],
    /// How each mesh is scored.
    pub params: &'a ScoreParams,
    /// For per-vertex truth maps without a 0/1 column: the top fraction taken as fixated.
    pub top_fraction: f64,
    /// The protocol (hold views, priors), the gaze model and the rarity parameters.
    pub viewing: &'a Viewing,
    /// Per-vertex or per-face truth maps (or told by their row count).
    pub truth_layout: TruthLayout,
}

/// One mesh, scored: what the caller may print.
pub struct ScoredMesh {
    /// The mesh's name.
    pub name: String,
    /// Its vertices.
    pub vertices: usize,
    /// Positive vertices of its truth.
    pub score_positives: usize,
    /// Fixations of its truth (0 for a map).
    pub score_fixations: usize,
    /// Subject splits behind its human ceiling.
    pub human_splits: usize,
    /// The chart files written for it.
    pub plots: Vec<String>,
}

/// What was written.
pub struct ScoreOutputs {
    /// PREFIX.csv: every score row of every mesh.
    pub csv: PathBuf,
    /// PREFIX.json: provenance, parameters, each mesh's entry and the means.
    pub json: PathBuf,
    /// Each mesh's entry.
    pub entries: Vec<MeshEntry>,
    /// Each method's summary averaged over the meshes.
    pub mean: Vec<MethodSummary>,
}

#[derive(Serialize)]
struct Summary<'a> {
    provenance: Provenance,
    parameters: &'a ScoreParams,
    top_fraction: f64,
    meshes: Vec<MeshEntry>,
    mean: Vec<MethodSummary>,
}

/// Refuses to score the gaze model on an object it was trained on: named like one, or holding
/// one's points under another name (a renamed or re-saved copy of a training mesh).
fn refuse_training_object(
    viewing: &Viewing,
    mesh_name: &str,
    mesh: &crate::mesh::Mesh,
) -> Result<(), PipelineError> {
    let model = viewing.gaze_model();
    let advice = "`meshgaze train --cv` gives leave-one-object-out figures, or pass --model trained without it (`meshgaze train --exclude NAME`)";
    if model.training.objects.iter().any(|o| o.name == mesh_name) {
        return Err(PipelineError::Invalid(format!(
            "{mesh_name}: the gaze model was trained on an object named `{mesh_name}`, so its score here would be a training-set figure; {advice}"
        )));
    }
    if let Some((object, matched)) = training_object_in(&model, mesh) {
        return Err(PipelineError::Invalid(format!(
            "{mesh_name}: this mesh's surface passes through {} of the {} points the gaze model keeps of its training object `{}` (dataset `{}`): it is that object under another name, so its score here would be a training-set figure; {advice}",
            matched,
            object.fingerprint.len(),
            object.name,
            object.dataset
        )));
    }
    Ok(())
}

/// The maps to score on one mesh: the files, then each method computed, with its seconds.
#[allow(clippy::type_complexity)]
fn maps_of(
    req: &ScoreRequest,
    name: &str,
    mesh_path: &Path,
    mesh: &crate::mesh::Mesh,
    inputs: &mut Vec<InputFile>,
    progress: &dyn Progress,
) -> Result<(Vec<(String, Vec<f64>)>, Vec<(String, f64)>), PipelineError> {
    let mut maps = Vec::new();
    let mut seconds = Vec::new();
    for file in req.saliency_files {
        let GroundTruth::VertexMap(m) =
            load_ground_truth(file, mesh.positions.len(), 0.05).map_err(PipelineError::stage)?
        else {
            return Err(PipelineError::input(
                file,
                "expected a per-vertex map (vertex,saliency)",
            ));
        };
        inputs.push(InputFile::hash(file).map_err(PipelineError::io(file))?);
        let stem = file.file_name().unwrap_or_default().to_string_lossy();
        maps.push((
            stem.split('.').next().unwrap_or("map").to_string(),
            m.values,
        ));
    }
    if req.methods.contains(&Method::Gaze) {
        refuse_training_object(req.viewing, name, mesh)?;
    }
    // The methods run side by side (GR and MR sharing their descriptors): each map is the same
    // on any thread count, kept in the order asked for; a method's seconds are its wall time
    // beside the others. One bar counts the methods done (their own steps would interleave on
    // a single bar).
    progress.start("saliency maps", req.methods.len() as u64);
    let computed = compute_saliency_side_by_side(
        req.methods,
        mesh,
        &SmsParams::default(),
        req.viewing,
        &|_| progress.advance(1),
    );
    progress.finish();
    let computed: Vec<_> = computed
        .into_iter()
        .zip(req.methods.iter())
        .map(|(out, &method)| {
            out.map(|out| (method, out))
                .map_err(|e| PipelineError::input(mesh_path, e))
        })
        .collect();
    for result in computed {
        let (method, out) = result?;
        seconds.push((method.name().to_string(), out.seconds));
        maps.push((method.name().to_string(), out.values));
    }
    Ok((maps, seconds))
}

/// Scores every mesh of `req` and writes PREFIX.csv, PREFIX.json and the plots beside them;
/// `on_mesh` is told of each mesh as it is done.
pub fn score_dataset(
    req: &ScoreRequest,
    prefix: &Path,
    progress: &dyn Progress,
    on_mesh: &mut dyn FnMut(&ScoredMesh),
) -> Result<ScoreOutputs, PipelineError> {
    if !(req.top_fraction > 0.0 && req.top_fraction <= 1.0) {
        return Err(PipelineError::Invalid(
            "--top-fraction must be in (0, 1]".into(),
        ));
    }
    if req.methods.is_empty() && req.saliency_files.is_empty() {
        return Err(PipelineError::Invalid(
            "nothing to score: give --method (e.g. sms,ms,mc) and/or --saliency FILE".into(),
        ));
    }
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(PipelineError::io(dir))?;
    }
    let csv_path = PathBuf::from(format!("{}.csv", prefix.display()));
    let mut csv = std::io::BufWriter::new(
        std::fs::File::create(&csv_path).map_err(PipelineError::io(&csv_path))?,
    );
    writeln!(csv, "{SCORE_CSV_HEADER}").map_err(PipelineError::io(&csv_path))?;
    let mut inputs = Vec::new();
    let mut entries = Vec::new();
    for (name, mesh_path, truth_path) in req.pairs {
        let (mesh, load) = load_mesh(mesh_path).map_err(PipelineError::stage)?;
        let truth = load_ground_truth_on(truth_path, &mesh, req.top_fraction, req.truth_layout)
            .map_err(PipelineError::stage)?;
        inputs.push(InputFile::hash(mesh_path).map_err(PipelineError::io(mesh_path))?);
        inputs.push(InputFile::hash(truth_path).map_err(PipelineError::io(truth_path))?);
        let (maps, seconds) = maps_of(req, name, mesh_path, &mesh, &mut inputs, progress)?;
        let seen = hold_view_exposure(&mesh, &req.viewing.protocol)
            .map_err(|e| PipelineError::input(mesh_path, e))?
            .seen();
        let score: MeshScore = score_mesh(&mesh, &truth, &maps, req.params, Some(&seen), progress)
            .map_err(|e| PipelineError::input(mesh_path, e))?;
        let plots = write_score_plots(prefix, name, &maps, &score).map_err(PipelineError::stage)?;
        write_score_rows(&mut csv, name, &score.rows).map_err(PipelineError::io(&csv_path))?;
        on_mesh(&ScoredMesh {
            name: name.clone(),
            vertices: mesh.positions.len(),
            score_positives: score.positives,
            score_fixations: score.fixations,
            human_splits: score.human_splits,
            plots,
        });
        entries.push(MeshEntry {
            mesh: name.clone(),
            load,
            truth_kind: match truth {
                GroundTruth::VertexMap(_) => "vertex_map",
                GroundTruth::Fixations(_) => "fixations",
            },
            positives: score.positives,
            fixations: score.fixations,
            human_splits: score.human_splits,
            chance_auc_judd: score.chance_auc_judd.clone(),
            seconds_per_method: seconds,
            summaries: score.summaries,
        });
    }
    csv.flush().map_err(PipelineError::io(&csv_path))?;
    let mean = mean_summaries(&entries);
    let json_path = PathBuf::from(format!("{}.json", prefix.display()));
    let summary = Summary {
        provenance: Provenance::new(inputs),
        parameters: req.params,
        top_fraction: req.top_fraction,
        meshes: entries,
        mean,
    };
    let json = serde_json::to_string_pretty(&summary).map_err(PipelineError::stage)? + "\n";
    std::fs::write(&json_path, json).map_err(PipelineError::io(&json_path))?;
    Ok(ScoreOutputs {
        csv: csv_path,
        json: json_path,
        entries: summary.meshes,
        mean: summary.mean,
    })
}

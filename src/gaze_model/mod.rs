//! A learned predictor of where people look: boosted trees over features that need no human
//! input (shape at several scales, placement along the protocol's up and front axes, what
//! the protocol's views show), trained on a lab's own per-point fixation flags.
//!
//! Training objects are oriented points with a 0/1 flag (the VR experiment's upstream gaze
//! files, 44 objects, 29 of them with no mesh), so every feature is computed from points
//! and normals alone; a mesh is predicted from its vertices and vertex normals.
pub mod boosted_trees;
mod error;

pub mod features;
pub(crate) mod local_shape;
pub mod object_fingerprint;
pub(crate) mod shape_contrast;
pub mod surface_points;
pub(crate) mod view_visibility;

pub use error::{FeatureError, GazeModelError, TreesError};

use std::path::Path;

use rand::seq::SliceRandom;
use rand::SeedableRng;
use serde::{Deserialize, Serialize};

use self::boosted_trees::{BoostParams, BoostedTrees};
use self::features::{feature_names, point_features, FeatureMatrix};
use self::surface_points::{read_gaze_points, SurfacePoints};
use crate::protocol::Protocol;
use crate::provenance::sha256_hex;

/// The model shipped with meshgaze, trained on every object of ../shared/data/fixations-vr/
/// points by `meshgaze train --dataset ../shared/data/fixations-vr -o models/gaze-vr.json`.
pub const BUILTIN_MODEL: &str = include_str!("../../models/gaze-vr.json");

/// The `format` field of a model file.
pub const MODEL_FORMAT: &str = "meshgaze-gaze-model";

/// One training object: its features and per-point flags.
#[derive(Debug, Clone)]
pub struct TrainingObject {
    /// The object's name (its file stem).
    pub name: String,
    /// The dataset (or study) it came from, by folder name: training balances datasets.
    pub dataset: String,
    /// SHA-256 of its gaze-point file.
    pub sha256: String,
    /// One feature row per point.
    pub features: FeatureMatrix,
    /// Whether each point is among the most looked-at (the file's flag column).
    pub labels: Vec<bool>,
    /// A few of its points, by which `score` recognises a copy of it under another name.
    pub fingerprint: Vec<[f64; 3]>,
}

/// What a model was trained on and how (all of it fixes the bytes of the model).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingRecord {
    /// Every training object.
    pub objects: Vec<ObjectRecord>,
    /// Each dataset's share of the training weight: a lab's 2 meshes weigh as much as
    /// another dataset's 59 unless a weight says otherwise.
    pub datasets: Vec<DatasetRecord>,
    /// Points drawn from each object.
    pub rows_per_object: usize,
    /// The seed of the draws.
    pub seed: u64,
    /// The protocol whose views the view features were computed with.
    pub protocol: String,
}

/// One training object as the model file records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectRecord {
    /// The object's name.
    pub name: String,
    /// The dataset it came from.
    pub dataset: String,
    /// SHA-256 of its gaze-point file.
    pub sha256: String,
    /// Its points.
    pub points: usize,
    /// Its flagged (most looked-at) points.
    pub positives: usize,
    /// Points drawn for training.
    pub rows_used: usize,
    /// A few of its points ([`object_fingerprint`]): `score` refuses a mesh that holds them
    /// whatever its name. Empty in model files written before it was kept.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fingerprint: Vec<[f64; 3]>,
}

/// One dataset of a model's training data and the weight it carried.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetRecord {
    /// The dataset's folder name.
    pub name: String,
    /// Its objects.
    pub objects: usize,
    /// Its training rows.
    pub rows: usize,
    /// The weight asked for (`train --weight NAME=W`, 1 by default).
    pub weight: f64,
    /// What each of its rows weighed in training: rows × weight / (its share of all rows),
    /// so the datasets' total weights stand in the ratio of their `weight`s.
    pub row_weight: f64,
}

/// A learned gaze predictor: boosted trees over per-point features, with the record of what
/// it was trained on. Trained on one experiment's observers, it predicts their habits; it is
/// not a general model of where people look.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GazeModel {
    /// [`MODEL_FORMAT`].
    pub format: String,
    /// The file format's version.
    pub version: u32,
    /// The meshgaze version that trained it.
    pub tool_version: String,
    /// The feature names, in column order.
    pub features: Vec<String>,
    /// What it was trained on and how.
    pub training: TrainingRecord,
    /// The trees.
    pub trees: BoostedTrees,
}

/// How a model is trained.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainOptions {
    /// The boosting parameters.
    pub params: BoostParams,
    /// Points drawn from each object (all of them when it has fewer), so every object
    /// weighs the same whatever its size.
    pub rows_per_object: usize,
    /// Seed of the row draws.
    pub seed: u64,
    /// Weight of a dataset by name (1 when absent): its rows together weigh this much
    /// relative to every other dataset's, whatever the number of objects in each.
    pub dataset_weights: Vec<(String, f64)>,
}

impl Default for TrainOptions {
    fn default() -> Self {
        TrainOptions {
            params: BoostParams::default(),
            rows_per_object: 4000,
            seed: 1,
            dataset_weights: Vec::new(),
        }
    }
}

impl TrainOptions {
    fn weight_of(&self, dataset: &str) -> f64 {
        self.dataset_weights
            .iter()
            .find(|(name, _)| name == dataset)
            .map_or(1.0, |(_, w)| *w)
    }
}

/// Reads a gaze-point file with a flag column and computes its features.
/// `dataset` names the folder it belongs to (training balances datasets).
pub fn training_object(
    path: &Path,
    dataset: &str,
    protocol: &Protocol,
) -> Result<TrainingObject, GazeModelError> {
    let bytes = std::fs::read(path).map_err(|error| GazeModelError::Io {
        path: path.to_path_buf(),
        error,
    })?;
    let points = read_gaze_points(path).map_err(|e| GazeModelError::Points(e.to_string()))?;
    let Some(labels) = points.flag else {
        return Err(GazeModelError::Invalid(format!(
            "{}: no flag column (8th), so nothing to learn from",
            path.display()
        )));
    };
    let features =
        point_features(&points.points, protocol).map_err(|error| GazeModelError::Features {
            what: path.display().to_string(),
            error,
        })?;
    Ok(TrainingObject {
        name: object_name(path),
        dataset: dataset.to_string(),
        sha256: sha256_hex(&bytes),
        features,
        labels,
        fingerprint: object_fingerprint::fingerprint_of(&points.points.positions),
    })
}

/// A mesh with a per-vertex human map as a training object: its vertices with vertex
/// normals, flagged when among the `top_fraction` highest values (never where the value is
/// 0: an unlooked-at vertex is not a positive however few vertices were looked at).
/// `sha256` names the inputs (e.g. of the mesh and the truth file together).
pub fn training_object_from_map(
    name: &str,
    dataset: &str,
    sha256: String,
    mesh: &crate::mesh::Mesh,
    values: &[f64],
    top_fraction: f64,
    protocol: &Protocol,
) -> Result<TrainingObject, GazeModelError> {
    if values.len() != mesh.positions.len() {
        return Err(GazeModelError::Invalid(format!(
            "{name}: {} values for {} vertices",
            values.len(),
            mesh.positions.len()
        )));
    }
    let points = SurfacePoints::of_mesh(mesh);
    let features = point_features(&points, protocol).map_err(|error| GazeModelError::Features {
        what: name.to_string(),
        error,
    })?;
    let mut sorted: Vec<f64> = values.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let k = ((top_fraction * values.len() as f64).round() as usize).clamp(1, values.len());
    let threshold = sorted[k - 1];
    let labels: Vec<bool> = values.iter().map(|&v| v > 0.0 && v >= threshold).collect();
    if !labels.iter().any(|&b| b) {
        return Err(GazeModelError::Invalid(format!(
            "{name}: no vertex has a positive value to learn from"
        )));
    }
    Ok(TrainingObject {
        name: name.to_string(),
        dataset: dataset.to_string(),
        sha256,
        features,
        labels,
        fingerprint: object_fingerprint::fingerprint_of(&mesh.positions),
    })
}

/// `bunny` for `points/bunny.txt.gz`.
pub fn object_name(path: &Path) -> String {
    let file = path.file_name().unwrap_or_default().to_string_lossy();
    let file = file.strip_suffix(".gz").unwrap_or(&file);
    match file.split_once('.') {
        Some((stem, _)) => stem.to_string(),
        None => file.to_string(),
    }
}

/// Trains on `objects` (in the given order; callers sort by name for reproducible bytes).
pub fn train_model(
    objects: &[&TrainingObject],
    options: &TrainOptions,
    protocol_name: &str,
) -> Result<GazeModel, GazeModelError> {
    train_model_without(objects, options, protocol_name, &[])
}

/// `train_model` with the `dropped` features held constant (so no tree splits on them): the
/// ablations of cross-validation. The model still takes every feature as input.
pub fn train_model_without(
    objects: &[&TrainingObject],
    options: &TrainOptions,
    protocol_name: &str,
    dropped: &[String],
) -> Result<GazeModel, GazeModelError> {
    let names = feature_names();
    if let Some(unknown) = dropped.iter().find(|d| !names.contains(d)) {
        return Err(GazeModelError::Invalid(format!(
            "no feature named `{unknown}` to leave out"
        )));
    }
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut labels = Vec::new();
    let mut records = Vec::new();
    let mut row_dataset = Vec::new();
    for object in objects {
        if object.features.names != names {
            return Err(GazeModelError::Invalid(format!(
                "{}: features of another version",
                object.name
            )));
        }
        let rows = sample_rows(object, options);
        for (f, column) in columns.iter_mut().enumerate() {
            if dropped.contains(&names[f]) {
                column.extend(std::iter::repeat_n(0.0, rows.len()));
            } else {
                column.extend(rows.iter().map(|&i| object.features.columns[f][i]));
            }
        }
        labels.extend(rows.iter().map(|&i| object.labels[i]));
        row_dataset.extend(std::iter::repeat_n(object.dataset.as_str(), rows.len()));
        records.push(ObjectRecord {
            name: object.name.clone(),
            dataset: object.dataset.clone(),
            sha256: object.sha256.clone(),
            points: object.labels.len(),
            positives: object.labels.iter().filter(|&&b| b).count(),
            rows_used: rows.len(),
            fingerprint: object.fingerprint.clone(),
        });
    }
    let datasets = balance_datasets(&records, options)?;
    let weights: Vec<f64> = row_dataset
        .iter()
        .map(|d| {
            datasets
                .iter()
                .find(|r| r.name == *d)
                .map_or(1.0, |r| r.row_weight)
        })
        .collect();
    let trees = boosted_trees::train(&columns, &labels, &weights, &options.params)?;
    Ok(GazeModel {
        format: MODEL_FORMAT.to_string(),
        version: 1,
        tool_version: env!("CARGO_PKG_VERSION").to_string(),
        features: names,
        training: TrainingRecord {
            objects: records,
            datasets,
            rows_per_object: options.rows_per_object,
            seed: options.seed,
            protocol: protocol_name.to_string(),
        },
        trees,
    })
}

/// Each dataset's row weight: `N w_d / (W n_d)` for N rows in all, n_d in dataset d, w_d its
/// weight and W the sum of the weights, so the total weights stand as the `w_d` do and still
/// sum to N (one dataset: exactly 1 per row, as before datasets were balanced).
fn balance_datasets(
    records: &[ObjectRecord],
    options: &TrainOptions,
) -> Result<Vec<DatasetRecord>, GazeModelError> {
    let mut out: Vec<DatasetRecord> = Vec::new();
    for r in records {
        match out.iter_mut().find(|d| d.name == r.dataset) {
            Some(d) => {
                d.objects += 1;
                d.rows += r.rows_used;
            }
            None => out.push(DatasetRecord {
                name: r.dataset.clone(),
                objects: 1,
                rows: r.rows_used,
                weight: options.weight_of(&r.dataset),
                row_weight: 0.0,
            }),
        }
    }
    for (name, w) in &options.dataset_weights {
        if !(w.is_finite() && *w > 0.0) {
            return Err(GazeModelError::Invalid(format!(
                "dataset `{name}`: weight {w} is not a positive number"
            )));
        }
    }
    let all_rows: usize = out.iter().map(|d| d.rows).sum();
    let all_weight: f64 = out.iter().map(|d| d.weight).sum();
    for d in &mut out {
        d.row_weight = if d.rows == 0 {
            0.0
        } else {
            all_rows as f64 * d.weight / all_weight / d.rows as f64
        };
    }
    Ok(out)
}

/// The rows of an object used for training: a seeded draw that depends only on the seed and
/// the object's name, so an object contributes the same rows to every fold.
fn sample_rows(object: &TrainingObject, options: &TrainOptions) -> Vec<usize> {
    let n = object.labels.len();
    let mut rows: Vec<usize> = (0..n).collect();
    if n > options.rows_per_object {
        let seed = options.seed
            ^ u64::from_str_radix(&sha256_hex(object.name.as_bytes())[..16], 16).unwrap_or(0);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        rows.shuffle(&mut rng);
        rows.truncate(options.rows_per_object);
        rows.sort_unstable();
    }
    rows
}

impl GazeModel {
    /// Reads a model file, refusing one whose format or features this build does not know.
    pub fn from_json(text: &str, name: &str) -> Result<GazeModel, GazeModelError> {
        let model: GazeModel = serde_json::from_str(text)
            .map_err(|e| GazeModelError::Model(format!("{name}: not a gaze model: {e}")))?;
        if model.format != MODEL_FORMAT {
            return Err(GazeModelError::Model(format!(
                "{name}: format `{}`, expected `{MODEL_FORMAT}`",
                model.format
            )));
        }
        if model.features != feature_names() {
            return Err(GazeModelError::Model(format!(
                "{name}: trained on features [{}], this build computes [{}]; retrain it with `meshgaze train`",
                model.features.join(", "),
                feature_names().join(", ")
            )));
        }
        Ok(model)
    }

    /// Reads a model file written by `meshgaze train`.
    pub fn load(path: &Path) -> Result<GazeModel, GazeModelError> {
        let text = std::fs::read_to_string(path).map_err(|error| GazeModelError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        GazeModel::from_json(&text, &path.display().to_string())
    }

    /// The model shipped with meshgaze (models/gaze-vr.json): one VR experiment's.
    pub fn builtin() -> GazeModel {
        GazeModel::from_json(BUILTIN_MODEL, "built-in model").expect("the built-in model loads")
    }

    /// The JSON bytes (the same for the same training data and options).
    pub fn to_json(&self) -> String {
        serde_json::to_string(self).expect("a model serializes") + "\n"
    }

    /// Probability of being among the most looked-at points, per point.
    pub fn predict(
        &self,
        points: &SurfacePoints,
        protocol: &Protocol,
    ) -> Result<Vec<f64>, GazeModelError> {
        let features = point_features(points, protocol)?;
        Ok(self.predict_features(&features))
    }

    /// [`GazeModel::predict`] from features already computed.
    pub fn predict_features(&self, features: &FeatureMatrix) -> Vec<f64> {
        self.trees
            .predict(&features.columns)
            .iter()
            .map(|s| 1.0 / (1.0 + (-s).exp()))
            .collect()
    }

    /// Features by share of the total split gain, largest first.
    pub fn importances(&self) -> Vec<(String, f64)> {
        let total: f64 = self.trees.gain.iter().sum();
        let mut v: Vec<(String, f64)> = self
            .features
            .iter()
            .cloned()
            .zip(
                self.trees
                    .gain
                    .iter()
                    .map(|g| g / total.max(f64::MIN_POSITIVE)),
            )
            .collect();
        v.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(name: &str, dataset: &str, rows: usize) -> ObjectRecord {
        ObjectRecord {
            name: name.into(),
            dataset: dataset.into(),
            sha256: String::new(),
            points: rows,
            positives: 1,
            rows_used: rows,
            fingerprint: Vec::new(),
        }
    }

    #[test]
    fn one_dataset_keeps_unit_weights() {
        let records = [record("a", "vr", 4000), record("b", "vr", 1234)];
        let d = balance_datasets(&records, &TrainOptions::default()).unwrap();
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].row_weight, 1.0);
    }

    #[test]
    fn datasets_weigh_as_their_weights_say_whatever_their_size() {
        // 44 objects of one dataset against 2 of a lab's own.
        let mut records: Vec<ObjectRecord> = (0..44)
            .map(|i| record(&format!("o{i}"), "vr", 4000))
            .collect();
        records.push(record("p1", "lab", 4000));
        records.push(record("p2", "lab", 3000));
        let total = |d: &[DatasetRecord], name: &str| {
            let r = d.iter().find(|r| r.name == name).unwrap();
            r.rows as f64 * r.row_weight
        };
        let d = balance_datasets(&records, &TrainOptions::default()).unwrap();
        assert!((total(&d, "vr") - total(&d, "lab")).abs() < 1e-6);
        let all_rows: usize = records.iter().map(|r| r.rows_used).sum();
        assert!((total(&d, "vr") + total(&d, "lab") - all_rows as f64).abs() < 1e-6);
        let options = TrainOptions {
            dataset_weights: vec![("lab".into(), 3.0)],
            ..TrainOptions::default()
        };
        let d = balance_datasets(&records, &options).unwrap();
        assert!((total(&d, "lab") / total(&d, "vr") - 3.0).abs() < 1e-9);
        let bad = TrainOptions {
            dataset_weights: vec![("lab".into(), -1.0)],
            ..TrainOptions::default()
        };
        assert!(balance_datasets(&records, &bad).is_err());
    }
}

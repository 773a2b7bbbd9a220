//! Held-out evaluation of the gaze model: for each mesh with per-vertex truth, a model trained
//! without it predicts it, and is scored beside the shape methods, the priors and chance,
//! plain and with the never-shown vertices left out of the negatives.
//!
//! "Without it" is asked three ways: without the object (leave-one-object-out), without its
//! whole dataset (leave-one-dataset-out: the nearest thing to another lab's data), and without
//! its object family (leave-one-category-out, from a categories file: the proxy for transfer
//! when there is one dataset). Feature-group ablations retrain each of those without one
//! group of features, to show which group carries a held-out figure.
use crate::experiments::ExperimentError;
use serde::Serialize;

use std::path::Path;

use rayon::prelude::*;

use crate::gaze_model::features::{
    feature_group, feature_names, point_features, ranks, FeatureMatrix, FEATURE_GROUPS,
};
use crate::gaze_model::surface_points::SurfacePoints;
use crate::gaze_model::{train_model_without, TrainOptions, TrainingObject};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::protocol::ProtocolPerDataset;
use crate::saliency::{compute_saliency_viewed, Method, SmsParams, Viewing};
use crate::scoring::auc::auc_judd;
use crate::scoring::map_agreement::lcc;
use crate::scoring::mesh_score::{auc_judd_seen, chance_maps};
use crate::stimulus::hold_views::hold_view_exposure;

/// A mesh with per-vertex human truth.
pub struct EvaluationMesh {
    /// The mesh's name.
    pub name: String,
    /// The dataset folder it came from (leave-one-dataset-out holds these out together).
    pub dataset: String,
    /// The mesh.
    pub mesh: Mesh,
    /// The human map, one value per vertex.
    pub values: Vec<f64>,
    /// The vertices counted as fixated.
    pub positive: Vec<bool>,
}

/// One method on one held-out mesh.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CvRow {
    /// The held-out mesh.
    pub object: String,
    /// The method (`gaze`, a baseline, `up+mc`, `chance`).
    pub method: String,
    /// AUC-Judd, unblurred.
    pub auc_judd: f64,
    /// AUC-Judd with only vertices some hold view shows as negatives.
    pub auc_judd_visible: f64,
    /// LCC against the human map.
    pub lcc: f64,
}

/// The baselines scored beside the gaze model; `up+mc` (the sum of the two rank maps) and
/// chance (the mean of 20 seeded uniform maps) are added to these.
pub const BASELINES: [Method; 5] = [
    Method::Mc,
    Method::Ms,
    Method::Sms,
    Method::Up,
    Method::Centre,
];

/// What cross-validation measured: the score rows and each held-out mesh's predicted map.
pub struct CvResult {
    /// Leave-one-object-out, every method (the gaze model with every feature).
    pub rows: Vec<CvRow>,
    /// The gaze model under every hold-out scheme and ablation asked for.
    pub held_out: Vec<HeldOutRow>,
    /// (mesh name, the gaze model's map from the fold that held it out).
    pub held_out_maps: Vec<(String, Vec<f64>)>,
}

/// What a fold holds out with the mesh it predicts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scheme {
    /// Each object held out alone (leave-one-object-out).
    Object,
    /// Each dataset held out whole.
    Dataset,
    /// Each object category held out whole.
    Category,
}

impl Scheme {
    /// `object`, `dataset` or `category`.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Object => "object",
            Scheme::Dataset => "dataset",
            Scheme::Category => "category",
        }
    }
}

/// The gaze model on one held-out mesh under one scheme, with one feature group (or none)
/// left out of training.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct HeldOutRow {
    /// `object`, `dataset` or `category`.
    pub held_out_by: String,
    /// The held-out group (the object, its dataset or its category).
    pub group: String,
    /// The held-out mesh.
    pub object: String,
    /// The feature group left out of training, or `none`.
    pub without: String,
    /// AUC-Judd, unblurred.
    pub auc_judd: f64,
    /// AUC-Judd with only vertices some hold view shows as negatives.
    pub auc_judd_visible: f64,
    /// LCC against the human map.
    pub lcc: f64,
}

/// Object name -> category, read from a two-column TSV (`name<TAB>category`, `#` comments).
#[derive(Debug, Clone, Default)]
pub struct Categories {
    /// (object, category) pairs, in file order.
    pub of: Vec<(String, String)>,
}

impl Categories {
    /// The categories file at `path`.
    pub fn read(path: &Path) -> Result<Categories, ExperimentError> {
        let text = std::fs::read_to_string(path).map_err(|error| ExperimentError::Io {
            path: path.to_path_buf(),
            error,
        })?;
        Categories::parse(&text, &path.display().to_string())
    }

    /// Categories from TSV text; `name` labels the errors (name:line).
    pub fn parse(text: &str, name: &str) -> Result<Categories, ExperimentError> {
        let mut of: Vec<(String, String)> = Vec::new();
        for (i, line) in text.lines().enumerate() {
            let line = line.trim_end_matches('\r');
            if line.trim().is_empty() || line.starts_with('#') {
                continue;
            }
            let fields: Vec<&str> = line.split('\t').map(str::trim).collect();
            if fields.len() != 2 || fields.iter().any(|f| f.is_empty()) {
                return Err(ExperimentError::At {
                    name: name.to_string(),
                    line: i + 1,
                    column: 1,
                    message: format!("expected `object<TAB>category`, found {line:?}"),
                });
            }
            if let Some((_, c)) = of.iter().find(|(o, _)| o == fields[0]) {
                return Err(ExperimentError::At {
                    name: name.to_string(),
                    line: i + 1,
                    column: 1,
                    message: format!("`{}` is already in category `{c}`", fields[0]),
                });
            }
            of.push((fields[0].to_string(), fields[1].to_string()));
        }
        if of.is_empty() {
            return Err(ExperimentError::File {
                name: name.to_string(),
                message: "no `object<TAB>category` lines".into(),
            });
        }
        Ok(Categories { of })
    }

    /// The category of `object`, when the file names one.
    pub fn category(&self, object: &str) -> Option<&str> {
        self.of
            .iter()
            .find(|(o, _)| o == object)
            .map(|(_, c)| c.as_str())
    }
}

/// What to hold out beyond single objects.
#[derive(Debug, Clone, Default)]
pub struct CvPlan {
    /// Leave-one-category-out with these categories.
    pub categories: Option<Categories>,
    /// Retrain every scheme without each feature group in turn.
    pub ablations: bool,
}

/// The schemes `plan` asks for on these objects: leave-one-dataset-out only when the objects
/// come from two datasets or more.
pub fn schemes(objects: &[TrainingObject], plan: &CvPlan) -> Vec<Scheme> {
    let mut out = vec![Scheme::Object];
    let first = objects.first().map(|o| o.dataset.as_str());
    if objects.iter().any(|o| Some(o.dataset.as_str()) != first) {
        out.push(Scheme::Dataset);
    }
    if plan.categories.is_some() {
        out.push(Scheme::Category);
    }
    out
}

/// The group `scheme` puts an object or mesh in: its name, its dataset, or its category.
fn group_of(plan: &CvPlan, scheme: Scheme, name: &str, dataset: &str) -> String {
    match scheme {
        Scheme::Object => name.to_string(),
        Scheme::Dataset => dataset.to_string(),
        Scheme::Category => plan
            .categories
            .as_ref()
            .and_then(|c| c.category(name))
            .unwrap_or("")
            .to_string(),
    }
}

/// Refuses a categories file that leaves a training object or held-out mesh without one.
fn check_categories(
    objects: &[TrainingObject],
    meshes: &[EvaluationMesh],
    plan: &CvPlan,
) -> Result<(), ExperimentError> {
    let Some(categories) = &plan.categories else {
        return Ok(());
    };
    let missing: Vec<&str> = objects
        .iter()
        .map(|o| o.name.as_str())
        .chain(meshes.iter().map(|m| m.name.as_str()))
        .filter(|n| categories.category(n).is_none())
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    Err(ExperimentError::Invalid(format!(
        "the categories file names no category for: {}; every training object and held-out mesh needs one",
        missing.join(", ")
    )))
}

/// Every (scheme, held-out group, ablation): one training run each.
fn folds_of(
    schemes: &[Scheme],
    meshes: &[EvaluationMesh],
    plan: &CvPlan,
) -> Vec<(Scheme, String, &'static str)> {
    let withouts: Vec<&'static str> = if plan.ablations {
        std::iter::once("none").chain(FEATURE_GROUPS).collect()
    } else {
        vec!["none"]
    };
    let mut folds = Vec::new();
    for &scheme in schemes {
        let mut groups: Vec<String> = Vec::new();
        for m in meshes {
            let g = group_of(plan, scheme, &m.name, &m.dataset);
            if !groups.contains(&g) {
                groups.push(g);
            }
        }
        for g in groups {
            for &w in &withouts {
                folds.push((scheme, g.clone(), w));
            }
        }
    }
    folds
}

/// One held-out mesh's scores of `map` under `name`.
fn score_row(mesh: &EvaluationMesh, seen: &[bool], name: &str, map: &[f64]) -> CvRow {
    CvRow {
        object: mesh.name.clone(),
        method: name.to_string(),
        auc_judd: auc_judd(map, &mesh.positive, None),
        auc_judd_visible: auc_judd_seen(map, &mesh.positive, seen, None),
        lcc: lcc(map, &mesh.values, None),
    }
}

/// The held-out mesh's rows: the gaze model's held-out map, every baseline, the up+mc rank
/// sum and the mean of 20 seeded chance maps.
fn baseline_rows(
    held: &EvaluationMesh,
    seen: &[bool],
    gaze_map: Vec<f64>,
    viewing: &Viewing,
) -> Result<Vec<CvRow>, ExperimentError> {
    let mut maps: Vec<(String, Vec<f64>)> = vec![("gaze".into(), gaze_map)];
    for method in BASELINES {
        let out = compute_saliency_viewed(
            method,
            &held.mesh,
            &SmsParams::default(),
            viewing,
            &crate::progress::Silent,
        )
        .map_err(|error| ExperimentError::Method {
            what: format!("{}: {}", held.name, method.name()),
            error,
        })?;
        maps.push((method.name().to_string(), out.values));
    }
    let rank_sum: Vec<f64> = {
        let find = |name: &str| &maps.iter().find(|m| m.0 == name).expect("baseline").1;
        let (u, c) = (ranks(find("up")), ranks(find("mc")));
        u.iter().zip(&c).map(|(a, b)| a + b).collect()
    };
    maps.push(("up+mc".into(), rank_sum));
    let mut rows: Vec<CvRow> = maps
        .iter()
        .map(|(name, map)| score_row(held, seen, name, map))
        .collect();
    let chance: Vec<CvRow> = chance_maps(held.mesh.positions.len(), 20, 7)
        .iter()
        .map(|m| score_row(held, seen, "chance", m))
        .collect();
    let mean = |f: fn(&CvRow) -> f64| chance.iter().map(f).sum::<f64>() / chance.len() as f64;
    rows.push(CvRow {
        object: held.name.clone(),
        method: "chance".into(),
        auc_judd: mean(|r| r.auc_judd),
        auc_judd_visible: mean(|r| r.auc_judd_visible),
        lcc: mean(|r| r.lcc),
    });
    Ok(rows)
}

/// Every fold of every scheme of `plan`, and the baselines once per mesh.
pub fn cross_validate(
    objects: &[TrainingObject],
    meshes: &[EvaluationMesh],
    options: &TrainOptions,
    protocols: &ProtocolPerDataset,
    plan: &CvPlan,
    progress: &dyn Progress,
) -> Result<CvResult, ExperimentError> {
    // Each held-out mesh is seen as its own dataset's subjects saw it (its up axis).
    let protocol_of: Vec<_> = meshes
        .iter()
        .map(|m| protocols.for_dataset(&m.dataset))
        .collect();
    let protocol_name = protocols.name();
    check_categories(objects, meshes, plan)?;
    let folds = folds_of(&schemes(objects, plan), meshes, plan);
    progress.start("held-out folds", (folds.len() + meshes.len()) as u64);
    let features: Vec<FeatureMatrix> = meshes
        .par_iter()
        .zip(&protocol_of)
        .map(|(m, protocol)| point_features(&SurfacePoints::of_mesh(&m.mesh), protocol))
        .collect::<Result<_, _>>()?;
    let seen: Vec<Vec<bool>> = meshes
        .iter()
        .zip(&protocol_of)
        .map(|(m, protocol)| hold_view_exposure(&m.mesh, protocol).map(|e| e.seen()))
        .collect::<Result<_, _>>()?;
    let predictions: Vec<Vec<(usize, Vec<f64>)>> = folds
        .par_iter()
        .map(|(scheme, group, without)| {
            let training: Vec<&TrainingObject> = objects
                .iter()
                .filter(|o| group_of(plan, *scheme, &o.name, &o.dataset) != *group)
                .collect();
            let dropped: Vec<String> = if *without == "none" {
                Vec::new()
            } else {
                feature_names()
                    .into_iter()
                    .filter(|n| feature_group(n) == *without)
                    .collect()
            };
            let model = train_model_without(&training, options, &protocol_name, &dropped)?;
            let out = meshes
                .iter()
                .enumerate()
                .filter(|(_, m)| group_of(plan, *scheme, &m.name, &m.dataset) == *group)
                .map(|(i, _)| (i, model.predict_features(&features[i])))
                .collect();
            progress.advance(1);
            Ok(out)
        })
        .collect::<Result<_, ExperimentError>>()?;
    let mut held_out = Vec::new();
    let mut held_out_maps = vec![Vec::new(); meshes.len()];
    for ((scheme, group, without), maps) in folds.iter().zip(predictions) {
        for (i, map) in maps {
            let r = score_row(&meshes[i], &seen[i], "gaze", &map);
            held_out.push(HeldOutRow {
                held_out_by: scheme.name().to_string(),
                group: group.clone(),
                object: r.object,
                without: without.to_string(),
                auc_judd: r.auc_judd,
                auc_judd_visible: r.auc_judd_visible,
                lcc: r.lcc,
            });
            if *scheme == Scheme::Object && *without == "none" {
                held_out_maps[i] = map;
            }
        }
    }
    let mut rows = Vec::new();
    for (i, held) in meshes.iter().enumerate() {
        let viewing = Viewing {
            protocol: protocol_of[i].clone(),
            model: None,
            rarity: Default::default(),
        };
        rows.extend(baseline_rows(
            held,
            &seen[i],
            held_out_maps[i].clone(),
            &viewing,
        )?);
        progress.advance(1);
    }
    progress.finish();
    Ok(CvResult {
        rows,
        held_out,
        held_out_maps: meshes
            .iter()
            .map(|m| m.name.clone())
            .zip(held_out_maps)
            .collect(),
    })
}

/// Mean gaze AUC-Judd (plain, visible) and LCC per (scheme, ablation), in first-seen order,
/// with the number of held-out meshes: the summary of `held_out`.
pub fn held_out_means(rows: &[HeldOutRow]) -> Vec<(String, String, usize, f64, f64, f64)> {
    let mut keys: Vec<(String, String)> = Vec::new();
    for r in rows {
        let k = (r.held_out_by.clone(), r.without.clone());
        if !keys.contains(&k) {
            keys.push(k);
        }
    }
    keys.into_iter()
        .map(|(by, without)| {
            let of: Vec<&HeldOutRow> = rows
                .iter()
                .filter(|r| r.held_out_by == by && r.without == without)
                .collect();
            let k = of.len() as f64;
            let mean = |f: fn(&HeldOutRow) -> f64| of.iter().map(|r| f(r)).sum::<f64>() / k;
            (
                by,
                without,
                of.len(),
                mean(|r| r.auc_judd),
                mean(|r| r.auc_judd_visible),
                mean(|r| r.lcc),
            )
        })
        .collect()
}

/// Mean of each method over the objects, methods in first-seen order.
pub fn mean_rows(rows: &[CvRow]) -> Vec<CvRow> {
    let mut methods: Vec<&str> = Vec::new();
    for r in rows {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    methods
        .iter()
        .map(|m| {
            let of: Vec<&CvRow> = rows.iter().filter(|r| r.method == *m).collect();
            let k = of.len() as f64;
            CvRow {
                object: "mean".into(),
                method: m.to_string(),
                auc_judd: of.iter().map(|r| r.auc_judd).sum::<f64>() / k,
                auc_judd_visible: of.iter().map(|r| r.auc_judd_visible).sum::<f64>() / k,
                lcc: of.iter().map(|r| r.lcc).sum::<f64>() / k,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn categories_are_read_and_bad_lines_named() {
        let c = Categories::parse(
            "# family\nbunny\tanimals\r\njames\thumans and heads\n",
            "c.tsv",
        )
        .unwrap();
        assert_eq!(c.category("bunny"), Some("animals"));
        assert_eq!(c.category("james"), Some("humans and heads"));
        assert_eq!(c.category("cow"), None);
        let e = Categories::parse("bunny\tanimals\ncow animals\n", "c.tsv")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("c.tsv:2:1: expected `object<TAB>category`"),
            "{e}"
        );
        let e = Categories::parse("bunny\tanimals\nbunny\tpets\n", "c.tsv")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("c.tsv:2:1: `bunny` is already in category `animals`"),
            "{e}"
        );
        assert!(Categories::parse("# nothing\n", "c.tsv").is_err());
    }

    proptest! {
        #[test]
        fn the_categories_parser_never_panics(text in "[a-z\t\r\n# ]{0,200}") {
            if let Err(e) = Categories::parse(&text, "c.tsv") {
                prop_assert!(e.to_string().starts_with("c.tsv"));
            }
        }
    }
}

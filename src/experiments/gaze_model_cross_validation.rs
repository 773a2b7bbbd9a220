//! Leave-one-object-out evaluation: for each mesh with per-vertex truth, a model trained on
//! every other object predicts it, and is scored beside the shape methods, the priors and
//! chance, plain and with the never-shown vertices left out of the negatives.
use serde::Serialize;

use crate::gaze_model::features::ranks;
use crate::gaze_model::surface_points::SurfacePoints;
use crate::gaze_model::{train_model, TrainOptions, TrainingObject};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::protocol::Protocol;
use crate::saliency::{compute_saliency_viewed, Method, SmsParams, Viewing};
use crate::scoring::auc::auc_judd;
use crate::scoring::map_agreement::lcc;
use crate::scoring::mesh_score::{auc_judd_seen, chance_maps};
use crate::stimulus::hold_views::hold_view_exposure;

/// A mesh with per-vertex human truth.
pub struct EvaluationMesh {
    pub name: String,
    pub mesh: Mesh,
    pub values: Vec<f64>,
    pub positive: Vec<bool>,
}

/// One method on one held-out mesh.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct CvRow {
    pub object: String,
    pub method: String,
    pub auc_judd: f64,
    /// AUC-Judd with only vertices some hold view shows as negatives.
    pub auc_judd_visible: f64,
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
    pub rows: Vec<CvRow>,
    /// (mesh name, the gaze model's map from the fold that held it out).
    pub held_out_maps: Vec<(String, Vec<f64>)>,
}

pub fn leave_one_object_out(
    objects: &[TrainingObject],
    meshes: &[EvaluationMesh],
    options: &TrainOptions,
    protocol: &Protocol,
    progress: &dyn Progress,
) -> Result<CvResult, String> {
    let viewing = Viewing {
        protocol: protocol.clone(),
        model: None,
        rarity: Default::default(),
    };
    let mut rows = Vec::new();
    let mut held_out_maps = Vec::new();
    progress.start("leave-one-object-out", meshes.len() as u64);
    for held_out in meshes {
        let training: Vec<&TrainingObject> =
            objects.iter().filter(|o| o.name != held_out.name).collect();
        let model = train_model(&training, options, &protocol.name)?;
        let gaze = model.predict(&SurfacePoints::of_mesh(&held_out.mesh), protocol)?;
        let seen = hold_view_exposure(&held_out.mesh, protocol)?.seen();
        held_out_maps.push((held_out.name.clone(), gaze.clone()));
        let mut maps: Vec<(String, Vec<f64>)> = vec![("gaze".into(), gaze)];
        for method in BASELINES {
            let out = compute_saliency_viewed(
                method,
                &held_out.mesh,
                &SmsParams::default(),
                &viewing,
                &crate::progress::Silent,
            )
            .map_err(|e| format!("{}: {}: {e}", held_out.name, method.name()))?;
            maps.push((method.name().to_string(), out.values));
        }
        let rank_sum: Vec<f64> = {
            let find = |name: &str| &maps.iter().find(|m| m.0 == name).expect("baseline").1;
            let (u, c) = (ranks(find("up")), ranks(find("mc")));
            u.iter().zip(&c).map(|(a, b)| a + b).collect()
        };
        maps.push(("up+mc".into(), rank_sum));
        let score = |name: &str, map: &[f64]| CvRow {
            object: held_out.name.clone(),
            method: name.to_string(),
            auc_judd: auc_judd(map, &held_out.positive, None),
            auc_judd_visible: auc_judd_seen(map, &held_out.positive, &seen, None),
            lcc: lcc(map, &held_out.values, None),
        };
        for (name, map) in &maps {
            rows.push(score(name, map));
        }
        let chance: Vec<CvRow> = chance_maps(held_out.mesh.positions.len(), 20, 7)
            .iter()
            .map(|m| score("chance", m))
            .collect();
        let mean = |f: fn(&CvRow) -> f64| chance.iter().map(f).sum::<f64>() / chance.len() as f64;
        rows.push(CvRow {
            object: held_out.name.clone(),
            method: "chance".into(),
            auc_judd: mean(|r| r.auc_judd),
            auc_judd_visible: mean(|r| r.auc_judd_visible),
            lcc: mean(|r| r.lcc),
        });
        progress.advance(1);
    }
    progress.finish();
    Ok(CvResult {
        rows,
        held_out_maps,
    })
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

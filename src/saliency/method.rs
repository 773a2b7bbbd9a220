//! One entry point for every saliency method, so commands can compute any of them by name.
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::lee_mesh_saliency::{lee_mesh_saliency, LeeParams};
use super::mean_curvature_saliency::mean_curvature_saliency;
use super::rarity::{
    global_rarity_saliency, global_rarity_saliency_from, manifold_ranking_saliency,
    manifold_ranking_saliency_from, surface_regions_of_interest, GrParams, MrParams, SriParams,
    ZernikePatches,
};
use super::spectral_irregularity::{spectral_irregularity, SpectralParams};
use super::view_priors::{centre_prior, up_prior};
use super::SaliencyError;
use super::{sparse_metric_saliency, SmsExtras, SmsParams};
use crate::gaze_model::surface_points::SurfacePoints;
use crate::gaze_model::GazeModel;
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::protocol::Protocol;

/// A saliency method: the paper's seven, two view priors, and the learned gaze model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Sparse metric-based saliency (Hu et al. 2020).
    Sms,
    /// Mesh saliency of Lee, Varshney and Jacobs 2005.
    Ms,
    /// Magnitude of mean curvature (Meyer et al. 2003 cotangent estimator).
    Mc,
    /// Spectral irregularity of Song et al. 2014, on a simplified copy.
    Si,
    /// Surface regions of interest of Leifman, Shtrom and Tal 2012 (distinctness,
    /// extremities, association).
    Sri,
    /// Mesh saliency with global rarity of Wu et al. 2013 (local contrast + patch rarity).
    Gr,
    /// Mesh saliency via manifold ranking of unsalient patches, Tao et al. 2015.
    Mr,
    /// Prior: height along the protocol's up axis.
    Up,
    /// Prior: mean closeness to the screen centre over the hold views showing the vertex.
    Centre,
    /// The learned gaze model (built-in, or `--model`).
    Gaze,
}

/// The seven methods the paper compares (its Fig. 6, Tables 1-3 and Fig. 8), in its order:
/// SMS first, then MC, MS, SI and the three global-rarity methods.
pub const PAPER_METHODS: [Method; 7] = [
    Method::Sms,
    Method::Mc,
    Method::Ms,
    Method::Si,
    Method::Sri,
    Method::Mr,
    Method::Gr,
];

impl Method {
    /// Every method, paper methods first.
    pub const ALL: [Method; 10] = [
        Method::Sms,
        Method::Mc,
        Method::Ms,
        Method::Si,
        Method::Sri,
        Method::Mr,
        Method::Gr,
        Method::Up,
        Method::Centre,
        Method::Gaze,
    ];

    /// The method of a name as [`Method::name`] gives it (`sms`, `mc`, ...), case-blind.
    pub fn from_name(name: &str) -> Result<Method, SaliencyError> {
        let wanted = name.trim().to_ascii_lowercase();
        Method::ALL
            .into_iter()
            .find(|m| m.name() == wanted)
            .ok_or_else(|| {
                let names: Vec<&str> = Method::ALL.iter().map(|m| m.name()).collect();
                SaliencyError::Invalid(format!(
                    "unknown method `{name}`: expected one of {}",
                    names.join(", ")
                ))
            })
    }

    /// The short name (`sms`, `mc`, ...) that files, tables and the command line use.
    pub fn name(self) -> &'static str {
        match self {
            Method::Sms => "sms",
            Method::Ms => "ms",
            Method::Mc => "mc",
            Method::Si => "si",
            Method::Sri => "sri",
            Method::Gr => "gr",
            Method::Mr => "mr",
            Method::Up => "up",
            Method::Centre => "centre",
            Method::Gaze => "gaze",
        }
    }
}

/// A per-vertex map in [0, 1] with what the method reports about itself.
pub struct MethodOutput {
    /// One value per input vertex, in input order.
    pub values: Vec<f64>,
    /// The method's parameters and what it reports about its run, for the sidecar.
    pub report: serde_json::Value,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// How the mesh is shown and what model predicts gaze (the inputs of the priors and of the
/// gaze model), and the parameters of the global-rarity competitors.
#[derive(Debug, Clone)]
pub struct Viewing {
    /// The protocol: hold views for the priors and the gaze model's view features.
    pub protocol: Protocol,
    /// None: the built-in model.
    pub model: Option<GazeModel>,
    /// Parameters of SRI, GR and MR.
    pub rarity: RarityParams,
}

/// Parameters of SRI, GR and MR (each defaults to docs/baselines.md's choices).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RarityParams {
    /// SRI (Leifman et al. 2012).
    pub sri: SriParams,
    /// GR (Wu et al. 2013).
    pub gr: GrParams,
    /// MR (Tao et al. 2015).
    pub mr: MrParams,
}

impl RarityParams {
    /// Applies `method.name=value` settings (e.g. `sri.most_similar=32`, `gr.radii=[0.1,0.2]`);
    /// the value is JSON, or a bare number or word.
    pub fn with_settings(&self, settings: &[String]) -> Result<RarityParams, SaliencyError> {
        self.apply_settings(settings)
            .map_err(SaliencyError::Invalid)
    }

    /// [`RarityParams::with_settings`], its refusals as text naming the setting.
    fn apply_settings(&self, settings: &[String]) -> Result<RarityParams, String> {
        let mut tree = serde_json::to_value(self).map_err(|e| e.to_string())?;
        for setting in settings {
            let (key, value) = setting.split_once('=').ok_or_else(|| {
                format!("--set {setting}: expected METHOD.NAME=VALUE, e.g. sri.most_similar=32")
            })?;
            let (method, name) = key.trim().split_once('.').ok_or_else(|| {
                format!("--set {setting}: the name needs its method, e.g. sri.{key}")
            })?;
            let slot = tree
                .get_mut(method)
                .ok_or_else(|| format!("--set {setting}: `{method}` is not one of sri, gr, mr"))?
                .get_mut(name)
                .ok_or_else(|| {
                    let names: Vec<String> = serde_json::to_value(self)
                        .ok()
                        .and_then(|t| {
                            t.get(method)
                                .and_then(|m| m.as_object())
                                .map(|o| o.keys().cloned().collect())
                        })
                        .unwrap_or_default();
                    format!(
                        "--set {setting}: {method} has no parameter `{name}`; it has {}",
                        names.join(", ")
                    )
                })?;
            let value = value.trim();
            *slot = serde_json::from_str(value)
                .unwrap_or_else(|_| serde_json::Value::String(value.to_string()));
            // Checked one setting at a time, so a bad value is reported with its own name.
            serde_json::from_value::<RarityParams>(tree.clone())
                .map_err(|e| format!("--set {setting}: {e}"))?;
        }
        serde_json::from_value(tree).map_err(|e| format!("--set: {e}"))
    }
}

impl Viewing {
    /// The built-in protocol (hu2020) and the built-in gaze model.
    pub fn builtin() -> Viewing {
        Viewing {
            protocol: Protocol::builtin().0,
            model: None,
            rarity: RarityParams::default(),
        }
    }

    /// The gaze model to use: the given one, or the built-in one (parsed only when asked).
    pub fn gaze_model(&self) -> std::borrow::Cow<'_, GazeModel> {
        match &self.model {
            Some(m) => std::borrow::Cow::Borrowed(m),
            None => std::borrow::Cow::Owned(GazeModel::builtin()),
        }
    }
}

/// Computes `method` on `mesh` with its default parameters (SMS with `sms`), shown as the
/// built-in protocol shows it.
pub fn compute_saliency(
    method: Method,
    mesh: &Mesh,
    sms: &SmsParams,
    progress: &dyn Progress,
) -> Result<MethodOutput, SaliencyError> {
    compute_saliency_viewed(method, mesh, sms, &Viewing::builtin(), progress)
}

/// Computes `method` on `mesh`, with `viewing` for the priors and the gaze model.
pub fn compute_saliency_viewed(
    method: Method,
    mesh: &Mesh,
    sms: &SmsParams,
    viewing: &Viewing,
    progress: &dyn Progress,
) -> Result<MethodOutput, SaliencyError> {
    if mesh.triangles.is_empty() {
        return Err(SaliencyError::Compute(format!(
            "{}: the mesh has no triangles, so there is no surface to compute saliency on",
            method.name()
        )));
    }
    compute_nonempty(method, mesh, sms, viewing, progress)
}

/// Several methods on one mesh side by side, in the order given: each is parallel inside but
/// leaves a core idle part of the time, and work-stealing across methods fills the gaps. GR
/// and MR build their working copy, descriptors and patches once when their parameters agree
/// (the defaults do), which their maps do not depend on (the same values as one at a time);
/// each one's seconds then count that shared step too. `on_done` is called as each method
/// finishes.
pub fn compute_saliency_side_by_side(
    methods: &[Method],
    mesh: &Mesh,
    sms: &SmsParams,
    viewing: &Viewing,
    on_done: &(dyn Fn(Method) + Sync),
) -> Vec<Result<MethodOutput, SaliencyError>> {
    use rayon::prelude::*;
    let (gr, mr) = (&viewing.rarity.gr, &viewing.rarity.mr);
    let pair = match (
        methods.iter().position(|&m| m == Method::Gr),
        methods.iter().position(|&m| m == Method::Mr),
    ) {
        // Invalid parameters go the single-method way, which reports them before any work.
        (Some(g), Some(m))
            if gr.zernike_patches() == mr.zernike_patches()
                && gr.validate().is_ok()
                && mr.validate().is_ok() =>
        {
            Some((g, m))
        }
        _ => None,
    };
    let tasks: Vec<Vec<usize>> = (0..methods.len())
        .filter_map(|i| match pair {
            Some((g, m)) if i == g => Some(vec![g, m]),
            Some((_, m)) if i == m => None,
            _ => Some(vec![i]),
        })
        .collect();
    let mut done: Vec<(usize, Result<MethodOutput, SaliencyError>)> = tasks
        .par_iter()
        .flat_map_iter(|task| {
            let outputs = if let [g, m] = task[..] {
                rarity_pair(mesh, gr, mr)
                    .into_iter()
                    .zip([g, m])
                    .map(|(out, i)| (i, out))
                    .collect::<Vec<_>>()
            } else {
                let i = task[0];
                let out = compute_saliency_viewed(
                    methods[i],
                    mesh,
                    sms,
                    viewing,
                    &crate::progress::Silent,
                );
                vec![(i, out)]
            };
            for (i, _) in &outputs {
                on_done(methods[*i]);
            }
            outputs
        })
        .collect();
    done.sort_by_key(|(i, _)| *i);
    done.into_iter().map(|(_, out)| out).collect()
}

/// GR's and MR's maps from one working copy, descriptor set and patch set, the two maps side
/// by side.
fn rarity_pair(
    mesh: &Mesh,
    gr: &GrParams,
    mr: &MrParams,
) -> [Result<MethodOutput, SaliencyError>; 2] {
    let start = Instant::now();
    let shared = if mesh.triangles.is_empty() {
        Err(SaliencyError::Compute(
            "the mesh has no triangles, so there is no surface to compute saliency on".into(),
        ))
    } else {
        ZernikePatches::new(mesh, &gr.zernike_patches())
    };
    let shared = match shared {
        Ok(shared) => shared,
        Err(e) => {
            let text = e.to_string();
            return [
                Err(SaliencyError::Compute(format!("gr: {text}"))),
                Err(SaliencyError::Compute(format!("mr: {text}"))),
            ];
        }
    };
    let shared_seconds = start.elapsed().as_secs_f64();
    let output = |values: Vec<f64>, report: serde_json::Result<serde_json::Value>, t: Instant| {
        Ok(MethodOutput {
            values,
            report: report.map_err(|e| SaliencyError::Compute(e.to_string()))?,
            seconds: shared_seconds + t.elapsed().as_secs_f64(),
        })
    };
    let (g, m) = rayon::join(
        || {
            let t = Instant::now();
            let (v, r) = global_rarity_saliency_from(&shared, gr)?;
            output(v, serde_json::to_value((gr, &r)), t)
        },
        || {
            let t = Instant::now();
            let (v, r) = manifold_ranking_saliency_from(&shared, mr)?;
            output(v, serde_json::to_value((mr, &r)), t)
        },
    );
    [g, m]
}

/// [`compute_saliency_viewed`] on a mesh with triangles; the classical methods' own errors
/// are text (`SaliencyError::Compute`).
fn compute_nonempty(
    method: Method,
    mesh: &Mesh,
    sms: &SmsParams,
    viewing: &Viewing,
    progress: &dyn Progress,
) -> Result<MethodOutput, SaliencyError> {
    let t = Instant::now();
    let (values, report) = match method {
        Method::Sms => {
            let r = sparse_metric_saliency(mesh, sms, SmsExtras::default(), progress)?;
            (r.vertex_saliency, serde_json::to_value(&r.report))
        }
        Method::Ms => {
            progress.start("MS (Lee 2005)", 0);
            let params = LeeParams::default();
            let (v, r) = lee_mesh_saliency(mesh, &params);
            progress.finish();
            (v, serde_json::to_value((&params, &r)))
        }
        Method::Mc => {
            let (v, r) = mean_curvature_saliency(mesh);
            (v, serde_json::to_value(&r))
        }
        Method::Si => {
            progress.start("SI (Song 2014)", 0);
            let params = SpectralParams::default();
            let (v, r) = spectral_irregularity(mesh, &params)?;
            progress.finish();
            (v, serde_json::to_value((&params, &r)))
        }
        Method::Sri => {
            progress.start("SRI (Leifman 2012)", 0);
            let params = &viewing.rarity.sri;
            let (v, r) = surface_regions_of_interest(mesh, params)?;
            progress.finish();
            (v, serde_json::to_value((params, &r)))
        }
        Method::Gr => {
            progress.start("GR (Wu 2013)", 0);
            let params = &viewing.rarity.gr;
            let (v, r) = global_rarity_saliency(mesh, params)?;
            progress.finish();
            (v, serde_json::to_value((params, &r)))
        }
        Method::Mr => {
            progress.start("MR (Tao 2015)", 0);
            let params = &viewing.rarity.mr;
            let (v, r) = manifold_ranking_saliency(mesh, params)?;
            progress.finish();
            (v, serde_json::to_value((params, &r)))
        }
        Method::Up => (
            up_prior(mesh, &viewing.protocol),
            Ok(
                serde_json::json!({"up": viewing.protocol.viewpoints.up, "protocol": viewing.protocol.name}),
            ),
        ),
        Method::Centre => (
            centre_prior(mesh, &viewing.protocol)?,
            Ok(
                serde_json::json!({"protocol": viewing.protocol.name, "display": [viewing.protocol.display.width_px, viewing.protocol.display.height_px]}),
            ),
        ),
        Method::Gaze => {
            progress.start("gaze model", 0);
            let m = viewing.gaze_model();
            let mut v = m.predict(&SurfacePoints::of_mesh(mesh), &viewing.protocol)?;
            super::sms::gaussian_interpolation::min_max_normalize(&mut v);
            // A map of one of the model's own training objects is a training-set prediction;
            // the sidecar says so, whatever the file is called.
            let training_object =
                crate::gaze_model::object_fingerprint::training_object_in(&m, mesh)
                    .map(|(o, _)| o.name.clone());
            progress.finish();
            (
                v,
                Ok(serde_json::json!({
                    "protocol": viewing.protocol.name,
                    "mesh_is_training_object": training_object,
                    "model_trained_on": m.training.objects.iter().map(|o| &o.name).collect::<Vec<_>>(),
                    "model_sha256": crate::provenance::sha256_hex(m.to_json().as_bytes()),
                    "trees": m.trees.trees.len(),
                })),
            )
        }
    };
    Ok(MethodOutput {
        values,
        report: report.map_err(|e| SaliencyError::Compute(e.to_string()))?,
        seconds: t.elapsed().as_secs_f64(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_reads_back_from_its_name_and_an_unknown_name_lists_them() {
        for m in Method::ALL {
            assert_eq!(Method::from_name(m.name()).ok(), Some(m));
            assert_eq!(Method::from_name(&m.name().to_uppercase()).ok(), Some(m));
        }
        let e = Method::from_name("curvature").unwrap_err().to_string();
        assert!(e.contains("curvature") && e.contains("sms, mc, ms"), "{e}");
    }

    /// Side by side, with GR and MR sharing their inputs, every map is the one the method
    /// computes alone, in the order asked for; GR given MR's inputs built otherwise refuses.
    #[test]
    fn side_by_side_maps_equal_one_at_a_time() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("stimuli/meshes/bun_zipper_res2.ply");
        let (mesh, _) = crate::mesh::load_mesh(&path).unwrap();
        let mut viewing = Viewing::builtin();
        viewing.rarity.gr.vertices = 1500;
        viewing.rarity.mr.vertices = 1500;
        let methods = [Method::Mr, Method::Mc, Method::Gr];
        let sms = SmsParams::default();
        let alone = |m: Method| {
            compute_saliency_viewed(m, &mesh, &sms, &viewing, &crate::progress::Silent)
                .unwrap()
                .values
        };
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let done = std::sync::atomic::AtomicUsize::new(0);
        let together = compute_saliency_side_by_side(&methods, &mesh, &sms, &viewing, &|_| {
            done.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        });
        assert_eq!(done.into_inner(), 3);
        for (m, out) in methods.iter().zip(&together) {
            let out = out.as_ref().unwrap();
            assert_eq!(bits(&out.values), bits(&alone(*m)), "{}", m.name());
            assert!(out.seconds > 0.0);
        }
        // A GR parameter out of range is reported as GR alone reports it; MR still runs.
        let mut wrong = viewing.clone();
        wrong.rarity.gr.local_weight = 2.0;
        let out = compute_saliency_side_by_side(&methods, &mesh, &sms, &wrong, &|_| {});
        let error_of = |r: &Result<MethodOutput, SaliencyError>| match r {
            Err(e) => e.to_string(),
            Ok(_) => "no error".to_string(),
        };
        let alone_error = error_of(&compute_saliency_viewed(
            Method::Gr,
            &mesh,
            &sms,
            &wrong,
            &crate::progress::Silent,
        ));
        assert!(alone_error.contains("local_weight"), "{alone_error}");
        assert_eq!(error_of(&out[2]), alone_error);
        assert_eq!(
            bits(&out[0].as_ref().unwrap().values),
            bits(&alone(Method::Mr))
        );
        let mut other = viewing.rarity.mr.zernike_patches();
        other.patches += 1;
        let shared = ZernikePatches::new(&mesh, &other).unwrap();
        let refused = global_rarity_saliency_from(&shared, &viewing.rarity.gr).unwrap_err();
        assert!(
            refused.to_string().contains("gr: the shared working copy"),
            "{refused}"
        );
    }
}

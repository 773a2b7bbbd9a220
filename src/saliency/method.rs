//! One entry point for every saliency method, so commands can compute any of them by name.
use std::time::Instant;

use serde::{Deserialize, Serialize};

use super::lee_mesh_saliency::{lee_mesh_saliency, LeeParams};
use super::mean_curvature_saliency::mean_curvature_saliency;
use super::spectral_irregularity::{spectral_irregularity, SpectralParams};
use super::{sparse_metric_saliency, SmsExtras, SmsParams};
use crate::mesh::Mesh;
use crate::progress::Progress;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, clap::ValueEnum)]
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
}

impl Method {
    pub fn name(self) -> &'static str {
        match self {
            Method::Sms => "sms",
            Method::Ms => "ms",
            Method::Mc => "mc",
            Method::Si => "si",
        }
    }
}

/// A per-vertex map in [0, 1] with what the method reports about itself.
pub struct MethodOutput {
    pub values: Vec<f64>,
    pub report: serde_json::Value,
    pub seconds: f64,
}

/// Computes `method` on `mesh` with its default parameters (SMS with `sms`).
pub fn compute_saliency(
    method: Method,
    mesh: &Mesh,
    sms: &SmsParams,
    progress: &dyn Progress,
) -> Result<MethodOutput, String> {
    if mesh.triangles.is_empty() {
        return Err(format!(
            "{}: the mesh has no triangles, so there is no surface to compute saliency on",
            method.name()
        ));
    }
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
    };
    Ok(MethodOutput {
        values,
        report: report.map_err(|e| e.to_string())?,
        seconds: t.elapsed().as_secs_f64(),
    })
}

//! Scoring over a dataset: pairing meshes with their truth files by name, the per-mesh
//! entries, the mean over meshes, and the score table as CSV rows and Markdown.
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::{quantile, MethodSummary, ScoreRow};
use crate::mesh::{LoadReport, MeshFormat};

/// A mesh's name: its file name up to the first dot (`bunny.ply.gz` → `bunny`), the rule a
/// study and the viewer name meshes by.
pub use crate::file_bytes::stem_of as mesh_stem;

/// Why a dataset folder's meshes and truths could not be paired.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// `meshes/` or `truth/` could not be listed.
    #[error("cannot read {}: {cause}", folder.display())]
    Unreadable {
        /// The folder.
        folder: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
    },
    /// A mesh has no truth file of its name.
    #[error("{}: no truth file named {name}_* or {name}.* in {}", mesh.display(), truth_dir.display())]
    NoTruth {
        /// The mesh file.
        mesh: PathBuf,
        /// Its stem, the name a truth file must start with.
        name: String,
        /// The truth folder.
        truth_dir: PathBuf,
    },
    /// A mesh's name matches more than one truth file.
    #[error("{}: several truth files match {name}: {matches:?}", mesh.display())]
    SeveralTruths {
        /// The mesh file.
        mesh: PathBuf,
        /// Its stem.
        name: String,
        /// The truth files that match it.
        matches: Vec<PathBuf>,
    },
    /// `meshes/` holds no mesh file.
    #[error("{}: no meshes found", folder.display())]
    NoMeshes {
        /// The folder.
        folder: PathBuf,
    },
}

/// One mesh's scores, as score.json lists them.
#[derive(Serialize)]
pub struct MeshEntry {
    /// The mesh's name (its file stem).
    pub mesh: String,
    /// What the mesh reader found.
    pub load: LoadReport,
    /// `vertex_map` or `fixations`.
    pub truth_kind: &'static str,
    /// Positive vertices of the truth.
    pub positives: usize,
    /// Fixations of a fixation set (0 for a map).
    pub fixations: usize,
    /// Subject splits behind the human ceiling.
    pub human_splits: usize,
    /// Seconds each computed method took (wall time: the methods run side by side, so each
    /// shares the cores with the others, and GR and MR each count the working copy,
    /// descriptors and patches they share; `meshgaze saliency` or `bench` times one alone).
    pub seconds_per_method: Vec<(String, f64)>,
    /// One summary per map.
    pub summaries: Vec<MethodSummary>,
    /// Every chance map's AUC-Judd per blur ([`crate::scoring::MeshScore::chance_auc_judd`]).
    #[serde(skip)]
    pub chance_auc_judd: Vec<(f64, Vec<f64>)>,
}

/// Pairs DIR/meshes/NAME.* with DIR/truth/NAME[_.]*.
pub fn dataset_pairs(dir: &Path) -> Result<Vec<(String, PathBuf, PathBuf)>, DatasetError> {
    let meshes_dir = dir.join("meshes");
    let truth_dir = dir.join("truth");
    let list = |d: &Path| -> Result<Vec<PathBuf>, DatasetError> {
        let mut v: Vec<PathBuf> = std::fs::read_dir(d)
            .map_err(|cause| DatasetError::Unreadable {
                folder: d.to_path_buf(),
                cause,
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        v.sort();
        Ok(v)
    };
    let truths = list(&truth_dir)?;
    let mut pairs = Vec::new();
    for mesh in list(&meshes_dir)? {
        if MeshFormat::from_path(&mesh).is_none() {
            continue;
        }
        let name = mesh_stem(&mesh);
        let matches: Vec<&PathBuf> = truths
            .iter()
            .filter(|t| {
                let f = t.file_name().unwrap_or_default().to_string_lossy();
                f.starts_with(&format!("{name}_")) || f.starts_with(&format!("{name}."))
            })
            .collect();
        match matches.as_slice() {
            [t] => pairs.push((name, mesh.clone(), (*t).clone())),
            [] => {
                return Err(DatasetError::NoTruth {
                    mesh: mesh.clone(),
                    name,
                    truth_dir,
                })
            }
            _ => {
                return Err(DatasetError::SeveralTruths {
                    mesh: mesh.clone(),
                    matches: matches.into_iter().cloned().collect(),
                    name,
                })
            }
        }
    }
    if pairs.is_empty() {
        return Err(DatasetError::NoMeshes { folder: meshes_dir });
    }
    Ok(pairs)
}

/// The mean of each method's summary over meshes (methods of the first mesh, in its order).
pub fn mean_summaries(entries: &[MeshEntry]) -> Vec<MethodSummary> {
    let Some(first) = entries.first() else {
        return Vec::new();
    };
    first
        .summaries
        .iter()
        .map(|s| {
            let all: Vec<&MethodSummary> = entries
                .iter()
                .filter_map(|e| e.summaries.iter().find(|x| x.method == s.method))
                .collect();
            let mean = |f: &dyn Fn(&MethodSummary) -> f64| {
                all.iter().map(|x| f(x)).sum::<f64>() / all.len() as f64
            };
            // The band of the mean at each mesh's own peak blur: draw j averaged over meshes.
            let mut draw_means: Vec<f64> = Vec::new();
            for e in entries {
                let Some(x) = e.summaries.iter().find(|x| x.method == s.method) else {
                    continue;
                };
                let draws = e
                    .chance_auc_judd
                    .iter()
                    .find(|(b, _)| *b == x.auc_judd_peak_blur)
                    .map(|(_, d)| d.as_slice())
                    .unwrap_or(&[]);
                if draw_means.is_empty() {
                    draw_means = vec![0.0; draws.len()];
                }
                if draws.len() != draw_means.len() {
                    draw_means.clear();
                    break;
                }
                for (a, d) in draw_means.iter_mut().zip(draws) {
                    *a += d / all.len() as f64;
                }
            }
            MethodSummary {
                method: s.method.clone(),
                auc_judd_unblurred: mean(&|x| x.auc_judd_unblurred),
                auc_judd_visible_unblurred: mean(&|x| x.auc_judd_visible_unblurred),
                auc_judd_peak: mean(&|x| x.auc_judd_peak),
                auc_judd_peak_blur: mean(&|x| x.auc_judd_peak_blur),
                chance_auc_judd_at_peak: mean(&|x| x.chance_auc_judd_at_peak),
                chance_auc_judd_low_at_peak: quantile(&draw_means, 0.025),
                chance_auc_judd_high_at_peak: quantile(&draw_means, 0.975),
                lcc_unblurred: mean(&|x| x.lcc_unblurred),
                lcc_peak: mean(&|x| x.lcc_peak),
                lcc_peak_blur: mean(&|x| x.lcc_peak_blur),
                nss_unblurred: mean(&|x| x.nss_unblurred),
                gini_unblurred: mean(&|x| x.gini_unblurred),
            }
        })
        .collect()
}

/// The header of the score CSV (`mesh,method,metric,blur,value`).
pub const SCORE_CSV_HEADER: &str = "mesh,method,metric,blur,value";

/// Writes one mesh's score rows under [`SCORE_CSV_HEADER`].
pub fn write_score_rows(
    out: &mut impl Write,
    mesh: &str,
    rows: &[ScoreRow],
) -> std::io::Result<()> {
    for r in rows {
        writeln!(
            out,
            "{mesh},{},{},{},{}",
            r.method, r.metric, r.blur, r.value
        )?;
    }
    Ok(())
}

/// The Markdown table of AUC-Judd and LCC, unblurred and at the peak, per mesh and mean.
pub fn score_table_markdown(entries: &[MeshEntry], mean: &[MethodSummary]) -> String {
    let mut t = String::new();
    t.push_str("| mesh | method | AUC-Judd σ=0 | shown only σ=0 | AUC-Judd peak (σ_b) | chance at that σ_b [95%] | LCC σ=0 | LCC peak (σ_b) |\n");
    t.push_str("|---|---|---:|---:|---:|---:|---:|---:|\n");
    let row = |t: &mut String, mesh: &str, s: &MethodSummary| {
        let shown = if s.auc_judd_visible_unblurred.is_finite() {
            format!("{:.3}", s.auc_judd_visible_unblurred)
        } else {
            "—".to_string()
        };
        t.push_str(&format!(
            "| {mesh} | {} | {:.3} | {shown} | {:.3} ({:.2}) | {:.3} [{:.3}, {:.3}] | {:.3} | {:.3} ({:.2}) |\n",
            s.method,
            s.auc_judd_unblurred,
            s.auc_judd_peak,
            s.auc_judd_peak_blur,
            s.chance_auc_judd_at_peak,
            s.chance_auc_judd_low_at_peak,
            s.chance_auc_judd_high_at_peak,
            s.lcc_unblurred,
            s.lcc_peak,
            s.lcc_peak_blur
        ))
    };
    for e in entries {
        for s in &e.summaries {
            row(&mut t, &e.mesh, s);
        }
    }
    if entries.len() > 1 {
        for s in mean {
            row(&mut t, "**mean**", s);
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(method: &str, auc: f64) -> MethodSummary {
        MethodSummary {
            method: method.into(),
            auc_judd_unblurred: auc,
            auc_judd_visible_unblurred: auc - 0.01,
            auc_judd_peak: auc + 0.1,
            auc_judd_peak_blur: 0.05,
            chance_auc_judd_at_peak: 0.5,
            chance_auc_judd_low_at_peak: f64::NAN,
            chance_auc_judd_high_at_peak: f64::NAN,
            lcc_unblurred: 0.1,
            lcc_peak: 0.2,
            lcc_peak_blur: 0.1,
            nss_unblurred: 0.3,
            gini_unblurred: 0.4,
        }
    }

    fn entry(mesh: &str, auc: f64, draws: Vec<f64>) -> MeshEntry {
        MeshEntry {
            mesh: mesh.into(),
            load: LoadReport::default(),
            truth_kind: "vertex_map",
            positives: 1,
            fixations: 1,
            human_splits: 0,
            seconds_per_method: Vec::new(),
            summaries: vec![summary("mc", auc)],
            chance_auc_judd: vec![(0.05, draws)],
        }
    }

    #[test]
    fn the_table_is_one_markdown_table_and_the_mean_band_pairs_draws_across_meshes() {
        let entries = [
            entry("a", 0.6, (0..20).map(|j| 0.4 + 0.01 * j as f64).collect()),
            entry("b", 0.8, (0..20).map(|j| 0.6 - 0.01 * j as f64).collect()),
        ];
        let mean = mean_summaries(&entries);
        assert!((mean[0].auc_judd_unblurred - 0.7).abs() < 1e-12);
        // Draw j of a plus draw j of b is always 1.0: the band of the mean has no width.
        assert!((mean[0].chance_auc_judd_low_at_peak - 0.5).abs() < 1e-12);
        assert!((mean[0].chance_auc_judd_high_at_peak - 0.5).abs() < 1e-12);
        let t = score_table_markdown(&entries, &mean);
        let lines: Vec<&str> = t.lines().collect();
        assert_eq!(
            lines.len(),
            2 + 2 + 1,
            "header, separator, 2 meshes, mean:\n{t}"
        );
        assert!(lines[0].starts_with("| mesh |") && lines[1].starts_with("|---|"));
        assert!(lines.iter().all(|l| l.starts_with('|') && l.ends_with('|')));
        assert!(lines[4].contains("0.500 [0.500, 0.500]"), "{}", lines[4]);
    }
}

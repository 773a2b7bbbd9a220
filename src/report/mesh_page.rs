//! One mesh's page of a study: its scores with the chance band, its subjects' fixation fates,
//! the AUC and Lorenz charts, and the maps painted on the mesh beside the fixation density.
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::html::{esc, fmt3, png_data_uri, thumbnail};
use super::map_render::render_map;
use super::score_plots::write_score_plots;
use super::viewer::{viewer_fragment, ViewerInput, ViewerLimits};
use super::ReportError;
use crate::file_bytes::create_output_dir;
use crate::projection::table::ProjectedRow;
use crate::scoring::MeshScore;
use crate::stimulus::load::LoadedStimulus;

/// What one mesh's page shows.
pub struct MeshPage<'a> {
    pub name: &'a str,
    pub stim: &'a LoadedStimulus,
    pub maps: &'a [(String, Vec<f64>)],
    pub score: &'a MeshScore,
    /// The blurred fixation density, one value per vertex.
    pub density: &'a [f64],
    /// truth.json of the mesh, as written by the truth step.
    pub truth_json: &'a serde_json::Value,
    /// The truth's fixations (truth.csv rows), drawn as dots in the 3D viewer.
    pub fixations: &'a [ProjectedRow],
    /// (label, path relative to the page) of the files behind the page.
    pub links: &'a [(String, String)],
}

/// Writes DIR/NAME.html with its charts as DIR/NAME.auc.png and DIR/NAME.lorenz.png.
pub fn write_mesh_page(dir: &Path, page: &MeshPage) -> Result<PathBuf, ReportError> {
    create_output_dir(dir).map_err(ReportError::stage)?;
    write_score_plots(&dir.join("chart"), page.name, page.maps, page.score)?;
    let mut h = String::new();
    write!(
        h,
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>{0}: meshgaze study</title><style>{STYLE}</style></head><body><p><a href=\"../report.html\">← study</a></p><h1>{0}</h1>",
        esc(page.name)
    )?;
    h += &summary_table(page.score);
    h += &fates_table(page.truth_json);
    h += "<h2>In 3D</h2><p>Turn the mesh, colour it by each map or the fixation density, see every subject's fixations; the numbered buttons show exactly what the subjects saw at each hold of the video.</p>";
    let blur = page
        .truth_json
        .get("blur")
        .and_then(|b| b.as_f64())
        .unwrap_or(f64::NAN);
    h += &viewer_fragment(
        &ViewerInput {
            title: page.name.to_string(),
            mesh: &page.stim.mesh,
            maps: page.maps.to_vec(),
            truth_density: Some((page.density.to_vec(), blur)),
            fixations: page.fixations.to_vec(),
            stimulus: Some((&page.stim.plan, page.stim.fps)),
        },
        &ViewerLimits::default(),
    )?;
    write!(
        h,
        "<h2>AUC-Judd over blur</h2><p>Each map blurred over the surface; the grey band holds 95% of {} seeded random maps blurred the same way; black: one half of the subjects predicting the other.</p><div class=\"grid\"><img alt=\"AUC over blur\" src=\"chart.{1}.auc.png\"><img alt=\"Lorenz curves\" src=\"chart.{1}.lorenz.png\"></div>",
        page.score.chance_auc_judd.first().map_or(0, |c| c.1.len()),
        esc(page.name)
    )?;
    h += "<h2>Maps on the mesh</h2><p>Colours run blue to red from the 1st to the 99th percentile of each map (the colour bar along the bottom), so a few extreme vertices do not flatten the rest. Viewpoints 1 and 2 of the protocol.</p><div class=\"grid\">";
    let views = page.stim.protocol.viewpoints.count.min(2);
    let named = std::iter::once(("fixation density", page.density))
        .chain(page.maps.iter().map(|(n, m)| (n.as_str(), m.as_slice())));
    for (label, values) in named {
        for v in 0..views {
            let img = render_map(
                &page.stim.mesh,
                &page.stim.plan,
                &page.stim.protocol,
                values,
                v,
            );
            write!(
                h,
                "<figure><img alt=\"{0}\" src=\"{1}\"><figcaption>{0}, viewpoint {2}</figcaption></figure>",
                esc(label),
                png_data_uri(&thumbnail(&img, 420))?,
                v + 1
            )?;
        }
    }
    h += "</div><h2>Files</h2><ul>";
    for (label, href) in page.links {
        write!(h, "<li><a href=\"{}\">{}</a></li>", esc(href), esc(label))?;
    }
    h += "</ul></body></html>\n";
    let path = dir.join(format!("{}.html", page.name));
    std::fs::write(&path, h).map_err(ReportError::io("write", &path))?;
    Ok(path)
}

fn summary_table(score: &MeshScore) -> String {
    let mut t = String::from("<h2>Scores</h2><table><tr><th>method</th><th>AUC-Judd σ<sub>b</sub>=0</th><th>shown only σ<sub>b</sub>=0</th><th>AUC-Judd peak (σ<sub>b</sub>)</th><th>chance there: mean [95%]</th><th>LCC σ<sub>b</sub>=0</th><th>NSS σ<sub>b</sub>=0</th><th>Gini</th></tr>");
    for s in &score.summaries {
        let _ = write!(
            t,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{} ({:.2})</td><td>{} [{}, {}]</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&s.method),
            fmt3(s.auc_judd_unblurred),
            fmt3(s.auc_judd_visible_unblurred),
            fmt3(s.auc_judd_peak),
            s.auc_judd_peak_blur,
            fmt3(s.chance_auc_judd_at_peak),
            fmt3(s.chance_auc_judd_low_at_peak),
            fmt3(s.chance_auc_judd_high_at_peak),
            fmt3(s.lcc_unblurred),
            fmt3(s.nss_unblurred),
            fmt3(s.gini_unblurred)
        );
    }
    t += "</table>";
    t
}

/// The fate names in the order a fixation meets them.
pub const FATES: [&str; 7] = [
    "hit",
    "snapped",
    "background",
    "off-screen",
    "in-transition",
    "invalid",
    "filtered",
];

fn fates_table(truth: &serde_json::Value) -> String {
    let mut t = format!(
        "<h2>Fixations per subject</h2><p>The protocol keeps {} per subject; a kept fixation is on the mesh when its ray hits it (<em>hit</em>) or lands within the snap radius (<em>snapped</em>). Human ceiling (split-half AUC-Judd): {} unblurred, {} at its peak.</p><table><tr><th>subject</th><th>on mesh</th>",
        truth["expected_per_subject"],
        fmt3(truth["human_auc_judd_unblurred"].as_f64().unwrap_or(f64::NAN)),
        fmt3(truth["human_auc_judd_peak"].as_f64().unwrap_or(f64::NAN)),
    );
    for f in FATES {
        let _ = write!(t, "<th>{f}</th>");
    }
    t += "</tr>";
    if let Some(subjects) = truth["subjects"].as_object() {
        for (name, s) in subjects {
            let _ = write!(t, "<tr><td>{}</td><td>{}</td>", esc(name), s["on_mesh"]);
            for f in FATES {
                let _ = write!(t, "<td>{}</td>", s["fates"][f].as_u64().unwrap_or(0));
            }
            t += "</tr>";
        }
    }
    t += "</table>";
    t
}

pub(crate) const STYLE: &str = "body{font-family:sans-serif;max-width:1300px;margin:auto;padding:1em}table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 7px;text-align:right}td:first-child,th:first-child{text-align:left}.grid{display:grid;grid-template-columns:1fr 1fr 1fr;gap:8px}.grid img{width:100%}figure{margin:0}figcaption{font-size:90%;color:#444}";

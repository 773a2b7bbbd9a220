//! report.html for the demo: one self-contained file (images inlined as base64 PNG) that
//! opens offline in any browser.
use std::fmt::Write as _;
use std::path::Path;

use super::ReportError;

type Result<T, E = ReportError> = std::result::Result<T, E>;
use image::{Rgb, RgbImage};

use super::html::{esc, file_data_uri, fmt3, png_data_uri, thumbnail};
use super::map_render::render_map;
use super::viewer::{viewer_fragment, ViewerInput, ViewerLimits};
use crate::projection::ProjectionFate;
use crate::scoring::MeshScore;
use crate::stimulus::camera::Phase;
use crate::stimulus::load::LoadedStimulus;

use crate::truth::TruthResult;

pub struct StepTiming {
    pub name: String,
    pub seconds: f64,
    pub outputs: String,
}

pub struct ReportInputs<'a> {
    pub out_dir: &'a Path,
    pub stim: &'a LoadedStimulus,
    pub truth: &'a TruthResult,
    pub maps: &'a [(String, Vec<f64>)],
    pub method_seconds: &'a [(String, f64)],
    pub score: &'a MeshScore,
    pub plots: &'a [String],
    pub steps: &'a [StepTiming],
    pub total_seconds: f64,
}

const SUBJECT_COLORS: [[u8; 3]; 8] = [
    [230, 25, 75],
    [60, 180, 75],
    [255, 225, 25],
    [0, 130, 200],
    [245, 130, 48],
    [145, 30, 180],
    [70, 240, 240],
    [240, 50, 230],
];

fn disc(img: &mut RgbImage, cx: f64, cy: f64, r: f64, color: [u8; 3], ring: bool) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    let r_out = r + 2.0;
    for y in (cy - r_out).floor() as i64..=(cy + r_out).ceil() as i64 {
        for x in (cx - r_out).floor() as i64..=(cx + r_out).ceil() as i64 {
            if x < 0 || y < 0 || x >= w || y >= h {
                continue;
            }
            let d = ((x as f64 + 0.5 - cx).powi(2) + (y as f64 + 0.5 - cy).powi(2)).sqrt();
            let c = if d <= r && !(ring && d < r - 3.0) {
                Some(color)
            } else if d <= r_out && d > r {
                Some([0, 0, 0]) // outline, so dots read on any background
            } else {
                None
            };
            if let Some(c) = c {
                img.put_pixel(x as u32, y as u32, Rgb(c));
            }
        }
    }
}

fn cross(img: &mut RgbImage, cx: f64, cy: f64, r: f64, color: [u8; 3]) {
    let (w, h) = (img.width() as i64, img.height() as i64);
    for k in -(r as i64)..=(r as i64) {
        for t in -1..=1 {
            for (x, y) in [
                (cx as i64 + k + t, cy as i64 + k),
                (cx as i64 + k + t, cy as i64 - k),
            ] {
                if x >= 0 && y >= 0 && x < w && y < h {
                    img.put_pixel(x as u32, y as u32, Rgb(color));
                }
            }
        }
    }
}

pub fn write_report(path: &Path, r: &ReportInputs) -> Result<()> {
    let subjects: Vec<String> = r.truth.sidecar.subjects.keys().cloned().collect();
    let mut html = header(r, subjects.len());
    html += &pipeline_section(r)?;
    html += &keyframes_section(r)?;
    html += &fates_section(r)?;
    html += &checks_section(r)?;
    html += &maps_section(r)?;
    html += &viewer_section(r)?;
    html += &scores_section(r)?;
    html += &provenance_section(r)?;
    std::fs::write(path, html).map_err(ReportError::io("write", path))?;
    Ok(())
}

/// The page's head, style and introduction.
fn header(r: &ReportInputs, n_subjects: usize) -> String {
    let mut html = String::new();
    let _ = write!(
        html,
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>meshgaze demo report</title>
<style>
body {{ font-family: system-ui, -apple-system, "Segoe UI", sans-serif; max-width: 1200px; margin: 2em auto; padding: 0 1em; color: #222; line-height: 1.45; }}
h1 {{ margin-bottom: 0.2em; }} h2 {{ border-bottom: 1px solid #ccc; padding-bottom: 0.2em; margin-top: 2em; }}
table {{ border-collapse: collapse; margin: 0.8em 0; }} td, th {{ border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: right; }}
th {{ background: #f3f3f3; }} td:first-child, th:first-child {{ text-align: left; }}
.grid {{ display: grid; grid-template-columns: repeat(auto-fill, minmax(270px, 1fr)); gap: 10px; }}
.grid figure, .maps figure {{ margin: 0; }} figure img {{ width: 100%; border: 1px solid #ddd; }}
figcaption {{ font-size: 0.85em; color: #555; }}
.maps {{ display: grid; grid-template-columns: repeat(4, 1fr); gap: 10px; }}
.note {{ background: #fff8e1; border-left: 4px solid #f0b400; padding: 0.6em 1em; }}
code, pre {{ background: #f6f6f6; }} pre {{ padding: 0.6em; overflow-x: auto; font-size: 0.85em; }}
.swatch {{ display: inline-block; width: 0.9em; height: 0.9em; border: 1px solid #000; vertical-align: middle; margin-right: 0.3em; }}
</style></head><body>
<h1>meshgaze demo: the Stanford bunny, end to end</h1>
<p>meshgaze {version} rendered the stimulus, simulated {n_subj} observers, ingested their
SMI recordings, projected their fixations onto the mesh, built the ground truth, computed three
saliency maps and scored them, in {total:.1} s. Every number below comes from files in this folder.</p>
<p class="note"><b>The observers are simulated.</b> They favour protruding parts of the bunny (a
target model independent of all three saliency methods) with the accuracy of an SMI RED250
(0.4°). The scores show the pipeline at work; they say nothing about how people look at bunnies.
For real data, replace step 2 with your lab's SMI exports (<code>meshgaze ingest</code>).</p>
"#,
        version = env!("CARGO_PKG_VERSION"),
        n_subj = n_subjects,
        total = r.total_seconds
    );

    html
}

/// The steps, their seconds and their outputs.
fn pipeline_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    html += "<h2>Pipeline</h2><table><tr><th>step</th><th>seconds</th><th>outputs (in this folder)</th></tr>";
    for s in r.steps {
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{:.2}</td><td style=\"text-align:left\">{}</td></tr>",
            esc(&s.name),
            s.seconds,
            esc(&s.outputs)
        );
    }
    html += "</table>";

    Ok(html)
}

/// The first frame of each hold with the fixations made while it was held.
fn keyframes_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    let (stim, rows) = (r.stim, &r.truth.rows);
    let subjects: Vec<String> = r.truth.sidecar.subjects.keys().cloned().collect();
    let color_of = |s: &str| {
        SUBJECT_COLORS[subjects.iter().position(|x| x == s).unwrap_or(0) % SUBJECT_COLORS.len()]
    };
    html += "<h2>Stimulus keyframes and the fixations made while each view was held</h2>";
    html += "<p>Each thumbnail is the first frame of a 3 s hold. Dots are the filtered fixations (15 per subject) whose camera was that hold: filled = hit the mesh, ring = snapped to it, cross = on the background. Colour = subject: ";
    for s in &subjects {
        let c = color_of(s);
        let _ = write!(
            html,
            "<span class=\"swatch\" style=\"background:rgb({},{},{})\"></span>{} ",
            c[0],
            c[1],
            c[2],
            esc(s)
        );
    }
    html += "</p><div class=\"grid\">";
    let frames_dir = stim
        .manifest_path
        .parent()
        .unwrap_or(Path::new("."))
        .join("frames");
    let mut keyframes: Vec<_> = std::fs::read_dir(&frames_dir)
        .map_err(ReportError::io("list", &frames_dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with("frame_"))
        })
        .collect();
    keyframes.sort();
    for (v, kf) in keyframes.iter().enumerate() {
        let mut img = image::open(kf)
            .map_err(|e| ReportError::Stage(format!("cannot read {}: {e}", kf.display())))?
            .to_rgb8();
        let mut n = 0;
        for row in rows.iter().filter(|x| {
            x.phase() == Some(Phase::Hold) && x.viewpoint == Some(v) && x.fate != "filtered"
        }) {
            n += 1;
            let c = color_of(&row.subject);
            match row.fate() {
                Some(ProjectionFate::Hit) => {
                    disc(&mut img, row.screen_x, row.screen_y, 16.0, c, false)
                }
                Some(ProjectionFate::Snapped) => {
                    disc(&mut img, row.screen_x, row.screen_y, 16.0, c, true)
                }
                _ => cross(&mut img, row.screen_x, row.screen_y, 15.0, c),
            }
        }
        let _ = write!(
            html,
            "<figure><img alt=\"viewpoint {v}\" src=\"{}\"><figcaption>viewpoint {} (held from {:.0} s): {n} fixations</figcaption></figure>",
            png_data_uri(&thumbnail(&img, 560))?,
            v + 1,
            v as f64 * (stim.protocol.timing.hold_s + stim.protocol.timing.move_s)
        );
    }
    html += "</div>";

    Ok(html)
}

/// Fixation fates per subject, with totals.
fn fates_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    html += "<h2>What became of every fixation</h2><table><tr><th>subject</th>";
    for f in ProjectionFate::ALL {
        let _ = write!(html, "<th>{}</th>", f.name());
    }
    html += "</tr>";
    let mut totals = [0usize; 7];
    for (s, t) in &r.truth.sidecar.subjects {
        let _ = write!(html, "<tr><td>{}</td>", esc(s));
        for (k, f) in ProjectionFate::ALL.iter().enumerate() {
            let c = t.fates.get(f.name()).copied().unwrap_or(0);
            totals[k] += c;
            let _ = write!(html, "<td>{c}</td>");
        }
        html += "</tr>";
    }
    html += "<tr><th>total</th>";
    for t in totals {
        let _ = write!(html, "<th>{t}</th>");
    }
    html += "</tr></table><p><i>filtered</i>: removed by the protocol (first two, last two, not among the 15 longest); <i>background</i>: the gaze ray missed the mesh (meshgaze never moves them unless <code>project --snap</code> is given).</p>";

    Ok(html)
}

/// The projector self-check, the round trip and the stimulus check, from project.json.
fn checks_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    let stim = r.stim;
    let project_json = r.out_dir.join("projection").join("project.json");
    let pj: serde_json::Value = serde_json::from_slice(
        &std::fs::read(&project_json).map_err(ReportError::io("read", &project_json))?,
    )
    .map_err(|e| ReportError::Stage(format!("{}: not JSON: {e}", project_json.display())))?;
    html += "<h2>Checks</h2><ul>";
    if let Some(c) = pj.get("self_check").filter(|c| !c.is_null()) {
        let _ = write!(
            html,
            "<li><b>Projector vs renderer</b>: {} of {} hold-phase fixations stored the triangle the rasterizer's id buffer shows at their pixel; {} more differ only within their pixel, next to an edge.</li>",
            c["agreed"], c["checked"], c["sub_pixel"]
        );
    }
    if let Some(t) = pj.get("round_trip").filter(|c| !c.is_null()) {
        let _ = write!(
            html,
            "<li><b>Round trip</b> (simulate → ingest → filter → project): {} of {} hold-phase fixations land within 1° of visual angle of their true target ({:.1}%); median error {:.2}°. The misses are fixations whose 0.4° tracker error put them off the silhouette (background).</li>",
            t["within_1deg"],
            t["matched"],
            100.0 * t["rate"].as_f64().unwrap_or(f64::NAN),
            t["median_error_deg"].as_f64().unwrap_or(f64::NAN)
        );
    }
    let _ = write!(
        html,
        "<li><b>Stimulus</b>: mesh, protocol, video and timeline hashes match the manifest; the camera recomputed from mesh and protocol reproduces all {} timeline rows byte for byte.</li></ul>",
        stim.protocol.frame_count()
    );

    Ok(html)
}

/// The ground truth and each map painted on the mesh from the first viewpoint and the one most opposite it.
/// The interactive viewer of the bunny with every map, the truth and the fixations.
fn viewer_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::from(
        "<h2>In 3D</h2><p>Drag to turn the bunny, wheel to zoom; colour it by each map or the \
         fixation density; the numbered buttons show exactly what the observers saw at each \
         hold of the video, and the time slider replays it with the fixations of that moment.</p>\n",
    );
    html += &viewer_fragment(
        &ViewerInput {
            title: "bunny".to_string(),
            mesh: &r.stim.mesh,
            maps: r.maps.to_vec(),
            truth_density: Some((r.truth.density.clone(), r.truth.sidecar.blur)),
            fixations: r.truth.rows.clone(),
            stimulus: Some((&r.stim.plan, r.stim.fps)),
        },
        &ViewerLimits::default(),
    )?;
    Ok(html)
}

fn maps_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    let stim = r.stim;
    html += "<h2>Ground truth and saliency maps</h2><p>Blue = low, red = high, by the colour rule under each picture. Ground truth: fixation counts blurred with σ<sub>b</sub> = ";
    let _ = write!(html, "{} (normalized units).</p>", r.truth.sidecar.blur);
    let first = stim.plan.directions[0];
    let back = (0..stim.plan.directions.len())
        .min_by(|&a, &b| {
            let d = |i: usize| {
                let x = stim.plan.directions[i];
                x[0] * first[0] + x[1] * first[1] + x[2] * first[2]
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap_or(0);
    let mut columns: Vec<(String, &[f64])> =
        vec![("ground truth (fixation density)".into(), &r.truth.density)];
    for (name, m) in r.maps {
        let secs = r
            .method_seconds
            .iter()
            .find(|x| &x.0 == name)
            .map_or(String::new(), |x| format!(", {:.2} s", x.1));
        columns.push((format!("{}{secs}", name.to_uppercase()), m));
    }
    html += "<div class=\"maps\">";
    for view in [0, back] {
        for (name, values) in &columns {
            let img = thumbnail(
                &render_map(&stim.mesh, &stim.plan, &stim.protocol, values, view),
                420,
            );
            let _ = write!(
                html,
                "<figure><img alt=\"{0}\" src=\"{1}\"><figcaption>{0}, viewpoint {2}; {3}</figcaption></figure>",
                esc(name),
                png_data_uri(&img)?,
                view + 1,
                crate::mesh::ColorScale::RULE
            );
        }
    }
    html += "</div>";

    Ok(html)
}

/// The score table and the charts.
fn scores_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    html += "<h2>Scores</h2><table><tr><th>map</th><th>AUC-Judd σ=0</th><th>shown only σ=0</th><th>AUC-Judd peak</th><th>at σ<sub>b</sub></th><th>chance there: mean [95%]</th><th>LCC σ=0</th><th>LCC peak</th><th>NSS σ=0</th><th>Gini</th></tr>";
    for m in &r.score.summaries {
        let _ = write!(
            html,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{} [{}, {}]</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
            esc(&m.method),
            fmt3(m.auc_judd_unblurred),
            fmt3(m.auc_judd_visible_unblurred),
            fmt3(m.auc_judd_peak),
            m.auc_judd_peak_blur,
            fmt3(m.chance_auc_judd_at_peak),
            fmt3(m.chance_auc_judd_low_at_peak),
            fmt3(m.chance_auc_judd_high_at_peak),
            fmt3(m.lcc_unblurred),
            fmt3(m.lcc_peak),
            fmt3(m.nss_unblurred),
            fmt3(m.gini_unblurred)
        );
    }
    let _ = write!(
        html,
        "<tr><td>human (split-half, {} splits)</td><td>{}</td><td></td><td>{}</td><td>{:.2}</td><td colspan=\"5\"></td></tr></table>",
        r.truth.sidecar.human_splits,
        fmt3(r.truth.sidecar.human_auc_judd_unblurred),
        fmt3(r.truth.sidecar.human_auc_judd_peak),
        r.truth.sidecar.human_auc_judd_peak_blur
    );
    html += "<p>AUC-Judd: fixated vertices against all others (\"shown only\": against the vertices some hold view shows, since nobody could look at the rest); blurring the saliency map over σ<sub>b</sub> = 0–0.2 (normalized units, half the principal-axes box diagonal = 1) as in the paper's Fig. 6. The grey band holds 95% of 20 seeded random maps blurred the same way (dashed: their mean); the human line is the split-half ceiling: one half of the subjects predicting the other.</p><div class=\"grid\" style=\"grid-template-columns: 1fr 1fr\">";
    for p in r.plots {
        let _ = write!(
            html,
            "<figure><img alt=\"{0}\" src=\"{1}\"><figcaption>{0}</figcaption></figure>",
            esc(Path::new(p)
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .as_ref()),
            file_data_uri(Path::new(p))?
        );
    }
    html += "</div>";

    Ok(html)
}

/// Tool, command, hashes and the protocol text.
fn provenance_section(r: &ReportInputs) -> Result<String> {
    let mut html = String::new();
    let stim = r.stim;
    html += "<h2>Provenance</h2><table>";
    let rowp = |html: &mut String, k: &str, v: &str| {
        let _ = write!(
            html,
            "<tr><td>{}</td><td style=\"text-align:left\"><code>{}</code></td></tr>",
            esc(k),
            esc(v)
        );
    };
    rowp(
        &mut html,
        "tool",
        &format!("meshgaze {}", env!("CARGO_PKG_VERSION")),
    );
    rowp(
        &mut html,
        "command",
        &std::env::args().collect::<Vec<_>>().join(" "),
    );
    rowp(&mut html, "mesh SHA-256", &stim.mesh_sha256);
    rowp(&mut html, "protocol SHA-256", &stim.protocol_sha256);
    rowp(&mut html, "video SHA-256", &stim.video_sha256);
    rowp(&mut html, "manifest SHA-256", &stim.manifest_sha256);
    rowp(
        &mut html,
        "mesh",
        &format!(
            "{} vertices, {} triangles",
            stim.mesh.positions.len(),
            stim.mesh.triangles.len()
        ),
    );
    html += "</table><p>Every stage wrote its own JSON sidecar with the parameters and input hashes: stimulus/manifest.json, recordings/simulate.json, ingest/ingest.json, projection/project.json, truth/truth.json, saliency/*.json. The protocol used:</p><pre>";
    html += &esc(&stim.protocol_toml);
    html += "</pre></body></html>\n";
    Ok(html)
}

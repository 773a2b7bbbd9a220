//! report.html of a study, built from the files the study wrote (so it is the same after
//! `study merge` joins shards): the per-mesh table, the mean AUC-vs-blur curve of each method
//! with the human ceiling and the chance band of the mean, and data quality per subject.
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use super::html::{esc, fmt3};
use super::mesh_page::{FATES, STYLE};
use super::score_plots::{auc_chart_png, auc_series};
use super::ReportError;
use crate::scoring::{chance_band_of_mean, peak_over_blur, CHANCE, CHANCE_HIGH, CHANCE_LOW, HUMAN};

type Result<T, E = ReportError> = std::result::Result<T, E>;

/// A CSV table opened for reading, its failure naming the file.
fn open_table(path: &Path) -> Result<csv::Reader<std::fs::File>> {
    let file = std::fs::File::open(path).map_err(ReportError::io("read", path))?;
    Ok(csv::Reader::from_reader(file))
}

/// A row of `path` at 1-based line `line` that cannot be used.
fn table_error(path: &Path, line: usize, message: impl std::fmt::Display) -> ReportError {
    ReportError::Table {
        path: path.to_path_buf(),
        line,
        message: message.to_string(),
    }
}

/// One row of scores.csv.
struct Row {
    mesh: String,
    method: String,
    metric: String,
    blur: f64,
    value: f64,
}

fn read_scores(path: &Path) -> Result<Vec<Row>> {
    let mut r = open_table(path)?;
    let mut rows = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| table_error(path, i + 2, e))?;
        let num = |k: usize| -> Result<f64> {
            rec.get(k).unwrap_or("").parse::<f64>().map_err(|e| {
                table_error(path, i + 2, format!("column {}: not a number: {e}", k + 1))
            })
        };
        rows.push(Row {
            mesh: rec.get(0).unwrap_or("").to_string(),
            method: rec.get(1).unwrap_or("").to_string(),
            metric: rec.get(2).unwrap_or("").to_string(),
            blur: num(3)?,
            value: num(4)?,
        });
    }
    Ok(rows)
}

/// The chance draws of one mesh, as `score` wrote them to scores/chance/MESH.csv.
pub fn read_chance_draws(path: &Path) -> Result<Vec<(f64, Vec<f64>)>> {
    let mut r = open_table(path)?;
    let mut out: Vec<(f64, Vec<f64>)> = Vec::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| table_error(path, i + 2, e))?;
        let blur: f64 = rec
            .get(0)
            .unwrap_or("")
            .parse()
            .map_err(|e| table_error(path, i + 2, format!("bad blur: {e}")))?;
        let value: f64 = rec
            .get(2)
            .unwrap_or("")
            .parse()
            .map_err(|e| table_error(path, i + 2, format!("bad value: {e}")))?;
        match out.last_mut() {
            Some((b, v)) if *b == blur => v.push(value),
            _ => out.push((blur, vec![value])),
        }
    }
    Ok(out)
}

/// Writes the chance draws of one mesh (blur,draw,auc_judd).
pub fn write_chance_draws(path: &Path, draws: &[(f64, Vec<f64>)]) -> Result<()> {
    let mut s = String::from("blur,draw,auc_judd\n");
    for (blur, values) in draws {
        for (j, v) in values.iter().enumerate() {
            let _ = writeln!(s, "{blur},{},{v}", j + 1);
        }
    }
    std::fs::write(path, s).map_err(ReportError::io("write", path))
}

/// Per-subject data quality over all the stimuli of ingest/quality.csv.
#[derive(Default)]
struct SubjectQuality {
    stimuli: usize,
    samples: u64,
    lost: u64,
    precision: Vec<f64>,
    kept: u64,
    invalid: u64,
}

fn read_quality(path: &Path) -> Result<BTreeMap<String, SubjectQuality>> {
    let mut r = open_table(path)?;
    let headers = r.headers().map_err(|e| table_error(path, 1, e))?.clone();
    let col = |name: &str| headers.iter().position(|h| h == name);
    let (subject, samples, lost, precision, kept, invalid) = (
        col("subject"),
        col("samples"),
        col("lost_samples"),
        col("precision_rms_px"),
        col("kept"),
        col("invalid"),
    );
    let mut out: BTreeMap<String, SubjectQuality> = BTreeMap::new();
    for (i, rec) in r.records().enumerate() {
        let rec = rec.map_err(|e| table_error(path, i + 2, e))?;
        let get = |c: Option<usize>| c.and_then(|c| rec.get(c)).unwrap_or("");
        let q = out.entry(get(subject).to_string()).or_default();
        q.stimuli += 1;
        q.samples += get(samples).parse::<u64>().unwrap_or(0);
        q.lost += get(lost).parse::<u64>().unwrap_or(0);
        if let Ok(p) = get(precision).parse::<f64>() {
            if p.is_finite() {
                q.precision.push(p);
            }
        }
        q.kept += get(kept).parse::<u64>().unwrap_or(0);
        q.invalid += get(invalid).parse::<u64>().unwrap_or(0);
    }
    Ok(out)
}

fn median(v: &[f64]) -> f64 {
    crate::scoring::quantile(v, 0.5)
}

fn auc_curve(rows: &[Row], mesh: &str, method: &str) -> Vec<(f64, f64)> {
    rows.iter()
        .filter(|r| r.mesh == mesh && r.method == method && r.metric == "auc_judd")
        .map(|r| (r.blur, r.value))
        .collect()
}

fn auc_at(rows: &[Row], mesh: &str, method: &str, blur: f64) -> f64 {
    rows.iter()
        .find(|r| r.mesh == mesh && r.method == method && r.metric == "auc_judd" && r.blur == blur)
        .map_or(f64::NAN, |r| r.value)
}

/// A method's AUC-Judd averaged over the meshes that have its curve, at each blur of the grid.
fn mean_curve(rows: &[Row], meshes: &[String], method: &str) -> Vec<(f64, f64)> {
    let per: Vec<Vec<(f64, f64)>> = meshes
        .iter()
        .map(|m| auc_curve(rows, m, method))
        .filter(|c| !c.is_empty())
        .collect();
    let Some(first) = per.first() else {
        return Vec::new();
    };
    first
        .iter()
        .enumerate()
        .filter(|(i, _)| {
            per.iter()
                .all(|c| c.len() == first.len() && c[*i].0 == first[*i].0)
        })
        .map(|(i, p)| {
            (
                p.0,
                per.iter().map(|c| c[i].1).sum::<f64>() / per.len() as f64,
            )
        })
        .collect()
}

/// The mean AUC-vs-blur chart (report/mean_auc.png) and its table.
fn mean_section(
    out: &Path,
    rows: &[Row],
    meshes: &[String],
    methods: &[String],
    report_dir: &Path,
) -> Result<String> {
    let mut h = String::new();
    let mut draws = Vec::new();
    for m in meshes {
        let p = out.join("scores").join("chance").join(format!("{m}.csv"));
        if p.exists() {
            draws.push(read_chance_draws(&p)?);
        }
    }
    let band = if draws.len() == meshes.len() && !draws.is_empty() {
        let refs: Vec<&[(f64, Vec<f64>)]> = draws.iter().map(|d| d.as_slice()).collect();
        chance_band_of_mean(&refs)?
    } else {
        Vec::new()
    };
    let series = auc_series(
        methods
            .iter()
            .map(|m| (m.clone(), mean_curve(rows, meshes, m)))
            .collect(),
        "chance: mean and 95% of the mean of random maps",
        band.clone(),
        mean_curve(rows, meshes, HUMAN),
    );
    if series.iter().any(|s| !s.points.is_empty()) {
        auc_chart_png(
            &report_dir.join("mean_auc.png"),
            &format!("mean AUC-Judd over {} meshes vs blur", meshes.len()),
            &series,
        )?;
        h += "<h2>Mean AUC-Judd over blur</h2><p>Each method's AUC-Judd averaged over the meshes at each blur σ<sub>b</sub>; black: the split-half human ceiling; grey: the mean of the random maps, with the band holding 95% of the means of independent random maps (draw j of every mesh averaged).</p><img alt=\"mean AUC over blur\" src=\"report/mean_auc.png\" style=\"max-width:900px\">";
        h += "<table><tr><th>method</th><th>mean AUC-Judd σ<sub>b</sub>=0</th><th>peak of the mean (σ<sub>b</sub>)</th><th>chance there: mean [95%]</th></tr>";
        for s in series.iter().filter(|s| !s.points.is_empty()) {
            let (b, v) = peak_over_blur(&s.points);
            let at0 = s.points.first().map_or(f64::NAN, |p| p.1);
            let chance = band.iter().find(|x| x.0 == b);
            let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{} ({b:.2})</td><td>{}</td></tr>",
                esc(&s.name),
                fmt3(at0),
                fmt3(v),
                chance.map_or("–".to_string(), |c| format!(
                    "{} [{}, {}]",
                    fmt3(c.1),
                    fmt3(c.2),
                    fmt3(c.3)
                ))
            );
        }
        h += "</table>";
    }

    Ok(h)
}

/// One row per mesh, linking to its page.
fn mesh_table(out: &Path, rows: &[Row], meshes: &[String], methods: &[String]) -> Result<String> {
    let mut h = String::new();
    h += "<h2>Meshes</h2><p>Kept fixations on the mesh of the protocol's expected number per subject; fates of all fixations; the human ceiling at its peak; each method's AUC-Judd unblurred / at its peak (σ<sub>b</sub>) with the chance band at that blur. Each mesh's page (follow its name) holds the interactive 3D viewer of its maps, fixation density and fixations, with the cameras the subjects saw; one viewer per page keeps this report small for studies of many meshes.</p><table><tr><th>mesh</th><th>subjects</th><th>on mesh / expected</th>";
    for f in FATES {
        let _ = write!(h, "<th>{f}</th>");
    }
    h += "<th>human peak</th>";
    for m in methods {
        let _ = write!(h, "<th>{}</th>", esc(m));
    }
    h += "</tr>";
    for mesh in meshes {
        let truth_path = out.join("truth").join(mesh).join("truth.json");
        let truth: serde_json::Value = match std::fs::read(&truth_path) {
            Ok(b) => serde_json::from_slice(&b).map_err(|e| {
                ReportError::Stage(format!("{}: not JSON: {e}", truth_path.display()))
            })?,
            Err(_) => serde_json::Value::Null,
        };
        let subjects = truth["subjects"].as_object();
        let n_subjects = subjects.map_or(0, |s| s.len());
        let expected = truth["expected_per_subject"].as_u64().unwrap_or(0) as usize * n_subjects;
        let _ = write!(
            h,
            "<tr><td><a href=\"report/{0}.html\">{0}</a></td><td>{n_subjects}</td><td>{1} / {expected}</td>",
            esc(mesh),
            truth["fixations_on_mesh"]
        );
        for f in FATES {
            let total: u64 = subjects.map_or(0, |s| {
                s.values()
                    .map(|x| x["fates"][f].as_u64().unwrap_or(0))
                    .sum()
            });
            let _ = write!(h, "<td>{total}</td>");
        }
        let _ = write!(
            h,
            "<td>{}</td>",
            fmt3(truth["human_auc_judd_peak"].as_f64().unwrap_or(f64::NAN))
        );
        for m in methods {
            let c = auc_curve(rows, mesh, m);
            let (b, peak) = peak_over_blur(&c);
            let _ = write!(
                h,
                "<td>{} / {} ({b:.2}) <small>chance {} [{}, {}]</small></td>",
                fmt3(auc_at(rows, mesh, m, 0.0)),
                fmt3(peak),
                fmt3(auc_at(rows, mesh, CHANCE, b)),
                fmt3(auc_at(rows, mesh, CHANCE_LOW, b)),
                fmt3(auc_at(rows, mesh, CHANCE_HIGH, b))
            );
        }
        h += "</tr>";
    }
    h += "</table>";

    Ok(h)
}

/// Data quality per subject over all stimuli of ingest/quality.csv.
fn quality_table(quality_csv: &Path) -> Result<String> {
    let mut h = String::new();
    let q = read_quality(quality_csv)?;
    h += "<h2>Data quality per subject</h2><p>Over every stimulus of the subject's recording (ingest/quality.csv has one row per stimulus): tracking loss, precision as the RMS of sample-to-sample distances in pixels (median over stimuli), fixations kept by the protocol's filter and those invalid. The exports meshgaze reads carry no calibration validation result, so accuracy is not shown.</p><table><tr><th>subject</th><th>stimuli</th><th>samples</th><th>loss</th><th>precision RMS (px)</th><th>kept fixations</th><th>invalid</th></tr>";
    for (s, x) in &q {
        let loss = if x.samples > 0 {
            x.lost as f64 / x.samples as f64
        } else {
            f64::NAN
        };
        let _ = write!(
                h,
                "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td></tr>",
                esc(s),
                x.stimuli,
                x.samples,
                if loss.is_finite() { format!("{:.1}%", 100.0 * loss) } else { "–".into() },
                fmt3(median(&x.precision)),
                x.kept,
                x.invalid
            );
    }
    h += "</table>";

    Ok(h)
}

/// Where the last run's time went, from study.json's steps (wall-clock seconds per step):
/// totals per kind of step, and the meshes that took longest.
fn time_section(study_json: &Path) -> String {
    let Some(steps) = std::fs::read(study_json)
        .ok()
        .and_then(|b| serde_json::from_slice::<serde_json::Value>(&b).ok())
        .and_then(|v| v["run"]["steps"].as_array().cloned())
    else {
        return String::new();
    };
    let mut by_step: BTreeMap<String, (f64, usize, usize)> = BTreeMap::new();
    let mut by_mesh: BTreeMap<String, f64> = BTreeMap::new();
    for s in &steps {
        let (Some(step), Some(mesh)) = (s["step"].as_str(), s["mesh"].as_str()) else {
            continue;
        };
        let seconds = s["seconds"].as_f64().unwrap_or(0.0);
        let e = by_step.entry(step.to_string()).or_insert((0.0, 0, 0));
        e.0 += seconds;
        if s["outcome"] == "done" {
            e.1 += 1;
        } else {
            e.2 += 1;
        }
        if step != "ingest" {
            *by_mesh.entry(mesh.to_string()).or_insert(0.0) += seconds;
        }
    }
    let total: f64 = by_step.values().map(|v| v.0).sum();
    let mut h = String::from(
        "<h2>Where the time went</h2><p>Wall-clock seconds of the last run's steps (study.json, run.log), summed over meshes; with <code>--jobs</code> meshes run side by side, so the sum can exceed the run's length. Up-to-date steps cost only their check.</p><table><tr><th>step</th><th>seconds</th><th>share</th><th>done</th><th>up to date / skipped / failed</th></tr>",
    );
    let mut rows: Vec<(&String, &(f64, usize, usize))> = by_step.iter().collect();
    rows.sort_by(|a, b| b.1 .0.total_cmp(&a.1 .0));
    for (step, (seconds, done, other)) in rows {
        let _ = write!(
            h,
            "<tr><td>{}</td><td>{seconds:.1}</td><td>{:.0}%</td><td>{done}</td><td>{other}</td></tr>",
            esc(step),
            if total > 0.0 { 100.0 * seconds / total } else { 0.0 }
        );
    }
    h += "</table>";
    let mut meshes: Vec<(&String, &f64)> = by_mesh.iter().collect();
    meshes.sort_by(|a, b| b.1.total_cmp(a.1));
    if !meshes.is_empty() {
        h += "<p>Slowest meshes (every step but the shared ingest): ";
        let list: Vec<String> = meshes
            .iter()
            .take(5)
            .map(|(m, s)| format!("{} {s:.1} s", esc(m)))
            .collect();
        h += &list.join(", ");
        h += ".</p>";
    }
    h
}

/// Builds OUT/report.html (and OUT/report/mean_auc.png) from OUT/scores.csv, OUT/scores/chance/,
/// OUT/truth/*/truth.json and OUT/ingest/quality.csv. `problems` are listed at the top.
pub fn write_study_report(out: &Path, problems: &[String]) -> Result<PathBuf> {
    let scores_csv = out.join("scores.csv");
    let rows = if scores_csv.exists() {
        read_scores(&scores_csv)?
    } else {
        Vec::new()
    };
    let mut meshes: Vec<String> = rows.iter().map(|r| r.mesh.clone()).collect();
    meshes.dedup();
    let mut methods: Vec<String> = Vec::new();
    for r in &rows {
        let special = [CHANCE, CHANCE_LOW, CHANCE_HIGH, HUMAN].contains(&r.method.as_str());
        if !special && !methods.contains(&r.method) {
            methods.push(r.method.clone());
        }
    }
    let report_dir = out.join("report");
    crate::file_bytes::create_output_dir(&report_dir).map_err(ReportError::stage)?;

    let mut h = format!(
        "<!doctype html><html><head><meta charset=\"utf-8\"><title>meshgaze study</title><style>{STYLE}</style></head><body><h1>meshgaze study: {} meshes, {} methods</h1><p>Written by meshgaze {} from the files beside it (study.json has the provenance of every input).</p>",
        meshes.len(),
        methods.len(),
        env!("CARGO_PKG_VERSION"),
    );
    if !problems.is_empty() {
        h += "<h2>Problems</h2><ul>";
        for p in problems {
            let _ = write!(h, "<li>{}</li>", esc(p));
        }
        h += "</ul>";
    }

    h += &mean_section(out, &rows, &meshes, &methods, &report_dir)?;
    h += &mesh_table(out, &rows, &meshes, &methods)?;
    let quality_csv = out.join("ingest").join("quality.csv");
    if quality_csv.exists() {
        h += &quality_table(&quality_csv)?;
    }
    h += &time_section(&out.join("study.json"));
    h += "<h2>Files</h2><ul><li><a href=\"scores.csv\">scores.csv</a> (mesh, method, metric, blur, value)</li><li><a href=\"study.json\">study.json</a></li><li><a href=\"run.log\">run.log</a></li><li><a href=\"ingest/fixations.csv\">ingest/fixations.csv</a>, <a href=\"ingest/quality.csv\">ingest/quality.csv</a></li></ul></body></html>\n";
    let path = out.join("report.html");
    std::fs::write(&path, h).map_err(ReportError::io("write", &path))?;
    Ok(path)
}

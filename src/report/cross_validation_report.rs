//! The files of `meshgaze train --cv`: the leave-one-object-out table as CSV and Markdown, and
//! per held-out mesh the predicted map beside the human one.
use std::path::Path;

use crate::experiments::gaze_model_cross_validation::{
    held_out_means, mean_rows, CvRow, EvaluationMesh, HeldOutRow,
};
use crate::protocol::ProtocolPerDataset;
use crate::report::html::thumbnail;
use crate::report::map_render::render_map;
use crate::stimulus::camera::CameraPlan;

/// The rows and their per-method means as CSV at `path`.
pub fn write_cv_csv(path: &Path, rows: &[CvRow]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_path(path)?;
    for r in rows.iter().chain(mean_rows(rows).iter()) {
        w.serialize(r)?;
    }
    w.flush()?;
    Ok(())
}

/// Objects down, methods across: AUC-Judd plain / visible-only, then the mean LCC per method.
pub fn cv_markdown(rows: &[CvRow]) -> String {
    let means = mean_rows(rows);
    let methods: Vec<&str> = means.iter().map(|r| r.method.as_str()).collect();
    let mut s = format!("| object | {} |\n", methods.join(" | "));
    s += &format!("|---|{}\n", "---|".repeat(methods.len()));
    let mut objects: Vec<&str> = Vec::new();
    for r in rows {
        if !objects.contains(&r.object.as_str()) {
            objects.push(&r.object);
        }
    }
    let all: Vec<&CvRow> = rows.iter().chain(means.iter()).collect();
    for o in objects.iter().copied().chain(std::iter::once("mean")) {
        s += &format!("| {o} |");
        for m in &methods {
            match all.iter().find(|r| r.object == o && r.method == *m) {
                Some(r) => s += &format!(" {:.3} / {:.3} |", r.auc_judd, r.auc_judd_visible),
                None => s += " |",
            }
        }
        s += "\n";
    }
    s += "\nAUC-Judd unblurred, plain / with never-shown vertices left out of the negatives.\n";
    s += &format!(
        "LCC mean: {}\n",
        means
            .iter()
            .map(|r| format!("{} {:.3}", r.method, r.lcc))
            .collect::<Vec<_>>()
            .join(", ")
    );
    s
}

/// Every held-out row (scheme, group, object, ablation) as CSV at `path`.
pub fn write_held_out_csv(path: &Path, rows: &[HeldOutRow]) -> Result<(), csv::Error> {
    let mut w = csv::Writer::from_path(path)?;
    for r in rows {
        w.serialize(r)?;
    }
    w.flush()?;
    Ok(())
}

/// The held-out figures: per scheme its groups (meshes, the gaze model held out that way
/// beside held out alone, and the best baseline on those meshes), then the means of every
/// scheme and ablation.
pub fn held_out_markdown(held_out: &[HeldOutRow], cv_rows: &[CvRow]) -> String {
    let mut s = String::new();
    let lone = |object: &str| {
        held_out
            .iter()
            .find(|r| r.held_out_by == "object" && r.without == "none" && r.object == object)
            .map_or(f64::NAN, |r| r.auc_judd)
    };
    for by in ["dataset", "category"] {
        let rows: Vec<&HeldOutRow> = held_out
            .iter()
            .filter(|r| r.held_out_by == by && r.without == "none")
            .collect();
        if rows.is_empty() {
            continue;
        }
        s += &format!("\nLeave-one-{by}-out (gaze AUC-Judd, unblurred):\n\n");
        s += &format!("| {by} | meshes | held out by {by} | held out alone | best baseline |\n|---|---:|---:|---:|---|\n");
        let mut groups: Vec<&str> = Vec::new();
        for r in &rows {
            if !groups.contains(&r.group.as_str()) {
                groups.push(&r.group);
            }
        }
        for g in groups {
            let of: Vec<&&HeldOutRow> = rows.iter().filter(|r| r.group == g).collect();
            let k = of.len() as f64;
            let by_group = of.iter().map(|r| r.auc_judd).sum::<f64>() / k;
            let alone = of.iter().map(|r| lone(&r.object)).sum::<f64>() / k;
            let objects: Vec<&str> = of.iter().map(|r| r.object.as_str()).collect();
            let mut best = (String::new(), f64::NEG_INFINITY);
            let mut methods: Vec<&str> = Vec::new();
            for r in cv_rows {
                if r.method != "gaze"
                    && r.method != "chance"
                    && !methods.contains(&r.method.as_str())
                {
                    methods.push(&r.method);
                }
            }
            for m in methods {
                let v: Vec<f64> = cv_rows
                    .iter()
                    .filter(|r| r.method == m && objects.contains(&r.object.as_str()))
                    .map(|r| r.auc_judd)
                    .collect();
                let mean = v.iter().sum::<f64>() / v.len().max(1) as f64;
                if mean > best.1 {
                    best = (m.to_string(), mean);
                }
            }
            s += &format!(
                "| {g} | {} | {by_group:.3} | {alone:.3} | {} {:.3} |\n",
                of.len(),
                best.0,
                best.1
            );
        }
    }
    let means = held_out_means(held_out);
    if means.iter().any(|m| m.1 != "none") || means.iter().any(|m| m.0 != "object") {
        s += "\nMeans of the gaze model (AUC-Judd plain / visible-only, LCC) by how it was held out and the feature group left out of training:\n\n";
        s += "| held out by | without | meshes | AUC-Judd | visible | LCC |\n|---|---|---:|---:|---:|---:|\n";
        for (by, without, n, auc, visible, lcc) in means {
            s += &format!("| {by} | {without} | {n} | {auc:.3} | {visible:.3} | {lcc:.3} |\n");
        }
    }
    s
}

/// DIR/NAME.png per mesh: predicted map (left) beside the human map (right).
pub fn write_cv_figures(
    dir: &Path,
    meshes: &[EvaluationMesh],
    maps: &[(String, Vec<f64>)],
    protocols: &ProtocolPerDataset,
) -> Result<(), super::ReportError> {
    use super::ReportError;
    crate::file_bytes::create_output_dir(dir).map_err(ReportError::stage)?;
    for (m, (name, map)) in meshes.iter().zip(maps) {
        let protocol = &protocols.for_dataset(&m.dataset);
        let plan = CameraPlan::new(&m.mesh, protocol)?;
        let left = thumbnail(&render_map(&m.mesh, &plan, protocol, map, 0), 480);
        let right = thumbnail(&render_map(&m.mesh, &plan, protocol, &m.values, 0), 480);
        let mut both = image::RgbImage::new(left.width() + right.width(), left.height());
        image::imageops::replace(&mut both, &left, 0, 0);
        image::imageops::replace(&mut both, &right, left.width() as i64, 0);
        let path = dir.join(format!("{name}.png"));
        both.save(&path)
            .map_err(|e| ReportError::Chart(format!("cannot write {}: {e}", path.display())))?;
    }
    Ok(())
}

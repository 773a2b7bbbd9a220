//! The files of `meshgaze train --cv`: the leave-one-object-out table as CSV and Markdown, and
//! per held-out mesh the predicted map beside the human one.
use std::path::Path;

use crate::experiments::gaze_model_cross_validation::{mean_rows, CvRow, EvaluationMesh};
use crate::protocol::Protocol;
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

/// DIR/NAME.png per mesh: predicted map (left) beside the human map (right).
pub fn write_cv_figures(
    dir: &Path,
    meshes: &[EvaluationMesh],
    maps: &[(String, Vec<f64>)],
    protocol: &Protocol,
) -> Result<(), String> {
    crate::file_bytes::create_output_dir(dir).map_err(|e| e.to_string())?;
    for (m, (name, map)) in meshes.iter().zip(maps) {
        let plan = CameraPlan::new(&m.mesh, protocol)?;
        let left = thumbnail(&render_map(&m.mesh, &plan, protocol, map, 0), 480);
        let right = thumbnail(&render_map(&m.mesh, &plan, protocol, &m.values, 0), 480);
        let mut both = image::RgbImage::new(left.width() + right.width(), left.height());
        image::imageops::replace(&mut both, &left, 0, 0);
        image::imageops::replace(&mut both, &right, left.width() as i64, 0);
        let path = dir.join(format!("{name}.png"));
        both.save(&path)
            .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    Ok(())
}

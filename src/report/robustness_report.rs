//! The files of `meshgaze experiment robustness`: the agreement table as CSV and Markdown, the
//! figure (one row per method: its map on the clean mesh, then on each damaged copy), and the
//! JSON sidecar with provenance.
use std::path::{Path, PathBuf};

use image::RgbImage;
use serde::Serialize;

use crate::experiments::robustness::{AgreementRow, RobustnessParams, RobustnessResult};
use crate::mesh::Mesh;
use crate::protocol::Protocol;
use crate::provenance::{InputFile, Provenance};
use crate::report::map_render::render_map;
use crate::report::ReportError;
use crate::saliency::Method;
use crate::stimulus::camera::CameraPlan;

#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    parameters: &'a RobustnessParams,
    corruptions: Vec<(&'static str, String, usize, usize)>,
    rows: &'a [AgreementRow],
}

/// `mesh,method,corruption,pearson,auc_top,seconds`, one row per (method, corruption).
pub fn robustness_csv(mesh_name: &str, rows: &[AgreementRow]) -> String {
    let mut csv = String::from("mesh,method,corruption,pearson,auc_top,seconds\n");
    for r in rows {
        csv += &format!(
            "{mesh_name},{},{},{},{},{}\n",
            r.method, r.corruption, r.pearson, r.auc_top, r.seconds
        );
    }
    csv
}

/// The Markdown table (Pearson / AUC per method and corruption) and what each copy is.
pub fn robustness_markdown(
    mesh_name: &str,
    mesh: &Mesh,
    methods: &[Method],
    params: &RobustnessParams,
    result: &RobustnessResult,
) -> String {
    let mut md = format!(
        "Robustness on {mesh_name} ({} vertices): agreement with each method's map on the clean mesh, Pearson / AUC of finding the clean top {:.0}%.\n\n| method | noise | simplified | holes |\n|---|---:|---:|---:|\n",
        mesh.positions.len(),
        100.0 * params.top_fraction
    );
    for m in methods {
        md += &format!("| {} |", m.name());
        for c in ["noise", "simplified", "holes"] {
            match result
                .rows
                .iter()
                .find(|r| r.method == m.name() && r.corruption == c)
            {
                Some(r) => md += &format!(" {:.3} / {:.3} |", r.pearson, r.auc_top),
                None => md += " – |",
            }
        }
        md += "\n";
    }
    md += "\n";
    for c in &result.corrupted {
        md += &format!("- {}: {}\n", c.name, c.description);
    }
    md
}

/// One row per method, 400x400 tiles: the clean mesh, then each damaged copy with its own map,
/// seen from the built-in protocol's first hold view.
pub fn robustness_figure(mesh: &Mesh, result: &RobustnessResult) -> Result<RgbImage, ReportError> {
    let (w, h) = (400u32, 400u32);
    let text = include_str!("../../protocols/hu2020.toml")
        .replace("width_px = 1680", &format!("width_px = {w}"))
        .replace("height_px = 1050", &format!("height_px = {h}"));
    let figure_error = |e: String| ReportError::Chart(e);
    let protocol = Protocol::from_toml(&text, "hu2020.toml (400x400)")
        .map_err(|e| figure_error(e.to_string()))?;
    let plan = CameraPlan::new(mesh, &protocol)?;
    let cols = 1 + result.corrupted.len() as u32;
    let mut fig = RgbImage::from_pixel(
        w * cols,
        h * result.maps.len() as u32,
        image::Rgb([255, 255, 255]),
    );
    for (row, (_, clean, own)) in result.maps.iter().enumerate() {
        let mut tiles = vec![render_map(mesh, &plan, &protocol, clean, 0)];
        for (c, values) in result.corrupted.iter().zip(own) {
            tiles.push(render_map(&c.mesh, &plan, &protocol, values, 0));
        }
        for (col, tile) in tiles.iter().enumerate() {
            image::imageops::overlay(
                &mut fig,
                tile,
                (col as u32 * w) as i64,
                (row as u32 * h) as i64,
            );
        }
    }
    Ok(fig)
}

/// Writes PREFIX.csv, .md, .png and .json; returns the Markdown table.
pub fn write_robustness(
    mesh_path: &Path,
    mesh: &Mesh,
    methods: &[Method],
    params: &RobustnessParams,
    result: &RobustnessResult,
    prefix: &Path,
) -> Result<String, ReportError> {
    let path = |ext: &str| PathBuf::from(format!("{}.{ext}", prefix.display()));
    let write = |ext: &str, bytes: &[u8]| {
        let p = path(ext);
        std::fs::write(&p, bytes).map_err(ReportError::io("write", p))
    };
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(ReportError::io("create", dir))?;
    }
    let name = mesh_path
        .file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .to_string();
    write("csv", robustness_csv(&name, &result.rows).as_bytes())?;
    let md = robustness_markdown(&name, mesh, methods, params, result);
    write("md", md.as_bytes())?;
    robustness_figure(mesh, result)?
        .save(path("png"))
        .map_err(|e| ReportError::Chart(format!("{}: {e}", path("png").display())))?;
    let hashed = InputFile::hash(mesh_path).map_err(ReportError::io("read", mesh_path))?;
    let sidecar = Sidecar {
        provenance: Provenance::new(vec![hashed]),
        parameters: params,
        corruptions: result
            .corrupted
            .iter()
            .map(|c| {
                (
                    c.name,
                    c.description.clone(),
                    c.mesh.positions.len(),
                    c.mesh.triangles.len(),
                )
            })
            .collect(),
        rows: &result.rows,
    };
    let json = serde_json::to_string_pretty(&sidecar).expect("the sidecar serializes") + "\n";
    write("json", json.as_bytes())?;
    Ok(md)
}

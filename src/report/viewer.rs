//! The interactive 3D viewer: a mesh with its saliency maps, truth density and fixations, and
//! the cameras the subjects saw, as one HTML fragment (or a whole page) that needs no network.
//!
//! Rust decides everything that must match the rest of meshgaze: the colour scale of each map
//! (the static renders' [`ColorScale`] percentiles, carried as `lo`/`hi`), the cameras of every
//! video frame (computed by [`CameraPlan::at`], the function the renderer and the projection
//! use, so a hold-view button shows exactly the frame the subjects saw), decimation of meshes
//! too large for a browser. viewer.js only draws: WebGL, its own code, no library.
use base64::Engine;
use serde::Serialize;

use super::ReportError;
use crate::mesh::simplification::simplify_to_vertex_count;
use crate::mesh::{ColorScale, Mesh};
use crate::projection::table::ProjectedRow;
use crate::stimulus::camera::{CameraPlan, Phase};

const SCRIPT: &str = include_str!("viewer.js");
const STYLE: &str = include_str!("viewer.css");

/// What the viewer shows.
pub struct ViewerInput<'a> {
    /// The page's title (the mesh's name).
    pub title: String,
    /// The mesh.
    pub mesh: &'a Mesh,
    /// Per-vertex saliency maps, by method name, in the order the chooser lists them.
    pub maps: Vec<(String, Vec<f64>)>,
    /// The truth's blurred fixation density per vertex, and its σ_b.
    pub truth_density: Option<(Vec<f64>, f64)>,
    /// Projected fixations (every fate; those with a surface point become dots).
    pub fixations: Vec<ProjectedRow>,
    /// The stimulus's camera plan and frame rate: hold-view buttons and the replay slider.
    pub stimulus: Option<(&'a CameraPlan, u32)>,
}

/// Size limits of what is embedded.
#[derive(Debug, Clone, Copy)]
pub struct ViewerLimits {
    /// Meshes with more triangles are shown simplified to about this many.
    pub max_triangles: usize,
}

impl Default for ViewerLimits {
    fn default() -> Self {
        // Half a million triangles draw smoothly in a current browser on integrated graphics
        // and keep the page near 10 MB; larger scans are shown simplified.
        ViewerLimits {
            max_triangles: 500_000,
        }
    }
}

#[derive(Serialize)]
struct Layer {
    name: String,
    kind: &'static str,
    /// f32 little-endian, base64.
    values: String,
    lo: f64,
    hi: f64,
}

#[derive(Serialize)]
struct Dots {
    subject: Vec<usize>,
    fixation: Vec<usize>,
    start_ms: Vec<f64>,
    duration_ms: Vec<f64>,
    vertex: Vec<Option<usize>>,
    fate: Vec<String>,
    /// f32 x, y, z per dot, base64.
    points: String,
}

#[derive(Serialize)]
struct Hold {
    viewpoint: usize,
    frame: usize,
}

#[derive(Serialize)]
struct Timeline {
    width: u32,
    height: u32,
    fps: u32,
    frames: usize,
    /// Per frame: the view then the projection matrix, column-major f32, base64.
    matrices: String,
    holds: Vec<Hold>,
    /// Per frame: 0 hold, 1 move.
    phases: String,
    fov_y_deg: f64,
    center: [f64; 3],
}

#[derive(Serialize)]
struct ViewerData {
    title: String,
    vertices: usize,
    triangles: usize,
    /// Some(original vertex count) when the mesh is shown simplified.
    decimated_from: Option<usize>,
    positions: String,
    indices: String,
    layers: Vec<Layer>,
    rule: &'static str,
    subjects: Vec<String>,
    dots: Dots,
    /// Fixations without a surface point, by fate.
    not_on_mesh: std::collections::BTreeMap<String, usize>,
    timeline: Option<Timeline>,
    version: &'static str,
}

fn b64_f32(values: impl IntoIterator<Item = f64>) -> String {
    let bytes: Vec<u8> = values
        .into_iter()
        .flat_map(|v| (v as f32).to_le_bytes())
        .collect();
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

fn b64_u32(values: impl IntoIterator<Item = u32>) -> String {
    let bytes: Vec<u8> = values.into_iter().flat_map(|v| v.to_le_bytes()).collect();
    base64::engine::general_purpose::STANDARD.encode(bytes)
}

fn layer(name: &str, kind: &'static str, values: &[f64], keep: Option<&[usize]>) -> Layer {
    // The scale comes from the full map, as the static renders compute it, so a simplified
    // mesh shows the same colours for the vertices it keeps.
    let scale = ColorScale::of(values);
    let shown: Vec<f64> = match keep {
        Some(k) => k.iter().map(|&i| values[i]).collect(),
        None => values.to_vec(),
    };
    Layer {
        name: name.to_string(),
        kind,
        values: b64_f32(shown),
        lo: scale.lo,
        hi: scale.hi,
    }
}

fn timeline(plan: &CameraPlan, fps: u32) -> Timeline {
    let frames = (plan.duration_s() * fps as f64).round() as usize;
    let mut matrices = Vec::with_capacity(frames * 32);
    let mut phases = Vec::with_capacity(frames);
    let mut holds: Vec<Hold> = Vec::new();
    let (mut width, mut height) = (0, 0);
    for f in 0..frames {
        let cam = plan.at(f as f64 / fps as f64);
        matrices.extend(cam.view.to_cols_array());
        matrices.extend(cam.projection.to_cols_array());
        phases.push(u32::from(cam.phase != Phase::Hold));
        if cam.phase == Phase::Hold && !holds.iter().any(|h| h.viewpoint == cam.viewpoint) {
            holds.push(Hold {
                viewpoint: cam.viewpoint,
                frame: f,
            });
        }
        (width, height) = (cam.width_px, cam.height_px);
    }
    Timeline {
        width,
        height,
        fps,
        frames,
        matrices: b64_f32(matrices),
        holds,
        phases: b64_u32(phases),
        fov_y_deg: plan.fov_y_deg,
        center: plan.center,
    }
}

fn data_json(input: &ViewerInput, limits: &ViewerLimits) -> Result<String, ReportError> {
    let n = input.mesh.positions.len();
    for (name, values) in &input.maps {
        if values.len() != n {
            return Err(ReportError::Invalid(format!(
                "map `{name}` has {} values; the mesh has {n} vertices",
                values.len()
            )));
        }
    }
    if let Some((d, _)) = &input.truth_density {
        if d.len() != n {
            return Err(ReportError::Invalid(format!(
                "the truth density has {} values; the mesh has {n} vertices",
                d.len()
            )));
        }
    }
    if let Some(bad) = input
        .fixations
        .iter()
        .filter_map(|r| r.vertex)
        .find(|&v| v >= n)
    {
        return Err(ReportError::Invalid(format!(
            "a fixation names vertex {bad}; the mesh has {n} vertices"
        )));
    }
    let simplified;
    let (shown, keep) = if input.mesh.triangles.len() > limits.max_triangles {
        let (m, keep) = simplify_to_vertex_count(input.mesh, limits.max_triangles / 2);
        simplified = (m, keep);
        (&simplified.0, Some(simplified.1.as_slice()))
    } else {
        (input.mesh, None)
    };
    let mut layers = Vec::new();
    for (name, values) in &input.maps {
        layers.push(layer(name, "map", values, keep));
    }
    if let Some((density, blur)) = &input.truth_density {
        // A density file without its truth.json does not say its blur.
        let name = if blur.is_finite() {
            format!("truth density (σ_b {blur})")
        } else {
            "truth density".to_string()
        };
        layers.push(layer(&name, "truth", density, keep));
    }
    let mut subjects: Vec<String> = input.fixations.iter().map(|r| r.subject.clone()).collect();
    subjects.sort();
    subjects.dedup();
    let mut dots = Dots {
        subject: Vec::new(),
        fixation: Vec::new(),
        start_ms: Vec::new(),
        duration_ms: Vec::new(),
        vertex: Vec::new(),
        fate: Vec::new(),
        points: String::new(),
    };
    let mut points = Vec::new();
    let mut not_on_mesh = std::collections::BTreeMap::new();
    for r in &input.fixations {
        match (r.x, r.y, r.z) {
            (Some(x), Some(y), Some(z)) => {
                dots.subject
                    .push(subjects.binary_search(&r.subject).unwrap_or(0));
                dots.fixation.push(r.fixation);
                dots.start_ms.push(r.start_ms);
                dots.duration_ms.push(r.duration_ms);
                dots.vertex.push(r.vertex);
                dots.fate.push(r.fate.clone());
                points.extend([x, y, z]);
            }
            _ => *not_on_mesh.entry(r.fate.clone()).or_insert(0) += 1,
        }
    }
    dots.points = b64_f32(points);
    let data = ViewerData {
        title: input.title.clone(),
        vertices: shown.positions.len(),
        triangles: shown.triangles.len(),
        decimated_from: keep.map(|_| n),
        positions: b64_f32(shown.positions.iter().flat_map(|p| [p.x, p.y, p.z])),
        indices: b64_u32(shown.triangles.iter().flatten().copied()),
        layers,
        rule: ColorScale::RULE,
        subjects,
        dots,
        not_on_mesh,
        timeline: input.stimulus.map(|(plan, fps)| timeline(plan, fps)),
        version: env!("CARGO_PKG_VERSION"),
    };
    let json = serde_json::to_string(&data).map_err(ReportError::chart)?;
    // Inside <script>, "</" could close the element early (a subject named "</script>").
    Ok(json.replace("</", "<\\/"))
}

/// The viewer as an HTML fragment (a `<div class="mgv">`, its style and script) for a page of
/// its own or a report. Several fragments may share a page.
pub fn viewer_fragment(input: &ViewerInput, limits: &ViewerLimits) -> Result<String, ReportError> {
    let json = data_json(input, limits)?;
    Ok(format!(
        "<div class=\"mgv\"><noscript>The 3D viewer needs JavaScript and WebGL.</noscript></div>\n\
         <script type=\"application/json\" class=\"mgv-data\">{json}</script>\n\
         <style>{STYLE}</style>\n<script>{SCRIPT}</script>\n"
    ))
}

/// A whole self-contained page holding the viewer and nothing else.
pub fn viewer_page(input: &ViewerInput, limits: &ViewerLimits) -> Result<String, ReportError> {
    let fragment = viewer_fragment(input, limits)?;
    Ok(format!(
        "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\
         <title>{} · meshgaze view</title>\
         <style>html,body{{margin:0;height:100%;overflow:hidden;background:#fff;font-family:system-ui,sans-serif}}\
         body>.mgv{{height:100vh;border:0}}</style></head>\n<body>\n{fragment}</body></html>\n",
        super::html::esc(&input.title)
    ))
}

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{peak_rss_mb, TimingError};
use crate::mesh::load_mesh;
use crate::progress::Silent;
use crate::protocol::{Protocol, BUILTIN_NAME};
use crate::stimulus::{render_stimulus, FrameImages, StimulusOptions};

/// What the stimulus measurement found.
#[derive(Debug, Serialize, Deserialize)]
pub struct StimulusCell {
    /// Triangles of the rendered mesh.
    pub triangles: usize,
    /// Frames of the video.
    pub frames: usize,
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// Frames per second.
    pub fps: u32,
    /// Frames rasterized.
    pub rendered: usize,
    /// Frames reused from an identical earlier one (the holds).
    pub reused: usize,
    /// Rasterizing, thread seconds summed over the segments.
    pub render_s: f64,
    /// H.264 encoding, thread seconds summed over the segments.
    pub encode_s: f64,
    /// Wall seconds in all.
    pub total_s: f64,
    /// Peak resident memory of the process, MB.
    pub peak_rss_mb: f64,
}

/// The built-in protocol's full 48 s stimulus of the 50k armadillo (~100k triangles), rendered
/// and encoded into a temporary folder (removed afterwards), in this process.
pub fn stimulus_cell(data: &Path) -> Result<StimulusCell, TimingError> {
    let mesh_path = data.join("meshes/classic/decimated_profactor_50k/armadillo.obj");
    let (protocol, text) = Protocol::builtin();
    let (mesh, _) = load_mesh(&mesh_path).map_err(|e| TimingError::Input {
        path: mesh_path.clone(),
        message: e.to_string(),
    })?;
    let out = std::env::temp_dir().join(format!("meshgaze-bench-stimulus-{}", std::process::id()));
    let options = StimulusOptions {
        frames: FrameImages::None,
        id_buffer: false,
        verify: false,
    };
    let rendered = render_stimulus(
        &mesh_path,
        &mesh,
        &protocol,
        &text,
        BUILTIN_NAME,
        &out,
        &options,
        &Silent,
    );
    let _ = std::fs::remove_dir_all(&out);
    let m = rendered.map_err(|e| TimingError::Step {
        step: "the stimulus render".to_string(),
        message: e.to_string(),
    })?;
    Ok(StimulusCell {
        triangles: mesh.triangles.len(),
        frames: m.video.frames,
        width: m.video.width,
        height: m.video.height,
        fps: m.video.fps,
        rendered: m.timings.frames_rendered,
        reused: m.timings.frames_reused,
        render_s: m.timings.render_s,
        encode_s: m.timings.encode_s,
        total_s: m.timings.total_s,
        peak_rss_mb: peak_rss_mb(),
    })
}

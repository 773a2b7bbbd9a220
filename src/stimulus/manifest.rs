//! manifest.json: what a rendered stimulus is, with the hashes later stages check.
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::camera::CameraPlan;
use crate::protocol::Protocol;
use crate::provenance::Provenance;

/// The stimulus video as written.
#[derive(Debug, Clone, Serialize)]
pub struct VideoFacts {
    /// Its file name in the stimulus folder (`stimulus.mp4`).
    pub file: String,
    /// SHA-256 of the file, checked when the stimulus is loaded.
    pub sha256: String,
    /// The codec and its settings, in words.
    pub codec: &'static str,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Frames per second.
    pub fps: u32,
    /// Frames in the video.
    pub frames: usize,
    /// Length in seconds.
    pub duration_s: f64,
    /// File size in bytes.
    pub bytes: u64,
}

/// Where the render's time went.
#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    /// Seconds spent drawing frames (and overlays, PNGs), summed over the video's two
    /// segments, which render side by side.
    pub render_s: f64,
    /// Seconds the segments' encoder threads spent encoding, summed. Renderers and encoders
    /// all run at once (on a 2-core machine they share the cores), so the two add up to more
    /// than `total_s`.
    pub encode_s: f64,
    /// Wall-clock seconds of the whole render.
    pub total_s: f64,
    /// Frames drawn by the rasterizer.
    pub frames_rendered: usize,
    /// Frames of a hold that repeat the hold's first picture, encoded without drawing again.
    pub frames_reused: usize,
}

/// What a decoded-back check found.
#[derive(Debug, Clone, Serialize)]
pub struct VerifyReport {
    /// Frames decoded back from the encoded stream.
    pub frames_decoded: usize,
    /// The lowest peak signal-to-noise ratio of a decoded frame against its render, dB.
    pub min_psnr_db: f64,
    /// Channel values off by more than 48 from the rendered frame, over all frames.
    pub outlier_values: usize,
}

/// manifest.json: what a rendered stimulus is, and the hashes that tie its files together.
#[derive(Debug, Clone, Serialize)]
pub struct Manifest {
    /// Tool version, inputs (mesh, protocol) with their hashes.
    pub provenance: Provenance,
    /// The protocol the stimulus was rendered under.
    pub protocol: Protocol,
    /// The protocol file's text, byte for byte.
    pub protocol_toml: String,
    /// SHA-256 of `protocol_toml`: an edited manifest is refused.
    pub protocol_sha256: String,
    /// The mesh shown.
    pub mesh: MeshFacts,
    /// The video.
    pub video: VideoFacts,
    /// The camera timeline CSV.
    pub timeline: TimelineFacts,
    /// The camera plan every frame's camera comes from.
    pub camera: CameraPlan,
    /// Where the render's time went.
    pub timings: Timings,
    /// The decoded-back check, when asked for.
    pub verify: Option<VerifyReport>,
}

/// The mesh a stimulus shows.
#[derive(Debug, Clone, Serialize)]
pub struct MeshFacts {
    /// The mesh file as given to the renderer.
    pub file: String,
    /// SHA-256 of the file: a mesh changed after rendering is refused.
    pub sha256: String,
    /// Its vertices.
    pub vertices: usize,
    /// Its triangles.
    pub triangles: usize,
}

/// The camera timeline CSV as written.
#[derive(Debug, Clone, Serialize)]
pub struct TimelineFacts {
    /// Its file name in the stimulus folder (`timeline.csv`).
    pub file: String,
    /// SHA-256 of the file.
    pub sha256: String,
    /// Rows, one per frame.
    pub rows: usize,
}

/// Where a stimulus folder keeps its manifest.
pub fn manifest_path(dir: &Path) -> PathBuf {
    dir.join("manifest.json")
}

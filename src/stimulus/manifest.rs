//! manifest.json: what a rendered stimulus is, with the hashes later stages check.
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::camera::CameraPlan;
use crate::protocol::Protocol;
use crate::provenance::Provenance;

#[derive(Debug, Clone, Serialize)]
pub struct VideoFacts {
    pub file: String,
    pub sha256: String,
    pub codec: &'static str,
    pub width: u32,
    pub height: u32,
    pub fps: u32,
    pub frames: usize,
    pub duration_s: f64,
    pub bytes: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    /// Seconds spent drawing frames (and overlays, PNGs), summed over the video's two
    /// segments, which render side by side.
    pub render_s: f64,
    /// Seconds the segments' encoder threads spent encoding, summed. Renderers and encoders
    /// all run at once (on a 2-core machine they share the cores), so the two add up to more
    /// than `total_s`.
    pub encode_s: f64,
    pub total_s: f64,
    pub frames_rendered: usize,
    pub frames_reused: usize,
}

/// What a decoded-back check found.
#[derive(Debug, Clone, Serialize)]
pub struct VerifyReport {
    pub frames_decoded: usize,
    pub min_psnr_db: f64,
    /// Channel values off by more than 48 from the rendered frame, over all frames.
    pub outlier_values: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct Manifest {
    pub provenance: Provenance,
    pub protocol: Protocol,
    /// The protocol file's text, byte for byte.
    pub protocol_toml: String,
    pub protocol_sha256: String,
    pub mesh: MeshFacts,
    pub video: VideoFacts,
    pub timeline: TimelineFacts,
    pub camera: CameraPlan,
    pub timings: Timings,
    pub verify: Option<VerifyReport>,
}

#[derive(Debug, Clone, Serialize)]
pub struct MeshFacts {
    pub file: String,
    pub sha256: String,
    pub vertices: usize,
    pub triangles: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct TimelineFacts {
    pub file: String,
    pub sha256: String,
    pub rows: usize,
}

/// The timeline CSV header: one row per frame.
/// Where a stimulus folder keeps its files.
pub fn manifest_path(dir: &Path) -> PathBuf {
    dir.join("manifest.json")
}

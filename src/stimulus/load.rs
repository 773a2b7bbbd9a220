//! Reopening a rendered stimulus for projection: the manifest's hashes must match the mesh,
//! protocol, video and timeline on disk, and the camera recomputed from mesh and protocol
//! must reproduce the timeline byte for byte. Then the projector uses exactly the camera the
//! subjects saw.
use std::path::{Path, PathBuf};

use serde_json::Value;

use super::camera::CameraPlan;
use super::{timeline_header, timeline_row};
use crate::mesh::{load_mesh, LoadReport, Mesh};
use crate::protocol::Protocol;
use crate::provenance::{sha256_hex, InputFile};

/// A stimulus whose files were checked against its manifest.
pub struct LoadedStimulus {
    pub manifest_path: PathBuf,
    pub manifest_sha256: String,
    pub mesh_path: PathBuf,
    pub mesh: Mesh,
    pub mesh_report: LoadReport,
    pub mesh_sha256: String,
    pub protocol: Protocol,
    /// The protocol's TOML text as recorded in the manifest.
    pub protocol_toml: String,
    pub protocol_sha256: String,
    pub video_path: PathBuf,
    pub video_sha256: String,
    pub plan: CameraPlan,
    pub fps: u32,
    pub video_width: u32,
    pub video_height: u32,
}

impl LoadedStimulus {
    /// The mesh file's name up to its first dot (`bun_zipper_res2` for
    /// `bun_zipper_res2.ply.gz`): how recordings usually name the stimulus.
    pub fn mesh_stem(&self) -> String {
        self.mesh_path
            .file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .split('.')
            .next()
            .unwrap_or("")
            .to_string()
    }
}

fn field<'a>(v: &'a Value, path: &[&str], file: &Path) -> Result<&'a Value, String> {
    let mut cur = v;
    for p in path {
        cur = cur.get(p).ok_or_else(|| {
            format!(
                "{}: the manifest has no `{}`; was it written by `meshgaze stimulus`?",
                file.display(),
                path.join(".")
            )
        })?;
    }
    Ok(cur)
}

fn text<'a>(v: &'a Value, path: &[&str], file: &Path) -> Result<&'a str, String> {
    field(v, path, file)?
        .as_str()
        .ok_or_else(|| format!("{}: `{}` is not text", file.display(), path.join(".")))
}

/// A file named in the manifest: as written (relative to the working directory when the
/// stimulus was rendered), else relative to the manifest's folder, unless overridden.
fn resolve(named: &str, manifest_dir: &Path) -> PathBuf {
    let p = PathBuf::from(named);
    if p.is_absolute() || p.exists() {
        p
    } else {
        manifest_dir.join(p)
    }
}

fn check_hash(path: &Path, expected: &str, what: &str) -> Result<String, String> {
    let got = InputFile::hash(path)
        .map_err(|e| format!("{what} {}: {e}", path.display()))?
        .sha256;
    if got != expected {
        return Err(format!(
            "{what} {} does not match the stimulus manifest (SHA-256 {got}, manifest says {expected}): the file changed after rendering, or it is another file",
            path.display()
        ));
    }
    Ok(got)
}

/// Opens `manifest.json` (or a folder holding one), checks every hash and the timeline.
/// `mesh_override` points at the mesh when it moved since rendering (its hash must still
/// match).
pub fn load_stimulus(
    manifest: &Path,
    mesh_override: Option<&Path>,
) -> Result<LoadedStimulus, String> {
    let manifest_path = if manifest.is_dir() {
        manifest.join("manifest.json")
    } else {
        manifest.to_path_buf()
    };
    let bytes =
        std::fs::read(&manifest_path).map_err(|e| format!("{}: {e}", manifest_path.display()))?;
    let v: Value = serde_json::from_slice(&bytes).map_err(|e| {
        format!(
            "{}:{}:{}: not a stimulus manifest: {e}",
            manifest_path.display(),
            e.line(),
            e.column()
        )
    })?;
    let dir = manifest_path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    let mp = &manifest_path;
    // Protocol: the manifest carries its text; the hash guards against edits.
    let protocol_text = text(&v, &["protocol_toml"], mp)?;
    let protocol_sha = text(&v, &["protocol_sha256"], mp)?;
    if sha256_hex(protocol_text.as_bytes()) != protocol_sha {
        return Err(format!(
            "{}: the protocol text does not match its recorded SHA-256: the manifest was edited",
            mp.display()
        ));
    }
    let protocol = Protocol::from_toml(protocol_text, &format!("{} (protocol_toml)", mp.display()))
        .map_err(|e| e.to_string())?;
    // Mesh.
    let mesh_path = match mesh_override {
        Some(p) => p.to_path_buf(),
        None => resolve(text(&v, &["mesh", "file"], mp)?, &dir),
    };
    let mesh_sha256 = check_hash(&mesh_path, text(&v, &["mesh", "sha256"], mp)?, "mesh")?;
    let (mesh, mesh_report) = load_mesh(&mesh_path).map_err(|e| e.to_string())?;
    // Video.
    let video_path = dir.join(text(&v, &["video", "file"], mp)?);
    let video_sha256 = check_hash(&video_path, text(&v, &["video", "sha256"], mp)?, "video")?;
    // Timeline: hash, then every row recomputed.
    let timeline_path = dir.join(text(&v, &["timeline", "file"], mp)?);
    check_hash(
        &timeline_path,
        text(&v, &["timeline", "sha256"], mp)?,
        "timeline",
    )?;
    let plan = CameraPlan::new(&mesh, &protocol)?;
    let fps = protocol.video.fps;
    let timeline = std::fs::read_to_string(&timeline_path)
        .map_err(|e| format!("{}: {e}", timeline_path.display()))?;
    let mut lines = timeline.lines();
    if lines.next() != Some(timeline_header().as_str()) {
        return Err(format!(
            "{}:1: unexpected header (written by another meshgaze version?)",
            timeline_path.display()
        ));
    }
    let mut rows = 0;
    for (i, line) in lines.enumerate() {
        let expected = timeline_row(i, &plan.at(i as f64 / fps as f64));
        if line != expected {
            return Err(format!(
                "{}:{}: the camera recomputed from the mesh and protocol differs from the recorded one (another meshgaze version or a modified file); refusing to project with a camera the subjects did not see",
                timeline_path.display(),
                i + 2
            ));
        }
        rows += 1;
    }
    if rows != protocol.frame_count() {
        return Err(format!(
            "{}: {rows} frames, the protocol has {}",
            timeline_path.display(),
            protocol.frame_count()
        ));
    }
    Ok(LoadedStimulus {
        manifest_sha256: sha256_hex(&bytes),
        manifest_path,
        mesh_path,
        mesh,
        mesh_report,
        mesh_sha256,
        video_width: protocol.display.width_px,
        video_height: protocol.display.height_px,
        protocol_sha256: protocol_sha.to_string(),
        protocol_toml: protocol_text.to_string(),
        protocol,
        video_path,
        video_sha256,
        plan,
        fps,
    })
}

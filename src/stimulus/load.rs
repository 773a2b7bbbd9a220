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

/// Why a rendered stimulus cannot be used for projection. The variants that say a file
/// changed after rendering ([`StimulusLoadError::Changed`], [`StimulusLoadError::ProtocolEdited`],
/// [`StimulusLoadError::CameraDiffers`]) are told apart from a missing or unreadable stimulus
/// by callers such as `study`, which explain what a changed mesh means for its subjects.
#[derive(Debug, thiserror::Error)]
pub enum StimulusLoadError {
    /// A file could not be read.
    #[error("{}: {error}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// The manifest is not JSON.
    #[error("{}:{line}:{column}: not a stimulus manifest: {message}", path.display())]
    NotJson {
        /// The manifest.
        path: PathBuf,
        /// Line of the syntax error (1-based).
        line: usize,
        /// Column of the syntax error (1-based).
        column: usize,
        /// The parser's message.
        message: String,
    },
    /// The manifest lacks a field, or has it with the wrong type.
    #[error("{}: {message}", path.display())]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// Which field and what is wrong with it.
        message: String,
    },
    /// The protocol text in the manifest no longer matches its recorded hash.
    #[error("{}: the protocol text does not match its recorded SHA-256: the manifest was edited", path.display())]
    ProtocolEdited {
        /// The manifest.
        path: PathBuf,
    },
    /// The mesh, video or timeline is not the file the manifest recorded.
    #[error("{what} {} does not match the stimulus manifest (SHA-256 {got}, manifest says {expected}): the file changed after rendering, or it is another file", path.display())]
    Changed {
        /// `mesh`, `video` or `timeline`.
        what: &'static str,
        /// The file on disk.
        path: PathBuf,
        /// Its SHA-256 now.
        got: String,
        /// The SHA-256 the manifest recorded.
        expected: String,
    },
    /// The camera recomputed from mesh and protocol differs from a timeline row.
    #[error("{}:{line}: the camera recomputed from the mesh and protocol differs from the recorded one (another meshgaze version or a modified file); refusing to project with a camera the subjects did not see", path.display())]
    CameraDiffers {
        /// The timeline.
        path: PathBuf,
        /// The first differing line (1-based, header is line 1).
        line: usize,
    },
    /// The timeline's header or length is not what this version writes.
    #[error("{}{message}", path.display())]
    Timeline {
        /// The timeline.
        path: PathBuf,
        /// `:1: unexpected header ...` or `: N frames, ...`.
        message: String,
    },
    /// The protocol or mesh stage refused (its text names the file).
    #[error("{0}")]
    Stage(String),
    /// No camera plan frames the stimulus's mesh.
    #[error("{0}")]
    Camera(#[from] crate::stimulus::camera::CameraError),
}

impl StimulusLoadError {
    /// True when a file of the stimulus changed after it was rendered (as opposed to
    /// missing, unreadable or malformed).
    pub fn is_changed_after_rendering(&self) -> bool {
        matches!(
            self,
            StimulusLoadError::Changed { .. }
                | StimulusLoadError::ProtocolEdited { .. }
                | StimulusLoadError::CameraDiffers { .. }
        )
    }
}

/// A stimulus whose files were checked against its manifest.
pub struct LoadedStimulus {
    /// manifest.json.
    pub manifest_path: PathBuf,
    /// SHA-256 of manifest.json, for the provenance of what is computed from it.
    pub manifest_sha256: String,
    /// The mesh file (the manifest's, or the one given instead).
    pub mesh_path: PathBuf,
    /// The mesh, read.
    pub mesh: Mesh,
    /// What the mesh reader found.
    pub mesh_report: LoadReport,
    /// SHA-256 of the mesh file, equal to the manifest's.
    pub mesh_sha256: String,
    /// The protocol the stimulus was rendered under.
    pub protocol: Protocol,
    /// The protocol's TOML text as recorded in the manifest.
    pub protocol_toml: String,
    /// SHA-256 of that text, equal to the manifest's.
    pub protocol_sha256: String,
    /// stimulus.mp4.
    pub video_path: PathBuf,
    /// SHA-256 of the video, equal to the manifest's.
    pub video_sha256: String,
    /// The camera plan, recomputed from the mesh and protocol and checked against every
    /// timeline row.
    pub plan: CameraPlan,
    /// The video's frame rate.
    pub fps: u32,
    /// The video's width, px.
    pub video_width: u32,
    /// The video's height, px.
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

fn field<'a>(v: &'a Value, path: &[&str], file: &Path) -> Result<&'a Value, StimulusLoadError> {
    let mut cur = v;
    for p in path {
        cur = cur.get(p).ok_or_else(|| StimulusLoadError::Manifest {
            path: file.to_path_buf(),
            message: format!(
                "the manifest has no `{}`; was it written by `meshgaze stimulus`?",
                path.join(".")
            ),
        })?;
    }
    Ok(cur)
}

fn text<'a>(v: &'a Value, path: &[&str], file: &Path) -> Result<&'a str, StimulusLoadError> {
    field(v, path, file)?
        .as_str()
        .ok_or_else(|| StimulusLoadError::Manifest {
            path: file.to_path_buf(),
            message: format!("`{}` is not text", path.join(".")),
        })
}

/// A file named in the manifest: relative to the manifest's folder (as `stimulus` writes
/// it), or absolute. Manifests written before 2026-12-07 named the mesh as given on the
/// command line, relative to the working directory of that run: such a name is still taken
/// from the working directory when nothing of that name lies beside the manifest; the
/// manifest's sha256 then refuses any other file of that name.
fn resolve(named: &str, manifest_dir: &Path) -> PathBuf {
    let p = PathBuf::from(named);
    if p.is_absolute() {
        return p;
    }
    let beside = manifest_dir.join(&p);
    if beside.exists() || !p.exists() {
        beside
    } else {
        p
    }
}

fn check_hash(
    path: &Path,
    expected: &str,
    what: &'static str,
) -> Result<String, StimulusLoadError> {
    let got = InputFile::hash(path)
        .map_err(|e| StimulusLoadError::Stage(format!("{what} {}: {e}", path.display())))?
        .sha256;
    if got != expected {
        return Err(StimulusLoadError::Changed {
            what,
            path: path.to_path_buf(),
            got,
            expected: expected.to_string(),
        });
    }
    Ok(got)
}

/// Opens `manifest.json` (or a folder holding one), checks every hash and the timeline.
/// `mesh_override` points at the mesh when it moved since rendering (its hash must still
/// match).
pub fn load_stimulus(
    manifest: &Path,
    mesh_override: Option<&Path>,
) -> Result<LoadedStimulus, StimulusLoadError> {
    let manifest_path = if manifest.is_dir() {
        manifest.join("manifest.json")
    } else {
        manifest.to_path_buf()
    };
    let bytes = std::fs::read(&manifest_path).map_err(|error| StimulusLoadError::Read {
        path: manifest_path.clone(),
        error,
    })?;
    let v: Value = serde_json::from_slice(&bytes).map_err(|e| StimulusLoadError::NotJson {
        path: manifest_path.clone(),
        line: e.line(),
        column: e.column(),
        message: e.to_string(),
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
        return Err(StimulusLoadError::ProtocolEdited { path: mp.clone() });
    }
    let protocol = Protocol::from_toml(protocol_text, &format!("{} (protocol_toml)", mp.display()))
        .map_err(|e| StimulusLoadError::Stage(e.to_string()))?;
    // Mesh.
    let mesh_path = match mesh_override {
        Some(p) => p.to_path_buf(),
        None => {
            let named = text(&v, &["mesh", "file"], mp)?;
            let path = resolve(named, &dir);
            if !path.exists() {
                return Err(StimulusLoadError::Stage(format!(
                    "{} names the mesh `{named}`, and there is no such file at {}: give the mesh with --mesh FILE (its sha256 must be the manifest's)",
                    mp.display(),
                    path.display()
                )));
            }
            path
        }
    };
    let mesh_sha256 = check_hash(&mesh_path, text(&v, &["mesh", "sha256"], mp)?, "mesh")?;
    let (mesh, mesh_report) =
        load_mesh(&mesh_path).map_err(|e| StimulusLoadError::Stage(e.to_string()))?;
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
    let timeline =
        std::fs::read_to_string(&timeline_path).map_err(|error| StimulusLoadError::Read {
            path: timeline_path.clone(),
            error,
        })?;
    let mut lines = timeline.lines();
    if lines.next() != Some(timeline_header().as_str()) {
        return Err(StimulusLoadError::Timeline {
            path: timeline_path,
            message: ":1: unexpected header (written by another meshgaze version?)".to_string(),
        });
    }
    let mut rows = 0;
    for (i, line) in lines.enumerate() {
        let expected = timeline_row(i, &plan.at(i as f64 / fps as f64));
        if line != expected {
            return Err(StimulusLoadError::CameraDiffers {
                path: timeline_path,
                line: i + 2,
            });
        }
        rows += 1;
    }
    if rows != protocol.frame_count() {
        return Err(StimulusLoadError::Timeline {
            path: timeline_path,
            message: format!(
                ": {rows} frames, the protocol has {}",
                protocol.frame_count()
            ),
        });
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

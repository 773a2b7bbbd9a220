//! study.toml: what a study is made of, with paths and globs relative to the file itself.
use std::path::{Path, PathBuf};

use super::error::{OrStage, StudyError};

type Result<T, E = StudyError> = std::result::Result<T, E>;
use serde::Deserialize;

use crate::protocol::Protocol;
use crate::saliency::{Method, RarityParams, PAPER_METHODS};

/// The file as written (see docs/study.md).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StudyFile {
    /// The protocol file; unset: the built-in hu2020 protocol.
    pub protocol: Option<PathBuf>,
    /// Mesh files or globs (`meshes/*.ply`).
    pub meshes: Vec<String>,
    /// Recording files or globs (any format ingest reads, mixed); may match nothing yet (the
    /// stimuli come first).
    #[serde(default)]
    pub recordings: Vec<String>,
    /// Saliency methods to compute and score.
    #[serde(default = "default_methods")]
    pub methods: Vec<Method>,
    /// Parameters of sri, gr and mr as `METHOD.NAME=VALUE`, as `meshgaze saliency --set`.
    #[serde(default)]
    pub set: Vec<String>,
    /// Output folder; unset: `study/` beside study.toml.
    pub output: Option<PathBuf>,
    /// Messages that start a stimulus (one capture group, the video file name); unset: the
    /// protocol's, else any message naming an image or video file.
    pub stimulus_pattern: Option<String>,
    /// Messages that end the running stimulus.
    pub stimulus_end_pattern: Option<String>,
}

fn default_methods() -> Vec<Method> {
    PAPER_METHODS.to_vec()
}

/// A mesh of the study: its name (the file stem, which a video file's stem must equal).
#[derive(Debug, Clone, PartialEq)]
pub struct StudyMesh {
    /// The file stem.
    pub name: String,
    /// The mesh file.
    pub path: PathBuf,
}

/// A study with every path resolved.
#[derive(Debug, Clone)]
pub struct Study {
    /// study.toml.
    pub file: PathBuf,
    /// The protocol (the file's, or the built-in one).
    pub protocol: Protocol,
    /// The protocol's TOML text.
    pub protocol_text: String,
    /// How the protocol is named in provenance.
    pub protocol_name: String,
    /// Sorted by name.
    pub meshes: Vec<StudyMesh>,
    /// Sorted.
    pub recordings: Vec<PathBuf>,
    /// The saliency methods computed and scored on every mesh.
    pub methods: Vec<Method>,
    /// The `set` lines as written, and the parameters they give.
    pub settings: Vec<String>,
    /// The rarity parameters those settings give.
    pub rarity: RarityParams,
    /// The output folder.
    pub output: PathBuf,
    /// Overrides the protocol's stimulus-start message pattern.
    pub stimulus_pattern: Option<String>,
    /// Overrides the protocol's stimulus-end message pattern.
    pub stimulus_end_pattern: Option<String>,
    /// Patterns that matched no file, for the log.
    pub unmatched: Vec<String>,
}

/// A study names each mesh by its file's stem (up to the first dot); the viewer, below study
/// in the import order, names maps the same way, so the rule lives with the file helpers.
pub use crate::file_bytes::stem_of;

fn expand(
    base: &Path,
    patterns: &[String],
    what: &str,
    unmatched: &mut Vec<String>,
) -> Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in patterns {
        let full = base.join(p);
        let text = full.to_string_lossy().to_string();
        let mut hits: Vec<PathBuf> = glob::glob(&text)
            .map_err(|e| {
                StudyError::Invalid(format!("{what} pattern `{p}` is not a valid glob: {e}"))
            })?
            .filter_map(|e| e.ok())
            .filter(|p| p.is_file())
            .collect();
        if hits.is_empty() {
            unmatched.push(format!("{what} `{p}` matched no file (looked for {text})"));
        }
        out.append(&mut hits);
    }
    out.sort();
    out.dedup();
    Ok(out)
}

impl Study {
    /// Reads and resolves study.toml; errors name the file, line and column.
    pub fn load(path: &Path) -> Result<Study> {
        let config_error = |message: String| StudyError::Config {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read_to_string(path).map_err(StudyError::io("read", &path))?;
        let file: StudyFile =
            toml::from_str(&text).map_err(|e| config_error(located(&text, &e)))?;
        let base = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_path_buf();
        let (protocol, protocol_text, protocol_name) =
            Protocol::load_or_builtin(file.protocol.as_ref().map(|p| base.join(p)).as_deref())
                .or_stage()?;
        let mut unmatched = Vec::new();
        let mesh_paths = expand(&base, &file.meshes, "meshes", &mut unmatched)?;
        let mut meshes: Vec<StudyMesh> = mesh_paths
            .into_iter()
            .filter(|p| crate::mesh::MeshFormat::from_path(p).is_some())
            .map(|p| StudyMesh {
                name: stem_of(&p),
                path: p,
            })
            .collect();
        meshes.sort_by(|a, b| a.name.cmp(&b.name).then(a.path.cmp(&b.path)));
        if let Some(w) = meshes.windows(2).find(|w| w[0].name == w[1].name) {
            return Err(config_error(format!(
                "two meshes are named `{}` ({} and {}): a video is mapped to its mesh by name, so names must differ",
                w[0].name,
                w[0].path.display(),
                w[1].path.display()
            )));
        }
        if meshes.is_empty() {
            return Err(config_error(
                "`meshes` matched no mesh file (.obj, .ply, .off, optionally .gz)".into(),
            ));
        }
        if file.methods.is_empty() {
            return Err(config_error(
                "`methods` is empty; name at least one (sms, mc, ms, si, sri, mr, gr, up, centre, gaze)".into(),
            ));
        }
        let rarity = RarityParams::default()
            .with_settings(&file.set)
            .map_err(|e| config_error(format!("`set`: {e}")))?;
        let recordings = expand(&base, &file.recordings, "recordings", &mut unmatched)?;
        Ok(Study {
            file: path.to_path_buf(),
            protocol,
            protocol_text,
            protocol_name,
            meshes,
            recordings,
            methods: file.methods,
            settings: file.set,
            rarity,
            output: base.join(file.output.unwrap_or_else(|| PathBuf::from("study"))),
            stimulus_pattern: file.stimulus_pattern,
            stimulus_end_pattern: file.stimulus_end_pattern,
            unmatched,
        })
    }
}

/// A TOML error as `line L, column C: message`.
fn located(text: &str, e: &toml::de::Error) -> String {
    match e.span() {
        Some(span) => {
            let before = &text[..span.start.min(text.len())];
            let line = before.matches('\n').count() + 1;
            let column = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
            format!("line {line}, column {column}: {}", e.message())
        }
        None => e.message().to_string(),
    }
}

/// A commented study.toml for the meshes in `mesh_dir`.
pub fn template(mesh_dir: &str, recordings: &str) -> String {
    format!(
        r#"# A meshgaze study (docs/study.md). Paths and globs are relative to this file.

# The experiment protocol; unset: the built-in paper protocol (meshgaze protocol show).
# protocol = "my-protocol.toml"

# The meshes shown. A video is named after its mesh (bunny.ply -> bunny.mp4), and a
# recording's message naming bunny.mp4 maps its fixations back to bunny.ply.
meshes = ["{mesh_dir}/*.ply", "{mesh_dir}/*.obj", "{mesh_dir}/*.off"]

# The SMI exports, one per subject, each playing every video (sample or event exports).
# They may not exist yet: `meshgaze study run` renders the stimuli first.
recordings = ["{recordings}"]

# Saliency methods to compute and score against the subjects' fixations.
# The default is the paper's seven; each also takes up (height), centre (screen-centre
# prior) and gaze (the learned model).
methods = ["sms", "mc", "ms", "si", "sri", "mr", "gr"]

# Parameters of sri, gr and mr, as `meshgaze saliency --set` takes them
# (docs/baselines.md lists every one). Changing one recomputes only that method's maps.
# set = ["sri.most_similar=32", "gr.radii=[0.1, 0.2]"]

# Output folder (default: study/ beside this file).
# output = "study"

# Which messages start a stimulus: one capture group around the video name. Unset: any
# message naming an image or video file. `meshgaze ingest --list-messages FILE` shows them.
# stimulus_pattern = '^play (.*)$'
"#
    )
}

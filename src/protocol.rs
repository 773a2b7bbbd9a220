//! Experiment protocols as data: everything a stimulus and the later stages fix, read from
//! TOML (protocols/README.md documents every field).
use std::path::Path;

use serde::{Deserialize, Serialize};

/// `v` is positive and finite, else the rule naming `what`.
fn positive(v: f64, what: &str) -> Result<(), ProtocolRuleError> {
    if v > 0.0 && v.is_finite() {
        Ok(())
    } else {
        Err(ProtocolRuleError::from(format!(
            "{what} must be positive (got {v})"
        )))
    }
}

/// A protocol's values contradict each other or are out of range; the message names the
/// field (`Protocol::validate`).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ProtocolRuleError(pub String);

impl From<String> for ProtocolRuleError {
    fn from(message: String) -> Self {
        ProtocolRuleError(message)
    }
}

impl From<&str> for ProtocolRuleError {
    fn from(message: &str) -> Self {
        ProtocolRuleError(message.to_string())
    }
}

/// Why a protocol file could not be used; every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum ProtocolError {
    /// The file could not be read.
    #[error("{path}: {error}")]
    Io {
        /// The file.
        path: String,
        /// The I/O error.
        error: std::io::Error,
    },
    /// The file is not TOML of the protocol's shape (the message has the line and column).
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: String,
        /// The TOML parser's message.
        message: String,
    },
    /// The values contradict each other or are out of range.
    #[error("{path}: invalid protocol: {message}")]
    Invalid {
        /// The file.
        path: String,
        /// Which field and why.
        message: String,
    },
}

/// An experiment protocol: the display, the video, the viewpoints and their timing, the
/// rendering, the synchronisation marks and the fixation rules every later stage applies.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Protocol {
    /// Schema version of this file format (1).
    pub version: u32,
    /// A short name, recorded in every output's provenance.
    pub name: String,
    /// Free text: where the protocol comes from.
    #[serde(default)]
    pub description: String,
    /// The screen the subjects watched.
    pub display: Display,
    /// The stimulus video's encoding.
    pub video: Video,
    /// Which directions the camera holds on, and in which order.
    pub viewpoints: Viewpoints,
    /// How long each hold and each move lasts.
    pub timing: Timing,
    /// How the mesh is drawn.
    pub rendering: Rendering,
    /// Marks burned into the video to synchronise it with a recording.
    #[serde(default)]
    pub sync: Sync,
    /// The fixation detector's settings and the protocol's fixation filter.
    pub fixations: FixationRules,
}

/// The screen the stimulus is shown on.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Display {
    /// Screen width in pixels (the video's width).
    pub width_px: u32,
    /// Screen height in pixels (the video's height).
    pub height_px: u32,
    /// Visible screen width in millimetres.
    pub width_mm: f64,
    /// Visible screen height in millimetres.
    pub height_mm: f64,
    /// Nearest and farthest eye-to-screen distance of the subjects.
    pub viewing_distance_mm: [f64; 2],
}

/// The stimulus video's encoding.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Video {
    /// Frames per second.
    pub fps: u32,
    /// Target H.264 bit rate in bits per second.
    pub bitrate_bps: u32,
    /// Frames between IDR frames (seekable points).
    pub keyframe_interval_frames: u32,
}

/// How the viewpoint directions are made.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum ViewpointGenerator {
    /// The 12 vertex directions of a regular icosahedron: the whole surface from evenly
    /// spread directions.
    Icosahedron,
    /// `count` directions evenly spaced in azimuth around the up axis at `elevation_deg`.
    Turntable,
    /// The `directions` given.
    List,
}

/// The axis a mesh file holds as up, as its subjects saw it (Y in the Stanford and 3DVA meshes
/// the built-in protocol and gaze model assume; Z in much CAD and Blender output).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum UpAxis {
    /// +x.
    X,
    /// +y.
    Y,
    /// +z.
    Z,
    /// −x.
    #[cfg_attr(feature = "cli", value(name = "neg-x"))]
    NegX,
    /// −y.
    #[cfg_attr(feature = "cli", value(name = "neg-y"))]
    NegY,
    /// −z.
    #[cfg_attr(feature = "cli", value(name = "neg-z"))]
    NegZ,
}

impl UpAxis {
    /// The axis as a unit vector.
    pub fn direction(self) -> [f64; 3] {
        match self {
            UpAxis::X => [1.0, 0.0, 0.0],
            UpAxis::Y => [0.0, 1.0, 0.0],
            UpAxis::Z => [0.0, 0.0, 1.0],
            UpAxis::NegX => [-1.0, 0.0, 0.0],
            UpAxis::NegY => [0.0, -1.0, 0.0],
            UpAxis::NegZ => [0.0, 0.0, -1.0],
        }
    }

    /// How the axis is written (`+z`, `-y`).
    pub fn label(self) -> &'static str {
        match self {
            UpAxis::X => "+x",
            UpAxis::Y => "+y",
            UpAxis::Z => "+z",
            UpAxis::NegX => "-x",
            UpAxis::NegY => "-y",
            UpAxis::NegZ => "-z",
        }
    }
}

/// One protocol shown to several datasets whose meshes may store different up axes (a lab's
/// +z-up meshes trained beside the +y-up VR ones): each dataset, by folder name, sees the
/// protocol turned to its own up axis ([`Protocol::with_up_axis`]).
#[derive(Debug, Clone)]
pub struct ProtocolPerDataset {
    /// The protocol as given.
    pub base: Protocol,
    /// Datasets (folder names) whose meshes hold another up axis.
    pub up_axes: Vec<(String, UpAxis)>,
}

impl ProtocolPerDataset {
    /// Every dataset sees `base` as it is.
    pub fn same_for_all(base: Protocol) -> ProtocolPerDataset {
        ProtocolPerDataset {
            base,
            up_axes: Vec::new(),
        }
    }

    /// The protocol dataset `name` was shown.
    pub fn for_dataset(&self, name: &str) -> Protocol {
        match self.up_axes.iter().find(|(d, _)| d == name) {
            Some((_, axis)) => self.base.clone().with_up_axis(*axis),
            None => self.base.clone(),
        }
    }

    /// The name a model records: the protocol's, with each dataset's own up axis.
    pub fn name(&self) -> String {
        let mut name = self.base.name.clone();
        for (dataset, axis) in &self.up_axes {
            name.push_str(&format!(" ({dataset}: up {})", axis.label()));
        }
        name
    }
}

/// The directions the camera holds on, and the order of the tour.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Viewpoints {
    /// How the directions are made.
    pub generator: ViewpointGenerator,
    /// How many holds the video has (12 in the paper).
    pub count: usize,
    /// Turntable only.
    #[serde(default)]
    pub elevation_deg: f64,
    /// List only: directions from the mesh centre to the camera.
    #[serde(default)]
    pub directions: Vec<[f64; 3]>,
    /// The tour starts at the direction closest to this one, then always moves to the nearest
    /// direction not yet shown.
    pub first: [f64; 3],
    /// The mesh's up axis: screen-up at every keyframe (where the view is not along it).
    pub up: [f64; 3],
}

/// How the camera speeds up and slows down between two holds.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Easing {
    /// Constant speed (a jolt at both ends).
    Linear,
    /// ½ − ½ cos(π s): zero speed at both ends, peak speed π/2 × the mean.
    Cosine,
    /// 3s² − 2s³: zero speed at both ends, peak speed 1.5 × the mean.
    Smoothstep,
}

impl Easing {
    /// The eased fraction of the move at time fraction `s` (clamped to 0..=1).
    pub fn apply(self, s: f64) -> f64 {
        let s = s.clamp(0.0, 1.0);
        match self {
            Easing::Linear => s,
            Easing::Cosine => 0.5 - 0.5 * (std::f64::consts::PI * s).cos(),
            Easing::Smoothstep => s * s * (3.0 - 2.0 * s),
        }
    }

    /// Largest d(eased)/ds.
    pub fn peak_rate(self) -> f64 {
        match self {
            Easing::Linear => 1.0,
            Easing::Cosine => std::f64::consts::FRAC_PI_2,
            Easing::Smoothstep => 1.5,
        }
    }
}

/// How long each hold and each move lasts.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Timing {
    /// Seconds the camera holds on each viewpoint (3 in the paper).
    pub hold_s: f64,
    /// Seconds of each move between two viewpoints (1 in the paper).
    pub move_s: f64,
    /// The speed profile of a move.
    pub easing: Easing,
    /// After the last hold, move back to the first viewpoint (this fills the paper's 48th
    /// second: 12 × (3 + 1) = 48 s). Without it the video ends on the last hold.
    pub return_to_first: bool,
}

/// How the mesh is drawn.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Rendering {
    /// Background colour (RGB).
    pub background: [u8; 3],
    /// The mesh's colour (RGB), untextured.
    pub material: [u8; 3],
    /// Ambient light, 0..=1.
    pub ambient: f64,
    /// Diffuse (Lambert) light, 0..=1.
    pub diffuse: f64,
    /// Light direction in camera coordinates (x right, y up, z towards the viewer): a
    /// headlight, so every view is lit the same way.
    pub light_direction: [f64; 3],
    /// Vertical field of view.
    pub field_of_view_deg: f64,
    /// The mesh's bounding sphere spans this fraction of the screen height.
    pub fill: f64,
    /// Samples per pixel along each axis for anti-aliasing (1 = none).
    pub supersampling: u32,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq, Default)]
#[serde(rename_all = "kebab-case")]
/// A corner of the screen.
pub enum Corner {
    /// Top left.
    TopLeft,
    /// Top right.
    TopRight,
    /// Bottom left.
    BottomLeft,
    /// Bottom right (the default: away from the frame counter).
    #[default]
    BottomRight,
}

/// Marks burned into the video to synchronise it with a recording.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq, Default)]
#[serde(deny_unknown_fields)]
pub struct Sync {
    /// A square white during holds and black during moves, for a photodiode on the screen.
    #[serde(default)]
    pub photodiode: bool,
    /// Where the photodiode square is.
    #[serde(default)]
    pub photodiode_corner: Corner,
    /// The photodiode square's side in pixels.
    #[serde(default = "default_patch")]
    pub photodiode_size_px: u32,
    /// The frame index burned into the top-left corner.
    #[serde(default)]
    pub frame_counter: bool,
}

fn default_patch() -> u32 {
    40
}

/// Which camera a fixation that overlaps a move is projected with.
#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum DuringMove {
    /// Use the camera at the fixation's mid-time.
    Mid,
    /// Use the camera at the fixation's start.
    Start,
    /// Reject fixations that overlap a move.
    Reject,
}

/// The fixation detector's settings, the protocol's fixation filter and the stimulus rules.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct FixationRules {
    /// Fixations dropped at the start of each subject's viewing of a stimulus (2 in the paper).
    pub drop_first: usize,
    /// Fixations dropped at its end (2 in the paper).
    pub drop_last: usize,
    /// Of the rest, the longest kept (15 in the paper).
    pub keep_longest: usize,
    /// The largest calibration error, in degrees, at which the experimenter accepts a
    /// calibration (recorded in provenance; the exports carry no calibration result to check).
    pub calibration_accept_deg: f64,
    /// The tracker's accuracy in degrees: the radius of the cone a fixation is snapped within.
    pub tracker_accuracy_deg: f64,
    /// Which camera a fixation that overlaps a move is projected with.
    pub during_move: DuringMove,
    /// I-DT: largest dispersion, (max x − min x) + (max y − min y) in pixels (SMI's low-speed
    /// detector default 100 px).
    #[serde(default = "default_dispersion")]
    pub idt_max_dispersion_px: f64,
    /// Shortest fixation either detector reports (SMI's low-speed default 80 ms).
    #[serde(default = "default_min_duration")]
    pub min_duration_ms: f64,
    /// I-VT: largest gaze speed inside a fixation, in degrees of visual angle per second,
    /// converted to pixels with the display's size and mean viewing distance.
    #[serde(default = "default_velocity")]
    pub ivt_max_velocity_deg_s: f64,
    /// A regular expression with one capture group, the stimulus name, for the messages that
    /// start a stimulus (None: messages naming an image or video file).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stimulus_pattern: Option<String>,
    /// A regular expression for messages that end the running stimulus.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stimulus_end_pattern: Option<String>,
}

fn default_dispersion() -> f64 {
    100.0
}
fn default_min_duration() -> f64 {
    80.0
}
fn default_velocity() -> f64 {
    40.0
}

impl Display {
    /// Screen pixels per degree of visual angle at the mean viewing distance (centre of the
    /// screen).
    pub fn pixels_per_degree(&self) -> f64 {
        let distance = 0.5 * (self.viewing_distance_mm[0] + self.viewing_distance_mm[1]);
        let mm_per_degree = distance * 1f64.to_radians().tan();
        mm_per_degree * self.width_px as f64 / self.width_mm
    }
}

/// The paper's protocol (protocols/hu2020.toml), compiled into the binary so no default
/// depends on the working directory.
pub const BUILTIN_TOML: &str = include_str!("../protocols/hu2020.toml");
/// How the built-in protocol is named in provenance and messages.
pub const BUILTIN_NAME: &str = "built-in:hu2020.toml";

impl Protocol {
    /// The built-in protocol and its text.
    pub fn builtin() -> (Protocol, String) {
        let p = Protocol::from_toml(BUILTIN_TOML, BUILTIN_NAME)
            .expect("the built-in protocol is checked by the test suite");
        (p, BUILTIN_TOML.to_string())
    }

    /// The same protocol for meshes whose up axis is `axis`: its viewpoint frame (up, the
    /// first view and any listed directions) turned by the shortest rotation that takes its
    /// up to `axis`, so a mesh stored with another up axis is seen as the protocol's meshes
    /// are (the `up`, `centre` and `gaze` methods read up and the views from here). The
    /// icosahedron generator's 12 directions stay where they are: they cover every direction
    /// evenly whichever way is up, and the tour starts from the turned first view. The name
    /// records the change. Unchanged when the protocol's up already is `axis`.
    pub fn with_up_axis(mut self, axis: UpAxis) -> Protocol {
        let from = glam::DVec3::from_array(self.viewpoints.up).normalize_or(glam::DVec3::Y);
        let to = glam::DVec3::from_array(axis.direction());
        if from.abs_diff_eq(to, 1e-12) {
            return self;
        }
        let turn = glam::DQuat::from_rotation_arc(from, to);
        let rotate = |v: [f64; 3]| (turn * glam::DVec3::from_array(v)).to_array();
        self.viewpoints.up = axis.direction();
        self.viewpoints.first = rotate(self.viewpoints.first);
        for d in &mut self.viewpoints.directions {
            *d = rotate(*d);
        }
        self.name = format!("{} (up {})", self.name, axis.label());
        self
    }

    /// The protocol at `path`, or the built-in one; with its text and its name for provenance.
    pub fn load_or_builtin(
        path: Option<&Path>,
    ) -> Result<(Protocol, String, String), ProtocolError> {
        match path {
            Some(p) => {
                let (protocol, text) = Protocol::load(p)?;
                Ok((protocol, text, p.display().to_string()))
            }
            None => {
                let (protocol, text) = Protocol::builtin();
                Ok((protocol, text, BUILTIN_NAME.to_string()))
            }
        }
    }

    /// A protocol from TOML text, checked; `path` names it in errors.
    pub fn from_toml(text: &str, path: &str) -> Result<Protocol, ProtocolError> {
        let p: Protocol = toml::from_str(text).map_err(|e| ProtocolError::Parse {
            path: path.to_string(),
            message: e.to_string().trim_end().to_string(),
        })?;
        p.validate().map_err(|e| ProtocolError::Invalid {
            path: path.to_string(),
            message: e.0,
        })?;
        Ok(p)
    }

    /// The protocol in the TOML file at `path`, with its text.
    pub fn load(path: &Path) -> Result<(Protocol, String), ProtocolError> {
        let text = std::fs::read_to_string(path).map_err(|source| ProtocolError::Io {
            path: path.display().to_string(),
            error: source,
        })?;
        Ok((
            Protocol::from_toml(&text, &path.display().to_string())?,
            text,
        ))
    }

    /// Checks that the values are usable together; the message names the field.
    pub fn validate(&self) -> Result<(), ProtocolRuleError> {
        self.check_patterns()?;
        self.check_display_and_video()?;
        self.check_viewpoints_and_timing()?;
        self.check_rendering_and_fixations()
    }

    /// The message patterns compile, and the onset pattern has its one capture group.
    fn check_patterns(&self) -> Result<(), ProtocolRuleError> {
        for (key, pattern) in [
            ("stimulus_pattern", &self.fixations.stimulus_pattern),
            ("stimulus_end_pattern", &self.fixations.stimulus_end_pattern),
        ] {
            if let Some(p) = pattern {
                let re = regex::Regex::new(p).map_err(|e| {
                    format!("[fixations] {key} `{p}` is not a regular expression: {e}")
                })?;
                if key == "stimulus_pattern" && re.captures_len() != 2 {
                    return Err(ProtocolRuleError::from(format!(
                        "[fixations] stimulus_pattern `{p}` needs exactly one capture group, around the stimulus name"
                    )));
                }
            }
        }
        Ok(())
    }

    /// The screen, the viewing distance and the video settings.
    fn check_display_and_video(&self) -> Result<(), ProtocolRuleError> {
        if self.version != 1 {
            return Err(ProtocolRuleError::from(format!(
                "version {} is not supported (this meshgaze reads 1)",
                self.version
            )));
        }
        if self.display.width_px < 16 || self.display.height_px < 16 {
            return Err(ProtocolRuleError::from(
                "display.width_px and height_px must be at least 16",
            ));
        }
        if self.display.width_px % 2 == 1 || self.display.height_px % 2 == 1 {
            return Err(ProtocolRuleError::from(
                "display.width_px and height_px must be even (H.264 4:2:0 video)",
            ));
        }
        positive(self.display.width_mm, "display.width_mm")?;
        positive(self.display.height_mm, "display.height_mm")?;
        let [near, far] = self.display.viewing_distance_mm;
        positive(near, "display.viewing_distance_mm[0]")?;
        if far < near {
            return Err(ProtocolRuleError::from(
                "display.viewing_distance_mm must be [nearest, farthest]",
            ));
        }
        if !(1..=240).contains(&self.video.fps) {
            return Err(ProtocolRuleError::from(format!(
                "video.fps must be 1 to 240 (got {})",
                self.video.fps
            )));
        }
        if self.video.keyframe_interval_frames == 0 {
            return Err(ProtocolRuleError::from(
                "video.keyframe_interval_frames must be at least 1",
            ));
        }
        Ok(())
    }

    /// The viewpoints and how long each is held and moved between.
    fn check_viewpoints_and_timing(&self) -> Result<(), ProtocolRuleError> {
        if self.viewpoints.count == 0 {
            return Err(ProtocolRuleError::from(
                "viewpoints.count must be at least 1",
            ));
        }
        match self.viewpoints.generator {
            ViewpointGenerator::Icosahedron if self.viewpoints.count != 12 => {
                return Err(ProtocolRuleError::from(
                    "viewpoints.count must be 12 with the icosahedron generator",
                ))
            }
            ViewpointGenerator::List
                if self.viewpoints.directions.len() != self.viewpoints.count =>
            {
                return Err(ProtocolRuleError::from(format!(
                    "viewpoints.directions has {} entries but count is {}",
                    self.viewpoints.directions.len(),
                    self.viewpoints.count
                )))
            }
            _ => {}
        }
        for (name, v) in [
            ("viewpoints.first", self.viewpoints.first),
            ("viewpoints.up", self.viewpoints.up),
        ] {
            if v.iter().map(|x| x * x).sum::<f64>() == 0.0 {
                return Err(ProtocolRuleError::from(format!(
                    "{name} must not be the zero vector"
                )));
            }
        }
        if !(self.timing.hold_s >= 0.0 && self.timing.move_s >= 0.0) {
            return Err(ProtocolRuleError::from(
                "timing.hold_s and timing.move_s must be zero or more",
            ));
        }
        positive(self.duration_s(), "the protocol's duration")?;
        Ok(())
    }

    /// The camera's framing and the fixation filter.
    fn check_rendering_and_fixations(&self) -> Result<(), ProtocolRuleError> {
        let fov = self.rendering.field_of_view_deg;
        if !(fov > 1.0 && fov < 170.0) {
            return Err(ProtocolRuleError::from(format!(
                "rendering.field_of_view_deg must be in (1, 170) (got {fov})"
            )));
        }
        if !(self.rendering.fill > 0.0 && self.rendering.fill <= 1.0) {
            return Err(ProtocolRuleError::from("rendering.fill must be in (0, 1]"));
        }
        if !(1..=4).contains(&self.rendering.supersampling) {
            return Err(ProtocolRuleError::from(
                "rendering.supersampling must be 1 to 4",
            ));
        }
        let f = &self.fixations;
        positive(f.tracker_accuracy_deg, "fixations.tracker_accuracy_deg")?;
        positive(f.calibration_accept_deg, "fixations.calibration_accept_deg")?;
        if f.keep_longest == 0 {
            return Err(ProtocolRuleError::from(
                "fixations.keep_longest must be at least 1",
            ));
        }
        Ok(())
    }

    /// Total length: every viewpoint held, a move between consecutive ones, and a move back
    /// to the first with `return_to_first`.
    /// The video's length in seconds: every hold, and every move between them.
    pub fn duration_s(&self) -> f64 {
        let n = self.viewpoints.count as f64;
        let moves = if self.timing.return_to_first {
            n
        } else {
            n - 1.0
        };
        n * self.timing.hold_s + moves * self.timing.move_s
    }

    /// The video's number of frames.
    pub fn frame_count(&self) -> usize {
        (self.duration_s() * self.video.fps as f64).round() as usize
    }
}

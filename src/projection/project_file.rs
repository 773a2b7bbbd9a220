//! Projecting one stimulus's fixations from fixations.csv files onto its mesh: pick the
//! stimulus, turn rows into screen fixations, cast them, check them, and write projected.csv,
//! cone.csv and project.json.
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::self_check::{self_check, SelfCheck};
use super::table::{write_projected_csv, ProjectedRow};
use super::{
    count_fates, project_fixations, Cone, ProjectedFixation, ProjectionParams, RayCaster,
    ScreenFixation, ScreenMapping,
};
use crate::gaze::fixation_table::{read_fixations_csv, FixationRow};
use crate::progress::Progress;
use crate::projection::round_trip::{read_targets_csv, round_trip, RoundTrip};
use crate::protocol::DuringMove;
use crate::provenance::{InputFile, Provenance};
use crate::stimulus::load::LoadedStimulus;

/// Why fixations could not be projected, or the projection not written.
#[derive(Debug, thiserror::Error)]
pub enum ProjectError {
    /// An option or the fixations do not allow it; the message says which and why.
    #[error("{0}")]
    Invalid(String),
    /// A fixation or target table could not be used (its reader names file, line, column).
    #[error("{0}")]
    Table(String),
    /// A file could not be read, created or written.
    #[error("{action} {}: {cause}", path.display())]
    Io {
        /// `cannot read`, `cannot create`, `cannot write`.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// The I/O error.
        cause: std::io::Error,
    },
    /// A CSV output could not be written.
    #[error("cannot write {}: {cause}", path.display())]
    Csv {
        /// The file.
        path: PathBuf,
        /// The CSV writer's error.
        cause: csv::Error,
    },
}

type Result<T> = std::result::Result<T, ProjectError>;

fn invalid(message: impl Into<String>) -> ProjectError {
    ProjectError::Invalid(message.into())
}

/// The SHA-256 of an input, or which input could not be read.
fn hash(path: &Path) -> Result<InputFile> {
    InputFile::hash(path).map_err(|cause| ProjectError::Io {
        action: "cannot read",
        path: path.to_path_buf(),
        cause,
    })
}

/// `WIDTHxHEIGHT` in pixels.
pub fn parse_screen(s: &str) -> Result<(f64, f64)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| invalid("--screen: expected WIDTHxHEIGHT, e.g. 1920x1080"))?;
    let number = |v: &str, what: &str| {
        v.trim()
            .parse::<f64>()
            .map_err(|e| invalid(format!("--screen: {what} is not a number: {e}")))
    };
    let (w, h) = (number(w, "width")?, number(h, "height")?);
    if !(w > 0.0 && h > 0.0) {
        return Err(invalid("--screen: width and height must be positive"));
    }
    Ok((w, h))
}

/// Picks the stimulus whose fixations to project.
pub fn choose_stimulus(
    rows: &[FixationRow],
    explicit: Option<&str>,
    mesh_stem: &str,
) -> Result<String> {
    let mut names: Vec<&str> = rows.iter().map(|r| r.stimulus.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    if let Some(e) = explicit {
        if !names.contains(&e) {
            return Err(invalid(format!(
                "no fixation has stimulus `{e}`; the files have: {}",
                names.join(", ")
            )));
        }
        return Ok(e.to_string());
    }
    let stem = |n: &str| {
        n.rsplit(['/', '\\'])
            .next()
            .unwrap_or(n)
            .split('.')
            .next()
            .unwrap_or(n)
            .to_string()
    };
    let like_mesh: Vec<&&str> = names.iter().filter(|n| stem(n) == mesh_stem).collect();
    if like_mesh.len() == 1 {
        return Ok(like_mesh[0].to_string());
    }
    let with_onset: Vec<&&str> = names
        .iter()
        .filter(|n| {
            rows.iter()
                .any(|r| r.stimulus == **n && r.onset_offset_us.is_some())
        })
        .collect();
    if with_onset.len() == 1 {
        return Ok(with_onset[0].to_string());
    }
    Err(invalid(format!(
        "cannot tell which stimulus shows this mesh ({mesh_stem}); pass --stimulus-name, one of: {}",
        names.join(", ")
    )))
}

/// The rows of stimulus `name` as screen fixations, in subject then time order, numbered per
/// subject; `onset_us` overrides the rows' onset offsets.
pub fn screen_fixations(
    rows: &[FixationRow],
    name: &str,
    onset_us: Option<i64>,
) -> Result<Vec<ScreenFixation>> {
    let mut chosen: Vec<&FixationRow> = rows.iter().filter(|r| r.stimulus == name).collect();
    chosen.sort_by(|a, b| a.subject.cmp(&b.subject).then(a.start_us.cmp(&b.start_us)));
    let mut fixations = Vec::with_capacity(chosen.len());
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    for r in &chosen {
        let offset_us = match (r.onset_offset_us, onset_us) {
            (_, Some(onset)) => r.start_us - onset,
            (Some(o), None) => o,
            (None, None) => return Err(invalid(format!(
                "subject {}: fixations of `{name}` have no onset time (no stimulus message in the recording); pass --onset-us with the tracker time of the video's first frame",
                r.subject
            ))),
        };
        let k = index.entry(r.subject.as_str()).or_insert(0);
        fixations.push(ScreenFixation {
            subject: r.subject.clone(),
            index: *k,
            start_ms: offset_us as f64 / 1000.0,
            duration_ms: r.duration_ms,
            x_px: r.x_px,
            y_px: r.y_px,
            kept: r.fate == "kept",
            invalid: r.fate == "invalid",
        });
        *k += 1;
    }
    Ok(fixations)
}

/// How fixations are projected (None: the protocol's).
#[derive(Debug, Clone, Default)]
pub struct ProjectOptions {
    /// The stimulus name in the fixation files (None: the one named like the mesh, or the
    /// only one with an onset).
    pub stimulus_name: Option<String>,
    /// The tracker time of the video's first frame, for fixations without an onset message.
    pub onset_us: Option<i64>,
    /// The tracker's screen in pixels (None: the protocol's display).
    pub screen: Option<(f64, f64)>,
    /// Overrides the protocol's rule for fixations that overlap a move.
    pub during_move: Option<DuringMove>,
    /// Snap radius in degrees.
    pub snap_deg: Option<f64>,
    /// Gaussian cone half-angle in degrees.
    pub cone_deg: Option<f64>,
    /// targets.csv of simulated observers, for the round-trip check.
    pub targets: Option<PathBuf>,
    /// Checks the projector against the renderer's triangle-id images of the hold frames.
    pub self_check: bool,
}

/// project.json.
#[derive(Serialize)]
pub struct ProjectSidecar {
    /// Tool version and inputs with their hashes.
    pub provenance: Provenance,
    /// SHA-256 of the stimulus manifest.
    pub manifest_sha256: String,
    /// SHA-256 of the mesh.
    pub mesh_sha256: String,
    /// The stimulus whose fixations were projected.
    pub stimulus_name: String,
    /// Tracker screen to video pixels.
    pub mapping: ScreenMapping,
    /// How fixations were projected.
    pub parameters: ProjectionParams,
    /// Screen pixels per degree of visual angle (degrees to pixels for snap and cone).
    pub pixels_per_degree: f64,
    /// Fixation rows of other stimuli, left out.
    pub rows_of_other_stimuli: usize,
    /// Fates per subject.
    pub fates: BTreeMap<String, BTreeMap<&'static str, usize>>,
    /// Fates over every subject.
    pub totals: BTreeMap<&'static str, usize>,
    /// The projector-against-renderer check, when asked for.
    pub self_check: Option<SelfCheck>,
    /// How far projected fixations land from simulated observers' true targets.
    pub round_trip: Option<RoundTrip>,
}

/// What a projection produced.
pub struct ProjectionRun {
    /// Every fixation with its fate.
    pub projected: Vec<ProjectedFixation>,
    /// projected.csv's rows.
    pub rows: Vec<ProjectedRow>,
    /// project.json.
    pub sidecar: ProjectSidecar,
}

/// Reads fixations.csv files and projects the chosen stimulus's fixations onto `stim`.
pub fn project_files(
    stim: &LoadedStimulus,
    fixation_files: &[PathBuf],
    options: &ProjectOptions,
    progress: &dyn Progress,
) -> Result<ProjectionRun> {
    let mut inputs = vec![hash(&stim.manifest_path)?, hash(&stim.mesh_path)?];
    let mut rows = Vec::new();
    for f in fixation_files {
        rows.extend(read_fixations_csv(f).map_err(|e| ProjectError::Table(e.to_string()))?);
        inputs.push(hash(f)?);
    }
    let name = choose_stimulus(&rows, options.stimulus_name.as_deref(), &stim.mesh_stem())?;
    let others = rows.iter().filter(|r| r.stimulus != name).count();
    let fixations = screen_fixations(&rows, &name, options.onset_us)?;
    let mut run = project_screen_fixations(stim, &fixations, options, progress)?;
    if let Some(t) = &options.targets {
        inputs.push(hash(t)?);
    }
    run.sidecar.provenance = Provenance::new(inputs);
    run.sidecar.stimulus_name = name;
    run.sidecar.rows_of_other_stimuli = others;
    Ok(run)
}

/// Projects screen fixations onto `stim` (provenance and stimulus name left for the caller).
pub fn project_screen_fixations(
    stim: &LoadedStimulus,
    fixations: &[ScreenFixation],
    options: &ProjectOptions,
    progress: &dyn Progress,
) -> Result<ProjectionRun> {
    let protocol = &stim.protocol;
    let (sw, sh) = options.screen.unwrap_or((
        protocol.display.width_px as f64,
        protocol.display.height_px as f64,
    ));
    let mapping = ScreenMapping {
        screen_width_px: sw,
        screen_height_px: sh,
        video_width_px: stim.video_width,
        video_height_px: stim.video_height,
    };
    // Degrees to tracker-screen pixels: the protocol's display geometry, rescaled if the
    // tracker reports another resolution for the same panel.
    let ppd = protocol.display.pixels_per_degree() * sw / protocol.display.width_px as f64;
    if let Some(d) = options.snap_deg {
        if !(d > 0.0 && d <= 5.0) {
            return Err(invalid("--snap-deg must be in (0, 5] degrees"));
        }
    }
    if let Some(c) = options.cone_deg {
        if !(c > 0.0 && c <= 10.0) {
            return Err(invalid("--cone-deg must be in (0, 10] degrees"));
        }
    }
    let params = ProjectionParams {
        during_move: options
            .during_move
            .unwrap_or(protocol.fixations.during_move),
        snap_radius_px: options.snap_deg.map(|d| d * ppd),
        cone: options.cone_deg.map(|d| Cone {
            radius_px: d * ppd,
            sigma_px: 0.5 * d * ppd,
            rays_per_radius: 8,
        }),
        fps: stim.fps,
    };
    progress.start("building the BVH", 0);
    let caster = RayCaster::new(&stim.mesh);
    progress.finish();
    progress.start("projecting fixations", 0);
    let projected = project_fixations(&stim.plan, &caster, &mapping, fixations, &params);
    progress.finish();
    let check = options.self_check.then(|| {
        progress.start("self-check (id buffer)", 0);
        let c = self_check(&stim.plan, &caster, &mapping, &projected);
        progress.finish();
        c
    });
    let rows: Vec<ProjectedRow> = projected.iter().map(ProjectedRow::from).collect();
    let round_trip = match &options.targets {
        Some(t) => {
            let targets = read_targets_csv(t).map_err(|e| ProjectError::Table(e.to_string()))?;
            Some(round_trip(&stim.mesh, &stim.plan, ppd, &targets, &rows))
        }
        None => None,
    };
    let mut fates: BTreeMap<String, BTreeMap<&'static str, usize>> = BTreeMap::new();
    for p in &projected {
        fates.entry(p.subject.clone()).or_default();
    }
    for (s, c) in fates.iter_mut() {
        *c = count_fates(
            projected
                .iter()
                .filter(|p| &p.subject == s)
                .map(|p| &p.fate),
        )
        .into_iter()
        .map(|(f, n)| (f.name(), n))
        .collect();
    }
    let totals = count_fates(projected.iter().map(|p| &p.fate))
        .into_iter()
        .map(|(f, n)| (f.name(), n))
        .collect();
    let sidecar = ProjectSidecar {
        provenance: Provenance::new(Vec::new()),
        manifest_sha256: stim.manifest_sha256.clone(),
        mesh_sha256: stim.mesh_sha256.clone(),
        stimulus_name: String::new(),
        mapping,
        parameters: params,
        pixels_per_degree: ppd,
        rows_of_other_stimuli: 0,
        fates,
        totals,
        self_check: check,
        round_trip,
    };
    Ok(ProjectionRun {
        projected,
        rows,
        sidecar,
    })
}

/// Writes projected.csv, cone.csv (with a cone) and project.json into `out`.
pub fn write_projection(out: &Path, run: &ProjectionRun) -> Result<()> {
    let io = |action: &'static str, path: &Path| {
        let path = path.to_path_buf();
        move |cause| ProjectError::Io {
            action,
            path,
            cause,
        }
    };
    crate::file_bytes::create_output_dir(out).map_err(|cause| ProjectError::Io {
        action: "cannot create",
        path: out.to_path_buf(),
        cause,
    })?;
    let pp = out.join("projected.csv");
    write_projected_csv(
        std::io::BufWriter::new(std::fs::File::create(&pp).map_err(io("cannot create", &pp))?),
        &run.rows,
    )
    .map_err(|e| ProjectError::Table(format!("cannot write {}: {e}", pp.display())))?;
    if run.sidecar.parameters.cone.is_some() {
        let cp = out.join("cone.csv");
        let csv_error = |cause| ProjectError::Csv {
            path: cp.clone(),
            cause,
        };
        let mut w = csv::Writer::from_path(&cp).map_err(csv_error)?;
        w.write_record(["subject", "fixation", "vertex", "weight"])
            .map_err(csv_error)?;
        for p in &run.projected {
            for (v, wt) in &p.footprint {
                w.write_record([
                    p.subject.clone(),
                    p.index.to_string(),
                    v.to_string(),
                    format!("{wt}"),
                ])
                .map_err(csv_error)?;
            }
        }
        w.flush().map_err(io("cannot write", &cp))?;
    }
    let jp = out.join("project.json");
    let json = serde_json::to_string_pretty(&run.sidecar).expect("the sidecar serializes") + "\n";
    std::fs::write(&jp, json).map_err(io("cannot write", &jp))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screen_sizes_are_read_and_bad_ones_say_why() {
        assert_eq!(parse_screen("1920x1080").unwrap(), (1920.0, 1080.0));
        assert_eq!(parse_screen(" 1680 X 1050 ").unwrap(), (1680.0, 1050.0));
        let e = parse_screen("1920by1080").unwrap_err().to_string();
        assert_eq!(e, "--screen: expected WIDTHxHEIGHT, e.g. 1920x1080");
        let e = parse_screen("wide x 1080").unwrap_err().to_string();
        assert!(e.starts_with("--screen: width is not a number: "), "{e}");
        let e = parse_screen("0x1080").unwrap_err().to_string();
        assert_eq!(e, "--screen: width and height must be positive");
    }

    #[test]
    fn an_unreadable_input_is_named() {
        let missing = Path::new("/no/such/dir/fixations.csv");
        let e = hash(missing).unwrap_err();
        assert!(matches!(e, ProjectError::Io { .. }));
        assert!(
            e.to_string()
                .starts_with("cannot read /no/such/dir/fixations.csv: "),
            "{e}"
        );
    }
}

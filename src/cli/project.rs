use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};
use clap::Args;
use serde::Serialize;

use meshgaze::gaze::fixation_table::{read_fixations_csv, FixationRow};
use meshgaze::progress::Progress;
use meshgaze::projection::self_check::{self_check, SelfCheck};
use meshgaze::projection::table::{write_projected_csv, ProjectedRow};
use meshgaze::projection::{
    count_fates, fate_table_text, project_fixations, Cone, ProjectionParams, RayCaster,
    ScreenFixation, ScreenMapping,
};
use meshgaze::provenance::{InputFile, Provenance};
use meshgaze::simulate::{read_targets_csv, round_trip, RoundTrip};
use meshgaze::stimulus::load::load_stimulus;
use meshgaze::stimulus::protocol::DuringMove;

use super::progress_bar::Bars;

/// Project 2D screen fixations onto the mesh of a stimulus.
///
/// For each fixation of the chosen stimulus (from `meshgaze ingest`'s fixations.csv): its time
/// after the stimulus onset message, the camera of the video frame on screen at that time
/// (recomputed with the renderer's own function and checked against timeline.csv byte for
/// byte), the gaze point mapped into the video picture (letterboxed when the tracker's screen
/// has another shape), a ray from the eye, the first hit through a BVH (watertight triangle
/// test), and the hit triangle's nearest vertex (the paper's rule).
///
/// Every fixation gets one fate: hit, snapped, background, off-screen, in-transition, invalid
/// (no position, or not while the video played) or filtered (removed by the protocol's
/// filter at ingest). Writes OUT/projected.csv (the fixation-set ground-truth format that
/// `meshgaze truth` and `meshgaze score` read), OUT/project.json (provenance, parameters,
/// fates per subject, the projector self-check) and with --cone OUT/cone.csv.
///
/// The manifest is refused when the mesh, protocol, video or timeline on disk do not match
/// its SHA-256 hashes.
#[derive(Debug, Args)]
pub struct ProjectArgs {
    /// The stimulus: its manifest.json or the folder holding it.
    #[arg(long)]
    pub stimulus: PathBuf,
    /// fixations.csv files from `meshgaze ingest` (any number of subjects).
    #[arg(long, required = true, num_args = 1..)]
    pub fixations: Vec<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// The stimulus name in the fixation files [default: the one named like the mesh, or
    /// the only one with an onset message].
    #[arg(long)]
    pub stimulus_name: Option<String>,
    /// Fixations without an onset message: the tracker time (µs) of the stimulus onset.
    #[arg(long)]
    pub onset_us: Option<i64>,
    /// Which camera a fixation gets: at its mid-time, its start, or reject those overlapping
    /// a move [default: the protocol's].
    #[arg(long, value_enum)]
    pub during_move: Option<DuringMoveArg>,
    /// Snap background misses to the nearest visible surface within the tracker's accuracy
    /// (the protocol's tracker_accuracy_deg).
    #[arg(long)]
    pub snap: bool,
    /// Snap radius in degrees instead of the protocol's accuracy (implies --snap).
    #[arg(long)]
    pub snap_deg: Option<f64>,
    /// Also spread each fixation over a Gaussian cone of this half-angle in degrees (Lavoué
    /// et al. 2018 use 1°): writes cone.csv with per-vertex weights.
    #[arg(long)]
    pub cone_deg: Option<f64>,
    /// The tracker's screen in pixels, WIDTHxHEIGHT [default: the protocol's display].
    #[arg(long)]
    pub screen: Option<String>,
    /// The mesh, if it moved since rendering (its hash must match the manifest).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// targets.csv from `meshgaze simulate`: compare each projected fixation with its true
    /// target and report the share within 1° (the pipeline's round-trip check).
    #[arg(long)]
    pub targets: Option<PathBuf>,
    /// Skip comparing hold-phase hits with the renderer's triangle-id buffer.
    #[arg(long)]
    pub no_self_check: bool,
    #[arg(short, long)]
    pub quiet: bool,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DuringMoveArg {
    Mid,
    Start,
    Reject,
}

#[derive(Serialize)]
struct Sidecar<'a> {
    provenance: Provenance,
    manifest_sha256: &'a str,
    mesh_sha256: &'a str,
    stimulus_name: &'a str,
    mapping: ScreenMapping,
    parameters: &'a ProjectionParams,
    pixels_per_degree: f64,
    rows_of_other_stimuli: usize,
    fates: BTreeMap<String, BTreeMap<&'static str, usize>>,
    totals: BTreeMap<&'static str, usize>,
    self_check: Option<SelfCheck>,
    round_trip: Option<RoundTrip>,
}

fn parse_screen(s: &str) -> Result<(f64, f64)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .context("--screen: expected WIDTHxHEIGHT, e.g. 1920x1080")?;
    let (w, h): (f64, f64) = (
        w.trim()
            .parse()
            .context("--screen: width is not a number")?,
        h.trim()
            .parse()
            .context("--screen: height is not a number")?,
    );
    if !(w > 0.0 && h > 0.0) {
        bail!("--screen: width and height must be positive");
    }
    Ok((w, h))
}

/// Picks the stimulus whose fixations to project.
fn choose_stimulus(
    rows: &[FixationRow],
    explicit: Option<&str>,
    mesh_stem: &str,
) -> Result<String> {
    let mut names: Vec<&str> = rows.iter().map(|r| r.stimulus.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    if let Some(e) = explicit {
        if !names.contains(&e) {
            bail!(
                "no fixation has stimulus `{e}`; the files have: {}",
                names.join(", ")
            );
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
    bail!(
        "cannot tell which stimulus shows this mesh ({mesh_stem}); pass --stimulus-name, one of: {}",
        names.join(", ")
    )
}

pub fn run(args: ProjectArgs) -> Result<()> {
    let bars = Bars::new(args.quiet);
    let stim = load_stimulus(&args.stimulus, args.mesh.as_deref()).map_err(anyhow::Error::msg)?;
    let protocol = &stim.protocol;
    let mut inputs = vec![
        InputFile::hash(&stim.manifest_path)?,
        InputFile::hash(&stim.mesh_path)?,
    ];
    let mut rows = Vec::new();
    for f in &args.fixations {
        rows.extend(read_fixations_csv(f).map_err(anyhow::Error::msg)?);
        inputs.push(InputFile::hash(f)?);
    }
    let mesh_stem = stim.mesh_stem();
    let name = choose_stimulus(&rows, args.stimulus_name.as_deref(), &mesh_stem)?;
    let others = rows.iter().filter(|r| r.stimulus != name).count();
    let mut chosen: Vec<&FixationRow> = rows.iter().filter(|r| r.stimulus == name).collect();
    chosen.sort_by(|a, b| a.subject.cmp(&b.subject).then(a.start_us.cmp(&b.start_us)));
    let mut fixations = Vec::with_capacity(chosen.len());
    let mut index: BTreeMap<&str, usize> = BTreeMap::new();
    for r in &chosen {
        let offset_us = match (r.onset_offset_us, args.onset_us) {
            (_, Some(onset)) => r.start_us - onset,
            (Some(o), None) => o,
            (None, None) => bail!(
                "subject {}: fixations of `{name}` have no onset time (no stimulus message in the recording); pass --onset-us with the tracker time of the video's first frame",
                r.subject
            ),
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
    let (sw, sh) = match &args.screen {
        Some(s) => parse_screen(s)?,
        None => (
            protocol.display.width_px as f64,
            protocol.display.height_px as f64,
        ),
    };
    let mapping = ScreenMapping {
        screen_width_px: sw,
        screen_height_px: sh,
        video_width_px: stim.video_width,
        video_height_px: stim.video_height,
    };
    // Degrees to tracker-screen pixels: the protocol's display geometry, rescaled if the
    // tracker reports another resolution for the same panel.
    let ppd = protocol.display.pixels_per_degree() * sw / protocol.display.width_px as f64;
    let snap_deg = args
        .snap_deg
        .or(args.snap.then_some(protocol.fixations.tracker_accuracy_deg));
    if let Some(d) = snap_deg {
        if !(d > 0.0 && d <= 5.0) {
            bail!("--snap-deg must be in (0, 5] degrees");
        }
    }
    if let Some(c) = args.cone_deg {
        if !(c > 0.0 && c <= 10.0) {
            bail!("--cone-deg must be in (0, 10] degrees");
        }
    }
    let params = ProjectionParams {
        during_move: match args.during_move {
            Some(DuringMoveArg::Mid) => DuringMove::Mid,
            Some(DuringMoveArg::Start) => DuringMove::Start,
            Some(DuringMoveArg::Reject) => DuringMove::Reject,
            None => protocol.fixations.during_move,
        },
        snap_radius_px: snap_deg.map(|d| d * ppd),
        cone: args.cone_deg.map(|d| Cone {
            radius_px: d * ppd,
            sigma_px: 0.5 * d * ppd,
            rays_per_radius: 8,
        }),
        fps: stim.fps,
    };
    bars.start("building the BVH", 0);
    let caster = RayCaster::new(&stim.mesh);
    bars.finish();
    bars.start("projecting fixations", 0);
    let projected = project_fixations(&stim.plan, &caster, &mapping, &fixations, &params);
    bars.finish();
    let check = (!args.no_self_check).then(|| {
        bars.start("self-check (id buffer)", 0);
        let c = self_check(&stim.plan, &caster, &mapping, &projected);
        bars.finish();
        c
    });
    std::fs::create_dir_all(&args.output)
        .with_context(|| format!("cannot create {}", args.output.display()))?;
    let out_rows: Vec<ProjectedRow> = projected.iter().map(ProjectedRow::from).collect();
    let pp = args.output.join("projected.csv");
    write_projected_csv(
        std::io::BufWriter::new(
            std::fs::File::create(&pp)
                .with_context(|| format!("cannot create {}", pp.display()))?,
        ),
        &out_rows,
    )
    .map_err(anyhow::Error::msg)?;
    if params.cone.is_some() {
        let cp = args.output.join("cone.csv");
        let mut w = csv::Writer::from_path(&cp)
            .with_context(|| format!("cannot create {}", cp.display()))?;
        w.write_record(["subject", "fixation", "vertex", "weight"])?;
        for p in &projected {
            for (v, wt) in &p.footprint {
                w.write_record([
                    p.subject.clone(),
                    p.index.to_string(),
                    v.to_string(),
                    format!("{wt}"),
                ])?;
            }
        }
        w.flush()?;
    }
    let round_trip = match &args.targets {
        Some(t) => {
            let targets = read_targets_csv(t).map_err(anyhow::Error::msg)?;
            inputs.push(InputFile::hash(t)?);
            Some(round_trip(&stim.mesh, &stim.plan, ppd, &targets, &out_rows))
        }
        None => None,
    };
    let mut fates: BTreeMap<String, BTreeMap<&'static str, usize>> = BTreeMap::new();
    let subjects: Vec<String> = index.keys().map(|s| s.to_string()).collect();
    for s in &subjects {
        let c = count_fates(
            projected
                .iter()
                .filter(|p| &p.subject == s)
                .map(|p| &p.fate),
        );
        fates.insert(
            s.clone(),
            c.into_iter().map(|(f, n)| (f.name(), n)).collect(),
        );
    }
    let totals: BTreeMap<&'static str, usize> = count_fates(projected.iter().map(|p| &p.fate))
        .into_iter()
        .map(|(f, n)| (f.name(), n))
        .collect();
    let sidecar = Sidecar {
        provenance: Provenance::new(inputs),
        manifest_sha256: &stim.manifest_sha256,
        mesh_sha256: &stim.mesh_sha256,
        stimulus_name: &name,
        mapping,
        parameters: &params,
        pixels_per_degree: ppd,
        rows_of_other_stimuli: others,
        fates: fates.clone(),
        totals: totals.clone(),
        self_check: check.clone(),
        round_trip: round_trip.clone(),
    };
    let jp = args.output.join("project.json");
    std::fs::write(&jp, serde_json::to_string_pretty(&sidecar)? + "\n")
        .with_context(|| format!("cannot write {}", jp.display()))?;
    if !args.quiet {
        eprint!("{}", fate_table_text(&fates, &totals));
        eprintln!(
            "stimulus `{name}`: {} fixations of {} subjects projected ({others} rows of other stimuli not used)",
            projected.len(),
            subjects.len()
        );
        if let Some(c) = &check {
            eprintln!(
                "self-check: {}/{} hold-phase fixations hit the triangle the renderer drew at their pixel ({:.2}%)",
                c.agreed,
                c.checked,
                100.0 * c.rate
            );
        }
        if let Some(r) = &round_trip {
            eprintln!(
                "round trip: {}/{} hold-phase fixations within 1° of their true target ({:.2}%), {} on the mesh; error median {:.2}°, 95th percentile {:.2}°",
                r.within_1deg,
                r.matched,
                100.0 * r.rate,
                r.on_mesh,
                r.median_error_deg,
                r.p95_error_deg
            );
        }
        eprintln!("wrote {} and project.json", pp.display());
    }
    Ok(())
}

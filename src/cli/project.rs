use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use meshgaze::projection::fate_table_text;
use meshgaze::projection::project_file::{
    parse_screen, project_files, write_projection, ProjectOptions,
};
use meshgaze::protocol::DuringMove;
use meshgaze::stimulus::load::load_stimulus;

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

pub fn run(args: ProjectArgs) -> Result<()> {
    let bars = Bars::new(args.quiet);
    let stim = load_stimulus(&args.stimulus, args.mesh.as_deref()).map_err(anyhow::Error::msg)?;
    let options = ProjectOptions {
        stimulus_name: args.stimulus_name.clone(),
        onset_us: args.onset_us,
        screen: args.screen.as_deref().map(parse_screen).transpose()?,
        during_move: args.during_move.map(|d| match d {
            DuringMoveArg::Mid => DuringMove::Mid,
            DuringMoveArg::Start => DuringMove::Start,
            DuringMoveArg::Reject => DuringMove::Reject,
        }),
        snap_deg: args.snap_deg.or(args
            .snap
            .then_some(stim.protocol.fixations.tracker_accuracy_deg)),
        cone_deg: args.cone_deg,
        targets: args.targets.clone(),
        self_check: !args.no_self_check,
    };
    let run = project_files(&stim, &args.fixations, &options, &bars)?;
    write_projection(&args.output, &run)?;
    if !args.quiet {
        let s = &run.sidecar;
        eprint!("{}", fate_table_text(&s.fates, &s.totals));
        eprintln!(
            "stimulus `{}`: {} fixations of {} subjects projected ({} rows of other stimuli not used)",
            s.stimulus_name,
            run.projected.len(),
            s.fates.len(),
            s.rows_of_other_stimuli
        );
        if let Some(c) = &s.self_check {
            eprintln!(
                "self-check: {}/{} hold-phase fixations stored the triangle the renderer drew at their pixel, {} more differ only within their pixel near an edge ({:.2}% agree)",
                c.agreed,
                c.checked,
                c.sub_pixel,
                100.0 * c.rate
            );
        }
        if let Some(r) = &s.round_trip {
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
        eprintln!(
            "wrote {} and project.json",
            args.output.join("projected.csv").display()
        );
    }
    Ok(())
}

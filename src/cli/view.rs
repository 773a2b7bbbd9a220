use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use meshgaze::report::viewer::ViewerLimits;
use meshgaze::report::viewer_files::{view_page_from_files, ViewFiles};

/// Look at a mesh in 3D in the browser: its saliency maps, truth density and fixations.
///
/// Writes one self-contained HTML file that opens offline in any current browser (WebGL; the
/// viewer's code is in the file, nothing is fetched). Orbit with the mouse (drag), pan
/// (right-drag or shift-drag), zoom (wheel), or with touch (drag, pinch); double-click
/// resets. A chooser colours the surface by each map, the truth density or nothing, on the
/// static renders' scale (1st to 99th percentile of the map); a slider shows only the top k%.
/// Fixations are dots coloured by subject, filtered by subject and by fate (hit, snapped);
/// hovering one shows subject, time, duration and vertex.
///
/// With --stimulus, buttons move the camera to each hold view exactly as the video showed it
/// (the timeline's cameras) and a time slider replays the turntable with the fixations made
/// at that moment.
///
/// The page reads options after `#` in its address: `view.html#map=sms&view=2&k=10`
/// (map by name or index, or `plain`; hold view index; top percent; `t=SECONDS` replays at
/// that time; `press=I` clicks hold-view button I; `ui=0` hides the panel; `dots=0` hides the
/// fixations; `size=video` draws at the video's exact pixel size).
///
/// Examples:
///   meshgaze view bunny.ply --saliency sms.csv mc.csv --truth truth/ --stimulus stim/ -o view.html
///   meshgaze view bunny.ply --saliency sms=out/bunny.sms.csv -o view.html
#[derive(Debug, Args)]
pub struct ViewArgs {
    /// The mesh (.obj, .ply, .off, optionally .gz).
    pub mesh: PathBuf,
    /// Per-vertex maps (`meshgaze saliency`'s CSV or any per-vertex format), named by file
    /// stem, or NAME=PATH.
    #[arg(long, num_args = 1..)]
    pub saliency: Vec<String>,
    /// The truth: a `meshgaze truth` folder (its density, and its fixations unless
    /// --fixations is given) or its density.csv.
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// projected.csv files (or folders holding one) from `meshgaze project`.
    #[arg(long, num_args = 1..)]
    pub fixations: Vec<PathBuf>,
    /// The stimulus rendered from this mesh (folder or manifest.json): hold views and replay.
    #[arg(long)]
    pub stimulus: Option<PathBuf>,
    /// Meshes with more triangles are shown simplified (quadric edge collapse) to about this
    /// many, each kept vertex with its own values; the page says so.
    #[arg(long, default_value_t = ViewerLimits::default().max_triangles)]
    pub max_triangles: usize,
    /// The HTML file to write.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: ViewArgs) -> Result<()> {
    let files = ViewFiles {
        mesh: args.mesh.clone(),
        saliency: args.saliency.clone(),
        truth: args.truth.clone(),
        fixations: args.fixations.clone(),
        stimulus: args.stimulus.clone(),
        limits: ViewerLimits {
            max_triangles: args.max_triangles.max(1000),
        },
    };
    let (page, account) = view_page_from_files(&files)?;
    if let Some(dir) = args.output.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    std::fs::write(&args.output, &page)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if !args.quiet {
        eprintln!("{account}");
        eprintln!(
            "wrote {} ({:.1} MB); open it in a browser",
            args.output.display(),
            page.len() as f64 / 1e6
        );
    }
    Ok(())
}

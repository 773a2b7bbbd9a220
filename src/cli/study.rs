use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};

use meshgaze::study::{merge_study, run_study, template, RunOptions, Study};

use super::progress_bar::Bars;

/// A whole study in one command: a folder of meshes and a lab's SMI recordings to stimuli,
/// fixations, ground truth, saliency maps and scores.
///
/// Start with `meshgaze study init MESH_DIR --recordings 'recordings/*.txt' -o study.toml`,
/// then `meshgaze study run study.toml`: before any recording exists it renders the stimuli
/// (OUT/stimuli/<mesh>/stimulus.mp4, the videos to show); once recordings exist it ingests
/// them (one recording per subject playing every video in any order, split by the messages
/// naming each video), projects each mesh's fixations with that mesh's stimulus, builds each
/// mesh's truth, computes and scores every method, and writes OUT/scores.csv.
///
/// Like make, each step records the hash of its inputs and is skipped when they did not change;
/// a killed run started again redoes only unfinished steps. Every mesh is an independent job:
/// --jobs N runs N at once, --shard i/n runs one share on one machine (a cluster array job),
/// and `meshgaze study merge study.toml` joins the shares' scores.
#[derive(Debug, Args)]
pub struct StudyArgs {
    #[command(subcommand)]
    pub action: StudyAction,
}

#[derive(Debug, Subcommand)]
pub enum StudyAction {
    /// Write a commented study.toml for the meshes in a folder.
    Init {
        /// Folder of the meshes (relative to where study.toml will be).
        mesh_dir: String,
        /// Glob of the recordings (relative to study.toml).
        #[arg(long, default_value = "recordings/*.txt")]
        recordings: String,
        /// Where to write study.toml.
        #[arg(short, long, default_value = "study.toml")]
        output: PathBuf,
    },
    /// Run (or resume) the study.
    Run {
        /// The study file.
        study: PathBuf,
        /// Run the i-th of n shares of the meshes, e.g. 2/4 (stable: a mesh's share depends on
        /// its name only).
        #[arg(long)]
        shard: Option<String>,
        /// Meshes processed at once.
        #[arg(long, default_value_t = 1)]
        jobs: usize,
        #[arg(short, long)]
        quiet: bool,
    },
    /// Join the per-mesh scores of every share into OUT/scores.csv.
    Merge {
        /// The study file.
        study: PathBuf,
    },
}

fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let (i, n) = s
        .split_once('/')
        .context("--shard: expected i/n, e.g. 1/4")?;
    let (i, n): (usize, usize) = (
        i.trim().parse().context("--shard: i is not a number")?,
        n.trim().parse().context("--shard: n is not a number")?,
    );
    if n == 0 || i == 0 || i > n {
        bail!("--shard {s}: need 1 <= i <= n");
    }
    Ok((i, n))
}

pub fn run(args: StudyArgs) -> Result<()> {
    match args.action {
        StudyAction::Init {
            mesh_dir,
            recordings,
            output,
        } => init(&mesh_dir, &recordings, &output),
        StudyAction::Run {
            study,
            shard,
            jobs,
            quiet,
        } => run_shard(&study, shard.as_deref(), jobs, quiet),
        StudyAction::Merge { study } => merge(&study),
    }
}

fn init(mesh_dir: &str, recordings: &str, output: &Path) -> Result<()> {
    if output.exists() {
        bail!("{} exists; not overwriting it", output.display());
    }
    std::fs::write(output, template(mesh_dir, recordings))
        .with_context(|| format!("cannot write {}", output.display()))?;
    let study = Study::load(output)?;
    eprintln!(
        "wrote {}: {} meshes, {} recordings so far; next: meshgaze study run {}",
        output.display(),
        study.meshes.len(),
        study.recordings.len(),
        output.display()
    );
    Ok(())
}

fn run_shard(study: &Path, shard: Option<&str>, jobs: usize, quiet: bool) -> Result<()> {
    let s = Study::load(study)?;
    let options = RunOptions {
        shard: shard.map(parse_shard).transpose()?,
        jobs,
    };
    let bars = Bars::new(quiet);
    let t = std::time::Instant::now();
    let r = run_study(&s, &options, &bars)?;
    if quiet {
        return Ok(());
    }
    let count = |o: &str| r.steps.iter().filter(|x| x.outcome == o).count();
    for x in r.steps.iter().filter(|x| x.outcome == "failed") {
        eprintln!("failed: {} {}: {}", x.mesh, x.step, x.detail);
    }
    for p in &r.problems {
        eprintln!("problem: {p}");
    }
    eprintln!(
        "study: {} meshes, {} recordings; steps {} done, {} up to date, {} skipped, {} failed; {:.1} s; log {}",
        r.meshes_in_shard.len(),
        r.recordings,
        count("done"),
        count("up-to-date"),
        count("skipped"),
        count("failed"),
        t.elapsed().as_secs_f64(),
        s.output.join("run.log").display()
    );
    Ok(())
}

fn merge(study: &Path) -> Result<()> {
    let s = Study::load(study)?;
    let (n, report) = merge_study(&s)?;
    eprintln!(
        "merged the scores of {n} meshes into {}; report: {}",
        s.output.join("scores.csv").display(),
        report.display()
    );
    Ok(())
}

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use meshgaze::study::demo::{run_demo, DemoInputs};

use super::progress_bar::Bars;

/// The Stanford bunny (8,171 vertices) compiled into the binary, so the demo needs no files.
const BUNNY: &[u8] = include_bytes!("../../stimuli/meshes/bun_zipper_res2.ply");
/// The paper's protocol, compiled in for the same reason.
const PROTOCOL: &str = include_str!("../../protocols/hu2020.toml");

/// Run the whole pipeline end to end on the bundled Stanford bunny, and write report.html.
///
/// With no input: renders the paper's 48 s stimulus, simulates 8 virtual observers (SMI
/// RED250 recordings in formats A and C1; they favour protruding parts, a model independent
/// of every saliency method), ingests and filters their fixations, projects them onto the
/// mesh, builds the ground truth with the split-half human ceiling, computes SMS, MS and MC,
/// scores them, and writes OUT/report.html, a single file that opens offline. Every stage's
/// own outputs (the same files the individual commands write) are kept in OUT's subfolders.
///
/// The subjects are simulated: the scores show that the pipeline works, not how people look
/// at bunnies.
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// Output folder.
    #[arg(short, long, default_value = "meshgaze-demo")]
    pub output: PathBuf,
    /// Virtual subjects.
    #[arg(long, default_value_t = 8)]
    pub subjects: usize,
    /// Seed of the virtual observers.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: DemoArgs) -> Result<()> {
    let bars = Bars::new(args.quiet);
    let say = |m: &str| {
        if !args.quiet {
            eprintln!("meshgaze demo: {m}");
        }
    };
    let done = run_demo(
        &DemoInputs {
            mesh_bytes: BUNNY,
            protocol_toml: PROTOCOL,
            output: &args.output,
            subjects: args.subjects,
            seed: args.seed,
        },
        &bars,
        &say,
    )?;
    if !args.quiet {
        print_scores(&done.score, &done.ginis, &done.truth);
        eprintln!(
            "meshgaze demo: done in {:.1} s. Open {} in a browser.",
            done.seconds,
            done.report.display()
        );
    }
    println!("{}", done.report.display());
    Ok(())
}

fn print_scores(
    score: &meshgaze::scoring::MeshScore,
    ginis: &[(&str, f64)],
    truth: &meshgaze::truth::TruthResult,
) {
    for m in &score.summaries {
        let gini = ginis
            .iter()
            .find(|g| g.0 == m.method)
            .map_or(String::new(), |g| format!("; Gini {:.3}", g.1));
        eprintln!(
            "  {:<7} AUC-Judd {:.3} unblurred, {:.3} peak at σ_b {:.2}{gini}",
            m.method, m.auc_judd_unblurred, m.auc_judd_peak, m.auc_judd_peak_blur
        );
    }
    eprintln!(
        "  human   AUC-Judd {:.3} peak at σ_b {:.2} (split-half ceiling)",
        truth.sidecar.human_auc_judd_peak, truth.sidecar.human_auc_judd_peak_blur
    );
}

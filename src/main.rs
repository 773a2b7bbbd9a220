//! The `meshgaze` command line: a thin layer over the library.
mod commands;

use clap::{Parser, Subcommand};

/// Build and validate 3D eye-fixation datasets on polygon meshes, and compute mesh saliency.
///
/// Start with `meshgaze demo` (no input needed), then `meshgaze saliency MESH -o OUT` on your
/// own meshes. Every output comes with a JSON sidecar recording the tool version, the
/// parameters and the SHA-256 of each input file.
#[derive(Parser)]
#[command(name = "meshgaze", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    Saliency(commands::saliency::SaliencyArgs),
    Score(commands::score::ScoreArgs),
    Stimulus(commands::stimulus::StimulusArgs),
    Ingest(commands::ingest::IngestArgs),
    Simulate(commands::simulate::SimulateArgs),
    Project(commands::project::ProjectArgs),
    Truth(commands::truth::TruthArgs),
    Experiment(commands::experiment::ExperimentArgs),
    Features(commands::features::FeaturesArgs),
    Demo(commands::demo::DemoArgs),
    Bench(commands::bench::BenchArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Saliency(args) => commands::saliency::run(args),
        Command::Score(args) => commands::score::run(args),
        Command::Stimulus(args) => commands::stimulus::run(args),
        Command::Ingest(args) => commands::ingest::run(args),
        Command::Simulate(args) => commands::simulate::run(args),
        Command::Project(args) => commands::project::run(args),
        Command::Truth(args) => commands::truth::run(args),
        Command::Experiment(args) => commands::experiment::run(args),
        Command::Features(args) => commands::features::run(args),
        Command::Demo(args) => commands::demo::run(args),
        Command::Bench(args) => commands::bench::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("meshgaze: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

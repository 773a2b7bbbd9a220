//! The `meshgaze` command line: a thin layer over the library.
mod cli;

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
    Saliency(cli::saliency::SaliencyArgs),
    Score(cli::score::ScoreArgs),
    Stimulus(cli::stimulus::StimulusArgs),
    Ingest(cli::ingest::IngestArgs),
    Simulate(cli::simulate::SimulateArgs),
    Project(cli::project::ProjectArgs),
    Truth(cli::truth::TruthArgs),
    Experiment(cli::experiment::ExperimentArgs),
    Features(cli::features::FeaturesArgs),
    Demo(cli::demo::DemoArgs),
    Bench(cli::bench::BenchArgs),
    Protocol(cli::protocol::ProtocolArgs),
    Study(cli::study::StudyArgs),
    Train(cli::train::TrainArgs),
    View(cli::view::ViewArgs),
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Saliency(args) => cli::saliency::run(args),
        Command::Score(args) => cli::score::run(args),
        Command::Stimulus(args) => cli::stimulus::run(args),
        Command::Ingest(args) => cli::ingest::run(args),
        Command::Simulate(args) => cli::simulate::run(args),
        Command::Project(args) => cli::project::run(args),
        Command::Truth(args) => cli::truth::run(args),
        Command::Experiment(args) => cli::experiment::run(args),
        Command::Features(args) => cli::features::run(args),
        Command::Demo(args) => cli::demo::run(args),
        Command::Bench(args) => cli::bench::run(args),
        Command::Protocol(args) => cli::protocol::run(args),
        Command::Study(args) => cli::study::run(args),
        Command::Train(args) => cli::train::run(args),
        Command::View(args) => cli::view::run(args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("meshgaze: error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

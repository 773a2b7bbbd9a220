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
    keep_freed_memory();
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

/// glibc gives every freed block above its mmap threshold (128 KB, rising to at most 32 MB)
/// back to the system and trims the free top of its heaps, so the next block of that size
/// comes as fresh zeroed pages, one page fault per 4 KB. meshgaze allocates and frees blocks of
/// megabytes over and over (every blur level of `score` builds maps, merged sums and SI's dense
/// matrices), so the binary keeps freed memory for reuse instead: large blocks come from the
/// heap like small ones, and the heap is never trimmed. The library leaves the allocator alone
/// (the Python module runs inside another program's process).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn keep_freed_memory() {
    // SAFETY: mallopt only sets allocator parameters, and runs before any other thread exists.
    unsafe {
        libc::mallopt(libc::M_MMAP_MAX, 0);
        libc::mallopt(libc::M_TRIM_THRESHOLD, libc::c_int::MAX);
    }
}

#[cfg(not(all(target_os = "linux", target_env = "gnu")))]
fn keep_freed_memory() {}

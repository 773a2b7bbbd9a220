use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};

use meshgaze::protocol::Protocol;
use meshgaze::protocol::{BUILTIN_NAME, BUILTIN_TOML};

/// Show the built-in experiment protocol, or check a protocol file.
///
/// A protocol (TOML, documented in protocols/README.md) fixes the display, the video, the
/// viewpoints and their timing, the rendering, and the fixation rules. The paper's protocol
/// (hu2020) is compiled into meshgaze and used wherever --protocol is not given, so every
/// command works from any directory. To make your own: `meshgaze protocol show > mine.toml`,
/// edit it, then `meshgaze protocol check mine.toml`.
#[derive(Debug, Args)]
pub struct ProtocolArgs {
    #[command(subcommand)]
    pub action: ProtocolAction,
}

#[derive(Debug, Subcommand)]
pub enum ProtocolAction {
    /// Print the built-in protocol (hu2020.toml) to stdout.
    Show,
    /// Validate a protocol file and summarize it; exits non-zero with the file, line and
    /// column of the first problem.
    Check {
        /// The protocol file (TOML).
        file: PathBuf,
    },
}

pub fn run(args: ProtocolArgs) -> Result<()> {
    match args.action {
        ProtocolAction::Show => {
            print!("{BUILTIN_TOML}");
            Ok(())
        }
        ProtocolAction::Check { file } => {
            let (p, _) = Protocol::load(&file)?;
            println!("{}: valid protocol `{}`", file.display(), p.name);
            println!(
                "  video {}x{} at {} fps, {:.1} s ({} frames); {} viewpoints, hold {} s, move {} s",
                p.display.width_px,
                p.display.height_px,
                p.video.fps,
                p.duration_s(),
                p.frame_count(),
                p.viewpoints.count,
                p.timing.hold_s,
                p.timing.move_s
            );
            println!(
                "  fixations: drop the first {} and last {}, keep the {} longest",
                p.fixations.drop_first, p.fixations.drop_last, p.fixations.keep_longest
            );
            if file.as_os_str() != BUILTIN_NAME {
                let (builtin, _) = Protocol::builtin();
                if builtin == p {
                    println!("  (identical in content to the built-in hu2020 protocol)");
                }
            }
            Ok(())
        }
    }
}

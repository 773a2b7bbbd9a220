use std::path::PathBuf;

use anyhow::{Context, Result};
use clap::Args;

use meshgaze::mesh::load_mesh;
use meshgaze::protocol::Protocol;
use meshgaze::stimulus::{render_stimulus, FrameImages, StimulusOptions};

use super::progress_bar::Bars;

/// Render the eye-tracking stimulus of a mesh: a turntable video and its camera timeline.
///
/// Writes DIR/stimulus.mp4 (H.264 High, yuv420p, constant frame rate, exactly the protocol's
/// duration), DIR/timeline.csv (one row per frame: index, time in ms, phase hold/move,
/// viewpoint, camera position, view and projection matrices, viewport) and DIR/manifest.json
/// (the protocol, SHA-256 of mesh, protocol, video and timeline, tool version, camera plan).
/// `meshgaze project` refuses a manifest whose hashes do not match the files.
///
/// The protocol (TOML, see protocols/README.md) fixes the display, frame rate, viewpoints,
/// timing, lighting and framing; protocols/hu2020.toml reproduces the paper's 48 s video.
#[derive(Debug, Args)]
pub struct StimulusArgs {
    /// The mesh (.obj, .ply, .off, optionally .gz).
    pub mesh: PathBuf,
    /// The protocol file [default: the built-in hu2020 protocol, printed by
    /// `meshgaze protocol show`].
    #[arg(long)]
    pub protocol: Option<PathBuf>,
    /// Output folder.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Also write frames as PNG: the first frame of every hold, or every frame.
    #[arg(long, value_enum, default_value_t = FrameImages::None)]
    pub frames: FrameImages,
    /// Also write a triangle-id image of every keyframe (RGB = triangle index + 1, 0 = none).
    #[arg(long)]
    pub id_buffer: bool,
    /// Decode the encoded video back and compare it with the rendered frames (slower).
    #[arg(long)]
    pub verify: bool,
    /// No progress bars.
    #[arg(short, long)]
    pub quiet: bool,
}

pub fn run(args: StimulusArgs) -> Result<()> {
    let (protocol, text, protocol_name) = Protocol::load_or_builtin(args.protocol.as_deref())?;
    let (mesh, _) = load_mesh(&args.mesh)?;
    let options = StimulusOptions {
        frames: args.frames,
        id_buffer: args.id_buffer,
        verify: args.verify,
    };
    let bars = Bars::new(args.quiet);
    let m = render_stimulus(
        &args.mesh,
        &mesh,
        &protocol,
        &text,
        &protocol_name,
        &args.output,
        &options,
        &bars,
    )
    .map_err(anyhow::Error::msg)
    .with_context(|| format!("rendering the stimulus of {}", args.mesh.display()))?;
    if !args.quiet {
        eprintln!(
            "{}: {} frames ({:.1} s at {} fps, {}x{}) in {:.1} s (render {:.1} s: {} rendered, {} reused; encode {:.1} s); video {:.1} MB",
            args.mesh.display(),
            m.video.frames,
            m.video.duration_s,
            m.video.fps,
            m.video.width,
            m.video.height,
            m.timings.total_s,
            m.timings.render_s,
            m.timings.frames_rendered,
            m.timings.frames_reused,
            m.timings.encode_s,
            m.video.bytes as f64 / 1e6
        );
        if let Some(v) = &m.verify {
            eprintln!(
                "  decoded back: {} frames, lowest PSNR {:.1} dB, {} channel values off by > 48",
                v.frames_decoded, v.min_psnr_db, v.outlier_values
            );
        }
        eprintln!(
            "wrote {}/stimulus.mp4, timeline.csv, manifest.json",
            args.output.display()
        );
    }
    Ok(())
}

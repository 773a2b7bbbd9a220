//! Stimulus rendering: a protocol and a mesh become a turntable video, the camera timeline
//! of every frame, and a manifest with the hashes that later stages check.
pub mod camera;
mod error;
mod frame_loop;
pub(crate) mod h264_repeat;
pub mod hold_views;
pub mod load;
mod manifest;
pub(crate) mod overlay;

pub mod raster;
mod timeline;
pub mod video;
mod video_error;

pub use error::StimulusError;
pub use manifest::{
    manifest_path, Manifest, MeshFacts, TimelineFacts, Timings, VerifyReport, VideoFacts,
};
pub use timeline::{timeline_header, timeline_row};
pub use video_error::{H264StreamError, VideoError};

use frame_loop::render_frames;
use timeline::write_timeline;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

pub use camera::{CameraPlan, CameraState, Phase};

use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::protocol::Protocol;
use crate::provenance::{sha256_hex, InputFile, Provenance};

/// Which frames to also write as PNG.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum FrameImages {
    /// No PNG.
    None,
    /// The first frame of every hold.
    Keyframes,
    /// Every frame.
    All,
}

/// What to write beside the video.
#[derive(Debug, Clone)]
pub struct StimulusOptions {
    /// Which frames to also write as PNG.
    pub frames: FrameImages,
    /// Per-keyframe triangle-id images (no anti-aliasing).
    pub id_buffer: bool,
    /// Keep the encoded stream in memory and decode it back to check it.
    pub verify: bool,
}

/// Renders the stimulus of `mesh` under `protocol` into `out_dir`: stimulus.mp4, timeline.csv,
/// manifest.json (and frame / id images when asked).
#[allow(clippy::too_many_arguments)]
pub fn render_stimulus(
    mesh_file: &Path,
    mesh: &Mesh,
    protocol: &Protocol,
    protocol_text: &str,
    protocol_name: &str,
    out_dir: &Path,
    options: &StimulusOptions,
    progress: &dyn Progress,
) -> Result<Manifest, StimulusError> {
    let t0 = Instant::now();
    std::fs::create_dir_all(out_dir).map_err(StimulusError::io(out_dir))?;
    let plan = CameraPlan::new(mesh, protocol).map_err(StimulusError::Camera)?;
    let (w, h) = (protocol.display.width_px, protocol.display.height_px);
    let fps = protocol.video.fps;
    let n_frames = protocol.frame_count();
    let video_path = out_dir.join("stimulus.mp4");
    let settings = video::VideoSettings {
        width: w as usize,
        height: h as usize,
        fps,
        bitrate_bps: protocol.video.bitrate_bps,
        keyframe_interval: protocol.video.keyframe_interval_frames,
    };
    let file = video::Mp4File::create(&video_path, &settings).map_err(StimulusError::Video)?;
    let timeline_path = out_dir.join("timeline.csv");
    let frames_dir = out_dir.join("frames");
    if options.frames != FrameImages::None || options.id_buffer {
        std::fs::create_dir_all(&frames_dir).map_err(StimulusError::io(&frames_dir))?;
    }
    write_timeline(&plan, protocol, &timeline_path).map_err(StimulusError::io(&timeline_path))?;
    let (frames, counts, checkers) = render_frames(
        mesh,
        &plan,
        protocol,
        &settings,
        file,
        &frames_dir,
        options,
        progress,
    )
    .map_err(StimulusError::Video)?;
    let verify = options.verify.then(|| VerifyReport {
        frames_decoded: checkers.iter().map(|c| c.frames_decoded).sum(),
        min_psnr_db: checkers
            .iter()
            .map(|c| c.min_psnr_db)
            .fold(f64::INFINITY, f64::min),
        outlier_values: checkers.iter().map(|c| c.outlier_values).sum(),
    });
    let video_file = InputFile::hash(&video_path).map_err(StimulusError::io(&video_path))?;
    let timeline_file =
        InputFile::hash(&timeline_path).map_err(StimulusError::io(&timeline_path))?;
    let mesh_input = InputFile::hash(mesh_file).map_err(StimulusError::io(mesh_file))?;
    let protocol_input = InputFile::of_bytes(protocol_name, protocol_text.as_bytes());
    let manifest = Manifest {
        provenance: Provenance::new(vec![mesh_input.clone(), protocol_input]),
        protocol: protocol.clone(),
        protocol_toml: protocol_text.to_string(),
        protocol_sha256: sha256_hex(protocol_text.as_bytes()),
        mesh: MeshFacts {
            file: path_from(out_dir, mesh_file).display().to_string(),
            sha256: mesh_input.sha256,
            vertices: mesh.positions.len(),
            triangles: mesh.triangles.len(),
        },
        video: VideoFacts {
            file: "stimulus.mp4".into(),
            sha256: video_file.sha256,
            codec: "H.264 High@4.0, yuv420p, BT.709, constant frame rate, fast start",
            width: w,
            height: h,
            fps,
            frames,
            duration_s: frames as f64 / fps as f64,
            bytes: video_file.bytes,
        },
        timeline: TimelineFacts {
            file: "timeline.csv".into(),
            sha256: timeline_file.sha256,
            rows: n_frames,
        },
        camera: plan,
        timings: Timings {
            render_s: counts.render_s,
            encode_s: counts.encode_s,
            total_s: t0.elapsed().as_secs_f64(),
            frames_rendered: counts.rendered,
            frames_reused: counts.reused,
        },
        verify,
    };
    let manifest_path = out_dir.join("manifest.json");
    let json = serde_json::to_string_pretty(&manifest)
        .map_err(|e| StimulusError::Manifest(e.to_string()))?
        + "\n";
    std::fs::write(&manifest_path, json).map_err(StimulusError::io(&manifest_path))?;
    Ok(manifest)
}

/// `target` as the manifest names it: relative to the manifest's folder `base` (so a study
/// folder moved as a whole still finds its meshes, and no later command depends on the
/// working directory it runs from), or absolute where the two share no root.
pub(crate) fn path_from(base: &Path, target: &Path) -> PathBuf {
    let absolute = |p: &Path| {
        std::fs::canonicalize(p)
            .or_else(|_| std::path::absolute(p))
            .unwrap_or_else(|_| p.to_path_buf())
    };
    let (base, target) = (absolute(base), absolute(target));
    let (b, t): (Vec<_>, Vec<_>) = (base.components().collect(), target.components().collect());
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return target;
    }
    let mut relative = PathBuf::new();
    for _ in common..b.len() {
        relative.push("..");
    }
    for c in &t[common..] {
        relative.push(c.as_os_str());
    }
    relative
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_manifest_names_its_mesh_from_its_own_folder() {
        let root = std::env::temp_dir().join(format!("meshgaze-path-from-{}", std::process::id()));
        let (meshes, stimulus) = (root.join("meshes"), root.join("study/stimuli/m"));
        std::fs::create_dir_all(&meshes).unwrap();
        std::fs::create_dir_all(&stimulus).unwrap();
        std::fs::write(meshes.join("m.obj"), b"v 0 0 0\n").unwrap();
        let named = path_from(&stimulus, &meshes.join("m.obj"));
        assert_eq!(named, Path::new("../../../meshes/m.obj"));
        assert!(stimulus.join(&named).exists());
        // Spelled with `..` and `.` on the way: the same file, the same name.
        let roundabout = root.join("study/../meshes/./m.obj");
        assert_eq!(path_from(&stimulus, &roundabout), named);
        // A mesh inside the stimulus folder.
        std::fs::write(stimulus.join("own.obj"), b"v 0 0 0\n").unwrap();
        assert_eq!(
            path_from(&stimulus, &stimulus.join("own.obj")),
            Path::new("own.obj")
        );
        std::fs::remove_dir_all(&root).unwrap();
    }
}

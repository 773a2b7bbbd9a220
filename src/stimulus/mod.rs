//! Stimulus rendering: a protocol and a mesh become a turntable video, the camera timeline
//! of every frame, and a manifest with the hashes that later stages check.
pub mod camera;
mod error;
pub mod h264_repeat;
pub mod hold_views;
pub mod load;
pub mod overlay;

pub mod raster;
pub mod video;

pub use error::StimulusError;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use serde::Serialize;

pub use camera::{CameraPlan, CameraState, Phase};

use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::protocol::Protocol;
use crate::provenance::{sha256_hex, InputFile, Provenance};
use raster::Rasterizer;

/// Which frames to also write as PNG.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum FrameImages {
    None,
    /// The first frame of every hold.
    Keyframes,
    /// Every frame.
    All,
}

#[derive(Debug, Clone)]
pub struct StimulusOptions {
    pub frames: FrameImages,
    /// Per-keyframe triangle-id images (no anti-aliasing).
    pub id_buffer: bool,
    /// Keep the encoded stream in memory and decode it back to check it.
    pub verify: bool,
}

#[derive(Debug, Clone, Serialize)]
pub struct VideoFacts {
    pub file: String,
    pub sha256: String,
    pub codec: &'static str,
    pub width: u32,
    pub height: u32,
    pub fps: u32,
    pub frames: usize,
    pub duration_s: f64,
    pub bytes: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct Timings {
    /// Seconds spent drawing frames (and overlays, PNGs), summed over the video's two
    /// segments, which render side by side.
    pub render_s: f64,
    /// Seconds the segments' encoder threads spent encoding, summed. Renderers and encoders
    /// all run at once (on a 2-core machine they share the cores), so the two add up to more
    /// than `total_s`.
    pub encode_s: f64,
    pub total_s: f64,
    pub frames_rendered: usize,
    pub frames_reused: usize,
}

/// What a decoded-back check found.
#[derive(Debug, Clone, Serialize)]
pub struct VerifyReport {
    pub frames_decoded: usize,
    pub min_psnr_db: f64,
    /// Channel values off by more than 48 from the rendered frame, over all frames.
    pub outlier_values: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct Manifest {
    pub provenance: Provenance,
    pub protocol: Protocol,
    /// The protocol file's text, byte for byte.
    pub protocol_toml: String,
    pub protocol_sha256: String,
    pub mesh: MeshFacts,
    pub video: VideoFacts,
    pub timeline: TimelineFacts,
    pub camera: CameraPlan,
    pub timings: Timings,
    pub verify: Option<VerifyReport>,
}

#[derive(Debug, Clone, Serialize)]
pub struct MeshFacts {
    pub file: String,
    pub sha256: String,
    pub vertices: usize,
    pub triangles: usize,
}

#[derive(Debug, Clone, Serialize)]
pub struct TimelineFacts {
    pub file: String,
    pub sha256: String,
    pub rows: usize,
}

/// The timeline CSV header: one row per frame.
pub fn timeline_header() -> String {
    let mut h = vec![
        "frame",
        "time_ms",
        "phase",
        "viewpoint",
        "next_viewpoint",
        "progress",
        "eye_x",
        "eye_y",
        "eye_z",
    ]
    .into_iter()
    .map(String::from)
    .collect::<Vec<_>>();
    for m in ["view", "proj"] {
        for r in 0..4 {
            for c in 0..4 {
                h.push(format!("{m}_r{r}c{c}"));
            }
        }
    }
    h.extend(["viewport_x", "viewport_y", "viewport_w", "viewport_h"].map(String::from));
    h.join(",")
}

/// One timeline row (shortest exact float formatting, so a recomputed camera compares byte
/// for byte).
pub fn timeline_row(frame: usize, cam: &CameraState) -> String {
    let mut f = vec![
        frame.to_string(),
        format!("{}", cam.time_s * 1000.0),
        cam.phase.name().to_string(),
        cam.viewpoint.to_string(),
        cam.next_viewpoint.to_string(),
        format!("{}", cam.progress),
        format!("{}", cam.eye.x),
        format!("{}", cam.eye.y),
        format!("{}", cam.eye.z),
    ];
    for m in [cam.view, cam.projection] {
        for r in 0..4 {
            for c in 0..4 {
                f.push(format!("{}", m.col(c)[r]));
            }
        }
    }
    f.extend([
        "0".into(),
        "0".into(),
        cam.width_px.to_string(),
        cam.height_px.to_string(),
    ]);
    f.join(",")
}

fn save_png(path: &Path, rgb: &[u8], w: u32, h: u32) -> Result<(), String> {
    image::save_buffer(path, rgb, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| format!("{}: {e}", path.display()))
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
            file: mesh_file.display().to_string(),
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

/// Where the frame loop's time went and how many frames it drew.
#[derive(Default)]
struct FrameCounts {
    render_s: f64,
    encode_s: f64,
    rendered: usize,
    reused: usize,
}

/// The camera of every frame, one CSV row each.
fn write_timeline(plan: &CameraPlan, protocol: &Protocol, path: &Path) -> std::io::Result<()> {
    let mut timeline = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(timeline, "{}", timeline_header())?;
    for i in 0..protocol.frame_count() {
        let cam = plan.at(i as f64 / protocol.video.fps as f64);
        writeln!(timeline, "{}", timeline_row(i, &cam))?;
    }
    timeline.flush()
}

/// Where the video is cut into separately encoded segments: at the keyframe nearest its
/// middle, so the two halves encode side by side. The cut depends on the protocol alone, never
/// on the machine, so the bytes are the same everywhere. No cut when the keyframe interval
/// is under 2 (two keyframes in a row would then come from two encoders, and H.264 wants
/// consecutive keyframes to carry different ids) or the video is too short to have a
/// keyframe inside.
fn segment_bounds(frames: usize, keyframe_interval: usize) -> Vec<usize> {
    if keyframe_interval >= 2 {
        let cut =
            ((frames as f64 / 2.0 / keyframe_interval as f64).round() as usize) * keyframe_interval;
        if cut > 0 && cut < frames {
            return vec![0, cut, frames];
        }
    }
    vec![0, frames]
}

/// Every frame's picture (drawn once per hold, every frame of a move), the sync overlays,
/// the optional PNGs, and the encoder, in two segments side by side (`segment_bounds`).
/// Returns the frame count, where the time went, and each segment's decode check.
#[allow(clippy::too_many_arguments)]
fn render_frames(
    mesh: &Mesh,
    plan: &CameraPlan,
    protocol: &Protocol,
    settings: &video::VideoSettings,
    file: video::Mp4File,
    frames_dir: &Path,
    options: &StimulusOptions,
    progress: &dyn Progress,
) -> Result<(usize, FrameCounts, Vec<video::Checker>), String> {
    let raster = Rasterizer::new(mesh);
    let n_frames = protocol.frame_count();
    let bounds = segment_bounds(n_frames, protocol.video.keyframe_interval_frames as usize);
    progress.start("rendering + encoding", n_frames as u64);
    // A failing segment stops the others at their next frame.
    let stop = &std::sync::atomic::AtomicBool::new(false);
    let mut file = Some(file);
    let results: Vec<Result<SegmentResult, String>> = std::thread::scope(|scope| {
        let handles: Vec<_> = bounds
            .windows(2)
            .map(|range| {
                let sink = match file.take() {
                    Some(f) => video::FrameSink::File(Box::new(f)),
                    None => video::FrameSink::Memory(Vec::new()),
                };
                let segment = Segment {
                    raster: &raster,
                    plan,
                    protocol,
                    frames_dir,
                    options,
                    progress,
                    stop,
                };
                let (first, end) = (range[0], range[1]);
                scope.spawn(move || {
                    let result = video::SegmentEncoder::new(settings, first, sink, options.verify)
                        .and_then(|encoder| segment.run(first..end, encoder));
                    if result.is_err() {
                        stop.store(true, std::sync::atomic::Ordering::Relaxed);
                    }
                    result
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .unwrap_or_else(|_| Err("a stimulus segment's thread panicked".into()))
            })
            .collect()
    });
    progress.finish();
    let mut counts = FrameCounts::default();
    let mut checkers = Vec::new();
    let mut file = None;
    for result in results {
        let done = result?;
        counts.render_s += done.counts.render_s;
        counts.encode_s += done.counts.encode_s;
        counts.rendered += done.counts.rendered;
        counts.reused += done.counts.reused;
        checkers.extend(done.checker);
        match (done.sink, file.as_mut()) {
            (video::FrameSink::File(f), None) => file = Some(*f),
            (video::FrameSink::Memory(frames), Some(f)) => {
                for frame in &frames {
                    f.write(&frame.annexb, frame.key)?;
                }
            }
            _ => return Err("stimulus segments out of order (a bug)".into()),
        }
    }
    let frames = file
        .ok_or("no stimulus segment wrote the file (a bug)")?
        .finish()?;
    Ok((frames, counts, checkers))
}

/// What one segment hands back: its time and counts, its frames' destination, its check.
struct SegmentResult {
    counts: FrameCounts,
    sink: video::FrameSink,
    checker: Option<video::Checker>,
}

/// What every segment shares.
struct Segment<'a> {
    raster: &'a Rasterizer<'a>,
    plan: &'a CameraPlan,
    protocol: &'a Protocol,
    frames_dir: &'a Path,
    options: &'a StimulusOptions,
    progress: &'a dyn Progress,
    stop: &'a std::sync::atomic::AtomicBool,
}

impl Segment<'_> {
    /// Frame `i` with its overlays, and whether it begins a hold. A hold's image is rendered
    /// once and reused (`cached`: the viewpoint and image of the current hold).
    fn frame(
        &self,
        i: usize,
        cached: &mut Option<(usize, Arc<Vec<u8>>)>,
        counts: &mut FrameCounts,
    ) -> (Arc<Vec<u8>>, bool) {
        let protocol = self.protocol;
        let (w, h) = (protocol.display.width_px, protocol.display.height_px);
        let fps = protocol.video.fps;
        let overlays = protocol.sync.photodiode || protocol.sync.frame_counter;
        let cam = self.plan.at(i as f64 / fps as f64);
        let tr = Instant::now();
        // The first frame of a hold (from the plan: a segment may begin inside one).
        let previous = (i > 0).then(|| self.plan.at((i - 1) as f64 / fps as f64));
        let hold_start = cam.phase == Phase::Hold
            && previous.is_none_or(|p| p.phase != Phase::Hold || p.viewpoint != cam.viewpoint);
        let image = match cached {
            Some((viewpoint, image)) if cam.phase == Phase::Hold && *viewpoint == cam.viewpoint => {
                counts.reused += 1;
                image.clone()
            }
            _ => {
                counts.rendered += 1;
                let img = Arc::new(self.raster.render(&cam, &protocol.rendering));
                let key = if cam.phase == Phase::Hold {
                    cam.viewpoint
                } else {
                    usize::MAX
                };
                *cached = Some((key, img.clone()));
                img
            }
        };
        let frame = if overlays {
            let mut f = image.as_ref().clone();
            overlay::apply(&mut f, w as usize, h as usize, i, cam.phase, &protocol.sync);
            Arc::new(f)
        } else {
            image
        };
        counts.render_s += tr.elapsed().as_secs_f64();
        (frame, hold_start)
    }

    /// The frame as PNG (every frame, or the first of each hold), and the hold's vertex-id
    /// buffer, as the options ask.
    fn save_frame_images(&self, i: usize, frame: &[u8], hold_start: bool) -> Result<(), String> {
        let protocol = self.protocol;
        let (w, h) = (protocol.display.width_px, protocol.display.height_px);
        let options = self.options;
        if options.frames == FrameImages::All
            || (options.frames == FrameImages::Keyframes && hold_start)
        {
            save_png(
                &self.frames_dir.join(format!("frame_{i:05}.png")),
                frame,
                w,
                h,
            )?;
        }
        if options.id_buffer && hold_start {
            let cam = self.plan.at(i as f64 / protocol.video.fps as f64);
            save_id_buffer(
                self.raster,
                &cam,
                &self.frames_dir.join(format!("ids_{i:05}.png")),
            )?;
        }
        Ok(())
    }
    /// Renders the frames of `range` in order and encodes them on a thread of its own.
    fn run(
        &self,
        range: std::ops::Range<usize>,
        mut encoder: video::SegmentEncoder,
    ) -> Result<SegmentResult, String> {
        let mut counts = FrameCounts::default();
        let mut cached: Option<(usize, Arc<Vec<u8>>)> = None; // (viewpoint, image) of the current hold
                                                              // The encoder runs on its own thread behind the renderer: it takes frames in order, so
                                                              // the video is the same bytes as when one thread did both, and the wall time is about
                                                              // the larger of the two instead of their sum. A hold repeats one image (the same Arc),
                                                              // so the queue bounds only distinct images: the renderer can run through a
                                                              // transition while the encoder works through a hold.
        let in_flight = InFlight::new(IN_FLIGHT_IMAGES);
        let (send, receive) = std::sync::mpsc::channel::<(Arc<Vec<u8>>, bool)>();
        let (encoded, encoder) = std::thread::scope(|scope| -> Result<_, String> {
            let in_flight = &in_flight;
            let encoding = scope.spawn(move || -> Result<_, String> {
                // Whatever way this thread ends, the renderer must not wait for it any more.
                let _closing = in_flight.close_on_drop();
                let mut seconds = 0.0;
                for (frame, distinct) in receive {
                    let te = Instant::now();
                    if distinct {
                        encoder.push(&frame)?;
                        in_flight.release();
                    } else {
                        encoder.push_repeat(&frame)?;
                    }
                    seconds += te.elapsed().as_secs_f64();
                }
                Ok((seconds, encoder))
            });
            let mut last_sent: Option<Arc<Vec<u8>>> = None;
            let rendering = (|| -> Result<(), String> {
                for i in range {
                    if self.stop.load(std::sync::atomic::Ordering::Relaxed) {
                        break; // another segment failed; its error is the one to report
                    }
                    let (frame, hold_start) = self.frame(i, &mut cached, &mut counts);
                    self.save_frame_images(i, &frame, hold_start)?;
                    let distinct = !last_sent.as_ref().is_some_and(|l| Arc::ptr_eq(l, &frame));
                    // A distinct image waits for room; false: the encoder stopped, and its own
                    // error is the one to report.
                    if distinct && !in_flight.acquire() {
                        break;
                    }
                    last_sent = Some(frame.clone());
                    if send.send((frame, distinct)).is_err() {
                        break;
                    }
                    self.progress.advance(1);
                }
                Ok(())
            })();
            drop(send);
            let encoded = encoding
                .join()
                .map_err(|_| "the video encoder thread panicked".to_string())?;
            rendering?;
            encoded
        })?;
        counts.encode_s = encoded;
        let (sink, checker) = encoder.finish();
        Ok(SegmentResult {
            counts,
            sink,
            checker,
        })
    }
}

/// Distinct images each segment's renderer may have queued for its encoder: 16 at
/// 1680x1050 is 85 MB, 170 MB for the two segments.
const IN_FLIGHT_IMAGES: usize = 16;

/// A counting semaphore for the images in the queue, which the encoder closes when it ends
/// (done, failed or panicked) so the renderer never waits on it forever.
struct InFlight {
    state: std::sync::Mutex<(usize, bool)>,
    changed: std::sync::Condvar,
    limit: usize,
}

impl InFlight {
    fn new(limit: usize) -> InFlight {
        InFlight {
            state: std::sync::Mutex::new((0, false)),
            changed: std::sync::Condvar::new(),
            limit,
        }
    }

    /// Waits for room for one more image; false once the encoder has closed.
    fn acquire(&self) -> bool {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        while state.0 >= self.limit && !state.1 {
            state = self.changed.wait(state).unwrap_or_else(|e| e.into_inner());
        }
        if state.1 {
            return false;
        }
        state.0 += 1;
        true
    }

    fn release(&self) {
        let mut state = self.state.lock().unwrap_or_else(|e| e.into_inner());
        state.0 = state.0.saturating_sub(1);
        self.changed.notify_all();
    }

    fn close_on_drop(&self) -> impl Drop + '_ {
        struct Close<'a>(&'a InFlight);
        impl Drop for Close<'_> {
            fn drop(&mut self) {
                let mut state = self.0.state.lock().unwrap_or_else(|e| e.into_inner());
                state.1 = true;
                self.0.changed.notify_all();
            }
        }
        Close(self)
    }
}

/// The triangle under each pixel as a PNG: 24-bit id + 1 in RGB (0 = background), exact for
/// up to 16.7 million triangles.
fn save_id_buffer(raster: &Rasterizer, cam: &CameraState, path: &Path) -> Result<(), String> {
    let ids = raster.triangle_ids(cam);
    let rgb: Vec<u8> = ids
        .iter()
        .flat_map(|&t| {
            let v = if t == raster::BACKGROUND_ID { 0 } else { t + 1 };
            [(v >> 16) as u8, (v >> 8) as u8, v as u8]
        })
        .collect();
    save_png(path, &rgb, cam.width_px, cam.height_px)
}

/// Where a stimulus folder keeps its files.
pub fn manifest_path(dir: &Path) -> PathBuf {
    dir.join("manifest.json")
}

#[cfg(test)]
mod tests {
    use super::{segment_bounds, InFlight};

    #[test]
    fn the_video_is_cut_at_the_keyframe_nearest_its_middle() {
        assert_eq!(segment_bounds(1440, 60), vec![0, 720, 1440]);
        assert_eq!(segment_bounds(54, 20), vec![0, 20, 54]);
        assert_eq!(segment_bounds(100, 30), vec![0, 60, 100]);
        // No keyframe strictly inside, or a keyframe every frame: one segment.
        assert_eq!(segment_bounds(54, 60), vec![0, 54]);
        assert_eq!(segment_bounds(54, 1), vec![0, 54]);
        assert_eq!(segment_bounds(10, 40), vec![0, 10]);
        assert_eq!(segment_bounds(0, 60), vec![0, 0]);
    }

    #[test]
    fn queue_room_frees_on_release_and_never_blocks_after_the_encoder_ends() {
        let q = InFlight::new(2);
        assert!(q.acquire() && q.acquire());
        std::thread::scope(|s| {
            // The third image waits until the encoder has taken one.
            let waiting = s.spawn(|| q.acquire());
            std::thread::sleep(std::time::Duration::from_millis(50));
            assert!(!waiting.is_finished());
            q.release();
            assert!(waiting.join().unwrap());
        });
        // The queue is full again; the encoder ending (here: its guard dropped) wakes the
        // renderer with "stop" instead of leaving it waiting.
        std::thread::scope(|s| {
            let waiting = s.spawn(|| q.acquire());
            std::thread::sleep(std::time::Duration::from_millis(50));
            drop(q.close_on_drop());
            assert!(!waiting.join().unwrap());
        });
        assert!(!q.acquire());
    }
}

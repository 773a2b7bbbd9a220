//! The frame loop: every frame drawn (once per hold, every frame of a move), overlaid,
//! optionally saved as PNG, and encoded in two segments side by side.
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::camera::{CameraPlan, CameraState, Phase};
use super::raster::Rasterizer;
use super::video_error::VideoError;
use super::{video, FrameImages, StimulusOptions};
use crate::mesh::Mesh;
use crate::progress::Progress;
use crate::protocol::Protocol;

fn save_png(path: &Path, rgb: &[u8], w: u32, h: u32) -> Result<(), VideoError> {
    image::save_buffer(path, rgb, w, h, image::ExtendedColorType::Rgb8).map_err(|e| {
        VideoError::Image {
            path: path.to_path_buf(),
            detail: e.to_string(),
        }
    })
}

/// Where the frame loop's time went and how many frames it drew.
#[derive(Default)]
pub(super) struct FrameCounts {
    pub(super) render_s: f64,
    pub(super) encode_s: f64,
    pub(super) rendered: usize,
    pub(super) reused: usize,
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
pub(super) fn render_frames(
    mesh: &Mesh,
    plan: &CameraPlan,
    protocol: &Protocol,
    settings: &video::VideoSettings,
    file: video::Mp4File,
    frames_dir: &Path,
    options: &StimulusOptions,
    progress: &dyn Progress,
) -> Result<(usize, FrameCounts, Vec<video::Checker>), VideoError> {
    let raster = Rasterizer::new(mesh);
    let n_frames = protocol.frame_count();
    let bounds = segment_bounds(n_frames, protocol.video.keyframe_interval_frames as usize);
    progress.start("rendering + encoding", n_frames as u64);
    // A failing segment stops the others at their next frame.
    let stop = &std::sync::atomic::AtomicBool::new(false);
    let mut file = Some(file);
    let results: Vec<Result<SegmentResult, VideoError>> = std::thread::scope(|scope| {
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
                h.join().unwrap_or_else(|_| {
                    Err(VideoError::Thread("a stimulus segment's thread panicked"))
                })
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
            _ => return Err(VideoError::Thread("stimulus segments out of order (a bug)")),
        }
    }
    let frames = file
        .ok_or(VideoError::Thread(
            "no stimulus segment wrote the file (a bug)",
        ))?
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
            super::overlay::apply(&mut f, w as usize, h as usize, i, cam.phase, &protocol.sync);
            Arc::new(f)
        } else {
            image
        };
        counts.render_s += tr.elapsed().as_secs_f64();
        (frame, hold_start)
    }

    /// The frame as PNG (every frame, or the first of each hold), and the hold's vertex-id
    /// buffer, as the options ask.
    fn save_frame_images(
        &self,
        i: usize,
        frame: &[u8],
        hold_start: bool,
    ) -> Result<(), VideoError> {
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
    ) -> Result<SegmentResult, VideoError> {
        let mut counts = FrameCounts::default();
        let mut cached: Option<(usize, Arc<Vec<u8>>)> = None; // (viewpoint, image) of the current hold
                                                              // The encoder runs on its own thread behind the renderer: it takes frames in order, so
                                                              // the video is the same bytes as when one thread did both, and the wall time is about
                                                              // the larger of the two instead of their sum. A hold repeats one image (the same Arc),
                                                              // so the queue bounds only distinct images: the renderer can run through a
                                                              // transition while the encoder works through a hold.
        let in_flight = InFlight::new(IN_FLIGHT_IMAGES);
        let (send, receive) = std::sync::mpsc::channel::<(Arc<Vec<u8>>, bool)>();
        let (encoded, encoder) = std::thread::scope(|scope| -> Result<_, VideoError> {
            let in_flight = &in_flight;
            let encoding = scope.spawn(move || -> Result<_, VideoError> {
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
            let rendering = (|| -> Result<(), VideoError> {
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
                .map_err(|_| VideoError::Thread("the video encoder thread panicked"))?;
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
fn save_id_buffer(raster: &Rasterizer, cam: &CameraState, path: &Path) -> Result<(), VideoError> {
    let ids = raster.triangle_ids(cam);
    let rgb: Vec<u8> = ids
        .iter()
        .flat_map(|&t| {
            let v = if t == super::raster::BACKGROUND_ID {
                0
            } else {
                t + 1
            };
            [(v >> 16) as u8, (v >> 8) as u8, v as u8]
        })
        .collect();
    save_png(path, &rgb, cam.width_px, cam.height_px)
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

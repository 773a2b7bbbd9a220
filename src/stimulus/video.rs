//! H.264 in MP4 from RGB frames: openh264 (built from its bundled source, so nothing is
//! downloaded) and muxide (pure Rust, fast-start MP4 with the index before the data).
use std::io::{BufWriter, Write};
use std::path::Path;

use openh264::encoder::{
    BitRate, Encoder, EncoderConfig, FrameRate, FrameType, IntraFramePeriod, Level, Profile,
    RateControlMode, UsageType, VuiConfig,
};
use openh264::formats::{RgbSliceU8, YUVBuffer};
use openh264::OpenH264API;

/// The encoder's settings for one stimulus.
#[derive(Debug, Clone, Copy)]
pub struct VideoSettings {
    pub width: usize,
    pub height: usize,
    pub fps: u32,
    pub bitrate_bps: u32,
    pub keyframe_interval: u32,
}

/// One frame's H.264 access unit (Annex B) and whether it is a keyframe.
pub struct EncodedFrame {
    pub annexb: Vec<u8>,
    pub key: bool,
}

/// An MP4 file being written, one access unit after another.
pub struct Mp4File {
    muxer: muxide::api::Muxer<BufWriter<std::fs::File>>,
    fps: f64,
    frames: usize,
}

impl Mp4File {
    pub fn create(path: &Path, settings: &VideoSettings) -> Result<Mp4File, String> {
        let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let muxer = muxide::api::MuxerBuilder::new(BufWriter::new(file))
            .video(
                muxide::api::VideoCodec::H264,
                settings.width as u32,
                settings.height as u32,
                settings.fps as f64,
            )
            .with_fast_start(true)
            .build()
            .map_err(|e| format!("{}: cannot start the MP4 muxer: {e:?}", path.display()))?;
        Ok(Mp4File {
            muxer,
            fps: settings.fps as f64,
            frames: 0,
        })
    }

    /// Appends the next frame; it is shown at frame_index / fps seconds.
    pub fn write(&mut self, annexb: &[u8], key: bool) -> Result<(), String> {
        self.muxer
            .write_video(self.frames as f64 / self.fps, annexb, key)
            .map_err(|e| format!("MP4 muxing failed at frame {}: {e:?}", self.frames))?;
        self.frames += 1;
        Ok(())
    }

    /// Writes the MP4 index; returns the frame count.
    pub fn finish(mut self) -> Result<usize, String> {
        self.muxer
            .finish_in_place()
            .map_err(|e| format!("cannot finish the MP4: {e:?}"))?;
        Ok(self.frames)
    }
}

/// Where a segment's encoded frames go: straight into the file (the first segment), or kept
/// until the segments before it are written.
pub enum FrameSink {
    File(Box<Mp4File>),
    Memory(Vec<EncodedFrame>),
}

/// Encodes one run of consecutive frames with an encoder of its own. Its first frame is a
/// keyframe, at a place where one encoder for the whole video puts a keyframe too, so the
/// runs decode one after another as one stream; two runs encode side by side on two cores.
pub struct SegmentEncoder {
    encoder: Encoder,
    yuv: YUVBuffer,
    width: usize,
    height: usize,
    /// The video's index of this run's first frame (for messages).
    first_frame: usize,
    frames: usize,
    annexb: Vec<u8>,
    sink: FrameSink,
    /// Decodes every frame right after encoding it and compares, when asked for.
    checker: Option<Checker>,
}

/// Running comparison of decoded frames with the frames that were encoded.
pub struct Checker {
    decoder: openh264::decoder::Decoder,
    decoded: Vec<u8>,
    pub frames_decoded: usize,
    pub min_psnr_db: f64,
    pub outlier_values: usize,
}

impl SegmentEncoder {
    pub fn new(
        settings: &VideoSettings,
        first_frame: usize,
        sink: FrameSink,
        check: bool,
    ) -> Result<SegmentEncoder, String> {
        let config = EncoderConfig::new()
            .bitrate(BitRate::from_bps(settings.bitrate_bps))
            .max_frame_rate(FrameRate::from_hz(settings.fps as f32))
            .rate_control_mode(RateControlMode::Bitrate)
            .usage_type(UsageType::CameraVideoRealTime)
            .profile(Profile::High)
            .level(Level::Level_4_0)
            .skip_frames(false)
            .intra_frame_period(IntraFramePeriod::from_num_frames(
                settings.keyframe_interval,
            ))
            // On by default, it leaves isolated bright or dark pixels in P-frames: unacceptable
            // in an eye-tracking stimulus (measured in shared/docs/rust-ecosystem.md §3).
            .background_detection(false)
            // One thread per encoder, whatever the machine (a single slice gives its threads
            // nothing to share; the same bytes as openh264's automatic setting): the
            // segments are the parallelism.
            .num_threads(1)
            .vui(VuiConfig::bt709());
        let encoder = Encoder::with_api_config(OpenH264API::from_source(), config)
            .map_err(|e| format!("cannot start the H.264 encoder: {e}"))?;
        let checker = if check {
            Some(Checker {
                decoder: openh264::decoder::Decoder::new().map_err(|e| e.to_string())?,
                decoded: vec![0; settings.width * settings.height * 3],
                frames_decoded: 0,
                min_psnr_db: f64::INFINITY,
                outlier_values: 0,
            })
        } else {
            None
        };
        Ok(SegmentEncoder {
            encoder,
            yuv: YUVBuffer::new(settings.width, settings.height),
            width: settings.width,
            height: settings.height,
            first_frame,
            frames: 0,
            annexb: Vec::new(),
            sink,
            checker,
        })
    }

    /// Appends one RGB frame.
    pub fn push(&mut self, rgb: &[u8]) -> Result<(), String> {
        assert_eq!(rgb.len(), self.width * self.height * 3);
        self.yuv
            .read_rgb8(RgbSliceU8::new(rgb, (self.width, self.height)));
        self.encode_current(rgb)
    }

    /// Appends a frame that is the same picture as the last one pushed (`rgb`, kept for the
    /// decode check): its colour conversion is skipped, and 3 of every 4 frames of a
    /// stimulus repeat a hold.
    pub fn push_repeat(&mut self, rgb: &[u8]) -> Result<(), String> {
        if self.frames == 0 {
            return self.push(rgb);
        }
        self.encode_current(rgb)
    }

    fn encode_current(&mut self, rgb: &[u8]) -> Result<(), String> {
        let at = self.first_frame + self.frames;
        let bitstream = self
            .encoder
            .encode(&self.yuv)
            .map_err(|e| format!("H.264 encoding failed at frame {at}: {e}"))?;
        let key = matches!(bitstream.frame_type(), FrameType::IDR | FrameType::I);
        if self.frames == 0 && !key {
            return Err(format!(
                "frame {at} starts an encoder but is not a keyframe"
            ));
        }
        self.annexb.clear();
        bitstream.write_vec(&mut self.annexb);
        if self.annexb.is_empty() {
            return Err(format!("the encoder skipped frame {at}"));
        }
        if let Some(ch) = self.checker.as_mut() {
            for nal in openh264::nal_units(&self.annexb) {
                let out = ch
                    .decoder
                    .decode(nal)
                    .map_err(|e| format!("decoding back frame {at}: {e}"))?;
                if let Some(yuv) = out {
                    yuv.write_rgb8(&mut ch.decoded);
                    let mut se = 0.0;
                    for (a, b) in ch.decoded.iter().zip(rgb) {
                        let d = *a as f64 - *b as f64;
                        se += d * d;
                        if d.abs() > 48.0 {
                            ch.outlier_values += 1;
                        }
                    }
                    let mse = se / rgb.len() as f64;
                    let psnr = if mse == 0.0 {
                        99.0
                    } else {
                        10.0 * (255.0f64 * 255.0 / mse).log10()
                    };
                    ch.min_psnr_db = ch.min_psnr_db.min(psnr);
                    ch.frames_decoded += 1;
                }
            }
        }
        match &mut self.sink {
            FrameSink::File(file) => file.write(&self.annexb, key)?,
            FrameSink::Memory(frames) => frames.push(EncodedFrame {
                annexb: std::mem::take(&mut self.annexb),
                key,
            }),
        }
        self.frames += 1;
        Ok(())
    }

    /// The frames' destination (with the frames if kept in memory) and the decode check.
    pub fn finish(self) -> (FrameSink, Option<Checker>) {
        (self.sink, self.checker)
    }
}

/// Writes bytes to a file, flushing.
pub fn write_all(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = BufWriter::new(std::fs::File::create(path)?);
    f.write_all(bytes)?;
    f.flush()
}

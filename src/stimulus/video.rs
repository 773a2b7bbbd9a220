//! H.264 in MP4 from RGB frames: openh264 (built from its bundled source, so nothing is
//! downloaded) and muxide (pure Rust, fast-start MP4 with the index before the data).
use super::video_error::VideoError;
use std::io::{BufWriter, Write};
use std::path::Path;

use openh264::encoder::{
    BitRate, Encoder, EncoderConfig, FrameRate, FrameType, IntraFramePeriod, Level, Profile,
    RateControlMode, UsageType, VuiConfig,
};
use openh264::formats::{RgbSliceU8, YUVBuffer};
use openh264::OpenH264API;

use super::h264_repeat::RepeatWriter;

/// The encoder's settings for one stimulus.
#[derive(Debug, Clone, Copy)]
pub struct VideoSettings {
    /// Width, px.
    pub width: usize,
    /// Height, px.
    pub height: usize,
    /// Frames per second.
    pub fps: u32,
    /// Target bit rate, bits per second.
    pub bitrate_bps: u32,
    /// Frames between keyframes.
    pub keyframe_interval: u32,
}

/// One frame's H.264 access unit (Annex B) and whether it is a keyframe.
pub struct EncodedFrame {
    /// The access unit, Annex B byte stream.
    pub annexb: Vec<u8>,
    /// Whether it is a keyframe (IDR).
    pub key: bool,
}

/// An MP4 file being written, one access unit after another.
pub struct Mp4File {
    muxer: muxide::api::Muxer<BufWriter<std::fs::File>>,
    fps: f64,
    frames: usize,
}

impl Mp4File {
    /// Creates the file at `path` for a video of `settings`.
    pub fn create(path: &Path, settings: &VideoSettings) -> Result<Mp4File, VideoError> {
        let file = std::fs::File::create(path).map_err(|error| VideoError::Create {
            path: path.to_path_buf(),
            error,
        })?;
        let muxer = muxide::api::MuxerBuilder::new(BufWriter::new(file))
            .video(
                muxide::api::VideoCodec::H264,
                settings.width as u32,
                settings.height as u32,
                settings.fps as f64,
            )
            .with_fast_start(true)
            .build()
            .map_err(|e| VideoError::MuxerStart {
                path: path.to_path_buf(),
                detail: format!("{e:?}"),
            })?;
        Ok(Mp4File {
            muxer,
            fps: settings.fps as f64,
            frames: 0,
        })
    }

    /// Appends the next frame; it is shown at frame_index / fps seconds.
    pub fn write(&mut self, annexb: &[u8], key: bool) -> Result<(), VideoError> {
        self.muxer
            .write_video(self.frames as f64 / self.fps, annexb, key)
            .map_err(|e| VideoError::Mux {
                frame: self.frames,
                detail: format!("{e:?}"),
            })?;
        self.frames += 1;
        Ok(())
    }

    /// Writes the MP4 index; returns the frame count.
    pub fn finish(mut self) -> Result<usize, VideoError> {
        self.muxer
            .finish_in_place()
            .map_err(|e| VideoError::MuxFinish(format!("{e:?}")))?;
        Ok(self.frames)
    }
}

/// Where a segment's encoded frames go: straight into the file (the first segment), or kept
/// until the segments before it are written.
pub enum FrameSink {
    /// Written to the file as encoded.
    File(Box<Mp4File>),
    /// Kept in memory until the segments before it are written.
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
    keyframe_interval: usize,
    /// Writes a hold's repeated frames itself, and renumbers the encoder's frames around them.
    repeats: RepeatWriter,
    encoded: Vec<u8>,
    annexb: Vec<u8>,
    sink: FrameSink,
    /// Decodes every frame right after encoding it and compares, when asked for.
    checker: Option<Checker>,
}

/// Running comparison of decoded frames with the frames that were encoded.
pub struct Checker {
    decoder: openh264::decoder::Decoder,
    decoded: Vec<u8>,
    /// Frames decoded so far.
    pub frames_decoded: usize,
    /// The lowest PSNR of a decoded frame against its render, dB.
    pub min_psnr_db: f64,
    /// Channel values off by more than 48, over all frames.
    pub outlier_values: usize,
}

impl SegmentEncoder {
    /// An encoder of the segment starting at `first_frame`, writing to `sink`, checking by
    /// decoding when `check`.
    pub fn new(
        settings: &VideoSettings,
        first_frame: usize,
        sink: FrameSink,
        check: bool,
    ) -> Result<SegmentEncoder, VideoError> {
        let encoder =
            Encoder::with_api_config(OpenH264API::from_source(), encoder_config(settings))
                .map_err(|e| VideoError::CodecStart {
                    what: "encoder",
                    detail: e.to_string(),
                })?;
        let checker = if check {
            Some(Checker {
                decoder: openh264::decoder::Decoder::new().map_err(|e| VideoError::CodecStart {
                    what: "decoder",
                    detail: e.to_string(),
                })?,
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
            keyframe_interval: settings.keyframe_interval as usize,
            repeats: RepeatWriter::new(),
            encoded: Vec::new(),
            annexb: Vec::new(),
            sink,
            checker,
        })
    }

    /// Appends one RGB frame.
    pub fn push(&mut self, rgb: &[u8]) -> Result<(), VideoError> {
        assert_eq!(rgb.len(), self.width * self.height * 3);
        self.yuv
            .read_rgb8(RgbSliceU8::new(rgb, (self.width, self.height)));
        self.encode_current(rgb)
    }

    /// Appends a frame that is the same picture as the last one pushed (`rgb`, kept for the
    /// decode check). 3 of every 4 frames of a stimulus repeat a hold; unless the frame is
    /// due to be a keyframe, it is written as a unit that copies the previous picture
    /// (`h264_repeat`), without the encoder.
    pub fn push_repeat(&mut self, rgb: &[u8]) -> Result<(), VideoError> {
        if self.frames == 0 {
            return self.push(rgb);
        }
        if self.keyframe_due() {
            // The YUV buffer still holds this picture.
            return self.encode_current(rgb);
        }
        let at = self.first_frame + self.frames;
        self.annexb.clear();
        self.repeats
            .repeat(&mut self.annexb)
            .map_err(|error| VideoError::Stream { frame: at, error })?;
        self.emit(rgb, false)
    }

    /// Whether the next frame is one of the video's keyframes (every `keyframe_interval`
    /// frames from the first; only the first when the interval is 0).
    fn keyframe_due(&self) -> bool {
        let at = self.first_frame + self.frames;
        match self.keyframe_interval {
            0 => at == 0,
            k => at.is_multiple_of(k),
        }
    }

    fn encode_current(&mut self, rgb: &[u8]) -> Result<(), VideoError> {
        let at = self.first_frame + self.frames;
        if self.frames > 0 && self.keyframe_due() {
            self.encoder.force_intra_frame();
        }
        let bitstream = self
            .encoder
            .encode(&self.yuv)
            .map_err(|e| VideoError::Encode {
                frame: at,
                detail: e.to_string(),
            })?;
        let key = matches!(bitstream.frame_type(), FrameType::IDR | FrameType::I);
        if self.frames == 0 && !key {
            return Err(VideoError::NotKeyframe(at));
        }
        self.encoded.clear();
        bitstream.write_vec(&mut self.encoded);
        if self.encoded.is_empty() {
            return Err(VideoError::Skipped(at));
        }
        self.annexb.clear();
        self.repeats
            .renumber(&self.encoded, &mut self.annexb)
            .map_err(|error| VideoError::Stream { frame: at, error })?;
        self.emit(rgb, key)
    }

    /// Checks (when asked) and stores the access unit in `annexb` as the next frame.
    fn emit(&mut self, rgb: &[u8], key: bool) -> Result<(), VideoError> {
        let at = self.first_frame + self.frames;
        if let Some(ch) = self.checker.as_mut() {
            for nal in openh264::nal_units(&self.annexb) {
                let out = ch.decoder.decode(nal).map_err(|e| VideoError::DecodeBack {
                    frame: at,
                    detail: e.to_string(),
                })?;
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

/// The encoder's configuration for a stimulus.
fn encoder_config(settings: &VideoSettings) -> EncoderConfig {
    EncoderConfig::new()
        .bitrate(BitRate::from_bps(settings.bitrate_bps))
        .max_frame_rate(FrameRate::from_hz(settings.fps as f32))
        .rate_control_mode(RateControlMode::Bitrate)
        .usage_type(UsageType::CameraVideoRealTime)
        .profile(Profile::High)
        .level(Level::Level_4_0)
        .skip_frames(false)
        // Keyframes are placed by `SegmentEncoder`, counted in the video's frames: the encoder
        // does not see the repeated frames, so its own count would drift.
        .intra_frame_period(IntraFramePeriod::from_num_frames(0))
        // On by default, it leaves isolated bright or dark pixels in P-frames: unacceptable
        // in an eye-tracking stimulus (measured in shared/docs/rust-ecosystem.md §3).
        .background_detection(false)
        // One thread per encoder, whatever the machine (a single slice gives its threads
        // nothing to share; the same bytes as openh264's automatic setting): the
        // segments are the parallelism.
        .num_threads(1)
        .vui(VuiConfig::bt709())
}

/// Writes bytes to a file, flushing.
pub fn write_all(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = BufWriter::new(std::fs::File::create(path)?);
    f.write_all(bytes)?;
    f.flush()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A test picture that changes with `t`: gradients and a moving block, so that the
    /// encoder has real motion and residual to code.
    fn picture(w: usize, h: usize, t: usize) -> Vec<u8> {
        let mut rgb = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let i = (y * w + x) * 3;
                let inside = (x + 4 * t) % w < 24 && (y + 2 * t) % h < 20;
                rgb[i] = (x * 255 / w) as u8;
                rgb[i + 1] = if inside { 230 } else { (y * 255 / h) as u8 };
                rgb[i + 2] = ((x * y + 40 * t) % 256) as u8;
            }
        }
        rgb
    }

    /// Decodes an access unit; the picture as RGB.
    fn decode(
        decoder: &mut openh264::decoder::Decoder,
        annexb: &[u8],
        w: usize,
        h: usize,
    ) -> Vec<u8> {
        let mut rgb = vec![0u8; w * h * 3];
        let mut pictures = 0;
        for nal in openh264::nal_units(annexb) {
            if let Some(yuv) = decoder.decode(nal).expect("decodes") {
                yuv.write_rgb8(&mut rgb);
                pictures += 1;
            }
        }
        assert_eq!(pictures, 1, "one access unit, one picture");
        rgb
    }

    #[test]
    fn repeated_frames_decode_as_copies_and_leave_the_encoders_frames_unchanged() {
        let (w, h) = (96, 64);
        let settings = VideoSettings {
            width: w,
            height: h,
            fps: 30,
            bitrate_bps: 400_000,
            keyframe_interval: 9,
        };
        // The encoder sees pictures 0..5; after picture 1 and 3 the video holds for a while
        // (one hold runs across frame 9, which must then be a keyframe the encoder makes).
        let shows: Vec<(usize, bool)> = [
            (0, true),
            (1, true),
            (1, false),
            (1, false),
            (2, true),
            (3, true),
            (3, false),
            (3, false),
            (3, false),
            (3, false),
            (3, false),
            (4, true),
            (5, true),
        ]
        .to_vec();
        let mut repeated = SegmentEncoder::new(&settings, 0, FrameSink::Memory(Vec::new()), true)
            .expect("encoder starts");
        for &(t, distinct) in &shows {
            let rgb = picture(w, h, t);
            if distinct {
                repeated.push(&rgb).unwrap();
            } else {
                repeated.push_repeat(&rgb).unwrap();
            }
        }
        let (FrameSink::Memory(frames), Some(checker)) = repeated.finish() else {
            panic!("frames kept in memory, with the check")
        };
        assert_eq!(frames.len(), shows.len());
        assert_eq!(checker.frames_decoded, shows.len());
        let keys: Vec<usize> = (0..frames.len()).filter(|&i| frames[i].key).collect();
        assert_eq!(keys, vec![0, 9], "keyframes counted in the video's frames");

        // The same pictures through openh264 alone, one frame each, with the keyframe of
        // frame 9 (a repeat of picture 3) forced at the same place in its own count.
        let mut plain =
            Encoder::with_api_config(OpenH264API::from_source(), encoder_config(&settings))
                .unwrap();
        let mut plain_decoder = openh264::decoder::Decoder::new().unwrap();
        let mut plain_pictures = Vec::new();
        for (i, &(t, distinct)) in shows.iter().enumerate() {
            if !distinct && i != 9 {
                continue;
            }
            if i == 9 {
                plain.force_intra_frame();
            }
            let mut yuv = YUVBuffer::new(w, h);
            yuv.read_rgb8(RgbSliceU8::new(&picture(w, h, t), (w, h)));
            let mut annexb = Vec::new();
            plain.encode(&yuv).unwrap().write_vec(&mut annexb);
            plain_pictures.push(decode(&mut plain_decoder, &annexb, w, h));
        }

        let mut decoder = openh264::decoder::Decoder::new().unwrap();
        let mut previous: Option<Vec<u8>> = None;
        let mut encoded = plain_pictures.iter();
        for (i, (frame, &(_, distinct))) in frames.iter().zip(&shows).enumerate() {
            let got = decode(&mut decoder, &frame.annexb, w, h);
            if distinct || i == 9 {
                assert_eq!(
                    &got,
                    encoded.next().unwrap(),
                    "frame {i}: the encoder's picture"
                );
            } else {
                assert!(
                    frame.annexb.len() < 40,
                    "frame {i}: a repeat is a few bytes"
                );
                assert_eq!(Some(&got), previous.as_ref(), "frame {i}: an exact copy");
            }
            previous = Some(got);
        }
        assert!(encoded.next().is_none());
    }
}

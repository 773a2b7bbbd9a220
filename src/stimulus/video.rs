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

pub struct Mp4Writer {
    encoder: Encoder,
    muxer: muxide::api::Muxer<BufWriter<std::fs::File>>,
    yuv: YUVBuffer,
    width: usize,
    height: usize,
    fps: f64,
    frames: usize,
    annexb: Vec<u8>,
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

impl Mp4Writer {
    pub fn create(
        path: &Path,
        width: usize,
        height: usize,
        fps: u32,
        bitrate_bps: u32,
        keyframe_interval: u32,
    ) -> Result<Mp4Writer, String> {
        let config = EncoderConfig::new()
            .bitrate(BitRate::from_bps(bitrate_bps))
            .max_frame_rate(FrameRate::from_hz(fps as f32))
            .rate_control_mode(RateControlMode::Bitrate)
            .usage_type(UsageType::CameraVideoRealTime)
            .profile(Profile::High)
            .level(Level::Level_4_0)
            .skip_frames(false)
            .intra_frame_period(IntraFramePeriod::from_num_frames(keyframe_interval))
            // On by default, it leaves isolated bright or dark pixels in P-frames: unacceptable
            // in an eye-tracking stimulus (measured in shared/docs/rust-ecosystem.md §3).
            .background_detection(false)
            .vui(VuiConfig::bt709());
        let encoder = Encoder::with_api_config(OpenH264API::from_source(), config)
            .map_err(|e| format!("cannot start the H.264 encoder: {e}"))?;
        let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
        let muxer = muxide::api::MuxerBuilder::new(BufWriter::new(file))
            .video(
                muxide::api::VideoCodec::H264,
                width as u32,
                height as u32,
                fps as f64,
            )
            .with_fast_start(true)
            .build()
            .map_err(|e| format!("{}: cannot start the MP4 muxer: {e:?}", path.display()))?;
        Ok(Mp4Writer {
            encoder,
            muxer,
            yuv: YUVBuffer::new(width, height),
            width,
            height,
            fps: fps as f64,
            frames: 0,
            annexb: Vec::new(),
            checker: None,
        })
    }

    /// Decode each frame back as it is written and compare it with the input.
    pub fn check_by_decoding(&mut self) -> Result<(), String> {
        self.checker = Some(Checker {
            decoder: openh264::decoder::Decoder::new().map_err(|e| e.to_string())?,
            decoded: vec![0; self.width * self.height * 3],
            frames_decoded: 0,
            min_psnr_db: f64::INFINITY,
            outlier_values: 0,
        });
        Ok(())
    }

    /// Appends one RGB frame; it is shown at frame_index / fps seconds.
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
        let bitstream = self
            .encoder
            .encode(&self.yuv)
            .map_err(|e| format!("H.264 encoding failed at frame {}: {e}", self.frames))?;
        let key = matches!(bitstream.frame_type(), FrameType::IDR | FrameType::I);
        self.annexb.clear();
        bitstream.write_vec(&mut self.annexb);
        if self.annexb.is_empty() {
            return Err(format!("the encoder skipped frame {}", self.frames));
        }
        if let Some(ch) = self.checker.as_mut() {
            for nal in openh264::nal_units(&self.annexb) {
                let out = ch
                    .decoder
                    .decode(nal)
                    .map_err(|e| format!("decoding back frame {}: {e}", self.frames))?;
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
        self.muxer
            .write_video(self.frames as f64 / self.fps, &self.annexb, key)
            .map_err(|e| format!("MP4 muxing failed at frame {}: {e:?}", self.frames))?;
        self.frames += 1;
        Ok(())
    }

    /// Writes the MP4 index; returns the frame count and the decode check if one ran.
    pub fn finish(mut self) -> Result<(usize, Option<Checker>), String> {
        self.muxer
            .finish_in_place()
            .map_err(|e| format!("cannot finish the MP4: {e:?}"))?;
        Ok((self.frames, self.checker))
    }
}

/// Writes bytes to a file, flushing.
pub fn write_all(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut f = BufWriter::new(std::fs::File::create(path)?);
    f.write_all(bytes)?;
    f.flush()
}

//! The video writer's errors: the encoder, the MP4 muxer, the hold repeats and the frame
//! images, each naming the frame or file it happened at.
use std::path::PathBuf;

/// The H.264 stream the encoder wrote is not one the hold repeats can extend (a feature they
/// do not write, or a header cut short). The stream is the encoder's own output, never user
/// data: this is a refusal to write a video that might not play, not a malformed input.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct H264StreamError(pub String);

impl From<&str> for H264StreamError {
    fn from(message: &str) -> Self {
        H264StreamError(message.to_string())
    }
}

impl From<String> for H264StreamError {
    fn from(message: String) -> Self {
        H264StreamError(message)
    }
}

/// Why a stimulus video (or one of its frame images) could not be written.
#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    /// The MP4 file could not be created.
    #[error("{}: {error}", path.display())]
    Create {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        error: std::io::Error,
    },
    /// The MP4 muxer could not start.
    #[error("{}: cannot start the MP4 muxer: {detail}", path.display())]
    MuxerStart {
        /// The file.
        path: PathBuf,
        /// The muxer's message.
        detail: String,
    },
    /// The muxer refused a frame.
    #[error("MP4 muxing failed at frame {frame}: {detail}")]
    Mux {
        /// The frame's index in the video.
        frame: usize,
        /// The muxer's message.
        detail: String,
    },
    /// The MP4 index could not be written.
    #[error("cannot finish the MP4: {0}")]
    MuxFinish(String),
    /// The H.264 encoder (or, for the decode check, the decoder) could not start.
    #[error("cannot start the H.264 {what}: {detail}")]
    CodecStart {
        /// `encoder` or `decoder`.
        what: &'static str,
        /// The codec's message.
        detail: String,
    },
    /// The encoder failed on a frame.
    #[error("H.264 encoding failed at frame {frame}: {detail}")]
    Encode {
        /// The frame's index in the video.
        frame: usize,
        /// The encoder's message.
        detail: String,
    },
    /// A segment's first frame did not come out as a keyframe.
    #[error("frame {0} starts an encoder but is not a keyframe")]
    NotKeyframe(usize),
    /// The encoder wrote nothing for a frame.
    #[error("the encoder skipped frame {0}")]
    Skipped(usize),
    /// The hold repeats could not extend the encoder's stream at a frame.
    #[error("frame {frame}: {error}")]
    Stream {
        /// The frame's index in the video.
        frame: usize,
        /// Why.
        error: H264StreamError,
    },
    /// The decode check could not decode a frame back.
    #[error("decoding back frame {frame}: {detail}")]
    DecodeBack {
        /// The frame's index in the video.
        frame: usize,
        /// The decoder's message.
        detail: String,
    },
    /// A frame image (PNG) could not be written.
    #[error("{}: {detail}", path.display())]
    Image {
        /// The file.
        path: PathBuf,
        /// The image encoder's message.
        detail: String,
    },
    /// A rendering or encoding thread panicked, or segments came back out of order (a bug).
    #[error("{0}")]
    Thread(&'static str),
}

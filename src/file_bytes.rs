//! Reading input files whole, gzip or not (detected by the magic bytes, not the name), and
//! the one rule that names a file by its stem.
use std::io::Read;
use std::path::Path;

/// Why a file could not be read: the I/O error, or corrupt gzip data.
#[derive(Debug)]
pub enum ReadError {
    /// The file could not be read.
    Io(std::io::Error),
    /// A `.gz` file's data is not valid gzip.
    CorruptGzip(std::io::Error),
}

/// The file's bytes, decompressed when they start with the gzip magic number.
pub fn read_maybe_gzipped(path: &Path) -> Result<Vec<u8>, ReadError> {
    let raw = std::fs::read(path).map_err(ReadError::Io)?;
    if !raw.starts_with(&[0x1f, 0x8b]) {
        return Ok(raw);
    }
    let mut out = Vec::new();
    flate2::read::MultiGzDecoder::new(&raw[..])
        .read_to_end(&mut out)
        .map_err(ReadError::CorruptGzip)?;
    Ok(out)
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Io(e) => write!(f, "{e}"),
            ReadError::CorruptGzip(e) => write!(f, "corrupt gzip data: {e}"),
        }
    }
}

/// Creates an output folder and its parents, naming it in the error.
pub fn create_output_dir(dir: &Path) -> Result<(), std::io::Error> {
    std::fs::create_dir_all(dir).map_err(|e| {
        std::io::Error::new(
            e.kind(),
            format!("cannot create output folder {}: {e}", dir.display()),
        )
    })
}

/// The stem of a file name: up to the first dot (`bunny.sms.csv` -> `bunny`), so a mesh and
/// the maps written beside it share one name.
pub fn stem_of(path: &Path) -> String {
    let file = path.file_name().unwrap_or_default().to_string_lossy();
    file.split('.').next().unwrap_or("").to_string()
}

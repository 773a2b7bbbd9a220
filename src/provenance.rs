//! Provenance: what produced an output, from what, with which parameters, so any file can be
//! traced and re-made.
use std::io::Read;
use std::path::Path;

use serde::Serialize;
use sha2::{Digest, Sha256};

/// One input of an output: its path, SHA-256 and size.
#[derive(Debug, Clone, Serialize)]
pub struct InputFile {
    /// The path as given (or the name of a built-in input).
    pub path: String,
    /// SHA-256 of its bytes, lowercase hex.
    pub sha256: String,
    /// Its size in bytes.
    pub bytes: u64,
}

impl InputFile {
    /// Provenance of an input held in memory (a built-in file), named `name`.
    pub fn of_bytes(name: &str, bytes: &[u8]) -> InputFile {
        InputFile {
            path: name.to_string(),
            sha256: crate::provenance::sha256_hex(bytes),
            bytes: bytes.len() as u64,
        }
    }

    /// The file at `path`, hashed as it is read.
    pub fn hash(path: &Path) -> std::io::Result<InputFile> {
        let mut file = std::fs::File::open(path)?;
        let mut hasher = Sha256::new();
        let mut buf = vec![0u8; 1 << 16];
        let mut bytes = 0u64;
        loop {
            let k = file.read(&mut buf)?;
            if k == 0 {
                break;
            }
            bytes += k as u64;
            hasher.update(&buf[..k]);
        }
        Ok(InputFile {
            path: path.display().to_string(),
            sha256: hex(&hasher.finalize()),
            bytes,
        })
    }
}

/// SHA-256 of `data`, lowercase hex.
pub fn sha256_hex(data: &[u8]) -> String {
    hex(&Sha256::digest(data))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The header every JSON sidecar starts with.
#[derive(Debug, Clone, Serialize)]
pub struct Provenance {
    /// `meshgaze`.
    pub tool: &'static str,
    /// The crate version that wrote the output.
    pub version: &'static str,
    /// The command line as given.
    pub command: Vec<String>,
    /// Every input file with its hash.
    pub inputs: Vec<InputFile>,
}

impl Provenance {
    /// This process's provenance over `inputs`.
    pub fn new(inputs: Vec<InputFile>) -> Provenance {
        Provenance {
            tool: env!("CARGO_PKG_NAME"),
            version: env!("CARGO_PKG_VERSION"),
            command: std::env::args().collect(),
            inputs,
        }
    }
}

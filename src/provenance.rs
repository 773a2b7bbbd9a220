//! Provenance: what produced an output, from what, with which parameters, so any file can be
//! traced and re-made.
use std::io::Read;
use std::path::Path;

use serde::Serialize;
use sha2::{Digest, Sha256};

#[derive(Debug, Clone, Serialize)]
pub struct InputFile {
    pub path: String,
    pub sha256: String,
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

pub fn sha256_hex(data: &[u8]) -> String {
    hex(&Sha256::digest(data))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The header every JSON sidecar starts with.
#[derive(Debug, Clone, Serialize)]
pub struct Provenance {
    pub tool: &'static str,
    pub version: &'static str,
    /// The command line as given.
    pub command: Vec<String>,
    pub inputs: Vec<InputFile>,
}

impl Provenance {
    pub fn new(inputs: Vec<InputFile>) -> Provenance {
        Provenance {
            tool: env!("CARGO_PKG_NAME"),
            version: env!("CARGO_PKG_VERSION"),
            command: std::env::args().collect(),
            inputs,
        }
    }
}

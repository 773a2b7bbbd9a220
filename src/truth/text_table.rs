//! The delimited text of truth files: decoding, the separator, fields with their columns, and
//! the table being read (its path, separator and header) that every error names.
use std::path::Path;

use super::TruthError;
use crate::file_bytes::{read_maybe_gzipped, ReadError};

pub(super) fn read_text(path: &Path) -> Result<String, TruthError> {
    let bytes = read_maybe_gzipped(path).map_err(|e| match e {
        ReadError::Io(source) => TruthError::Io {
            path: path.to_path_buf(),
            error: source,
        },
        ReadError::CorruptGzip(e) => TruthError::File {
            path: path.to_path_buf(),
            message: format!("gzip data is corrupt: {e}"),
        },
    })?;
    let text = String::from_utf8(bytes).map_err(|e| TruthError::File {
        path: path.to_path_buf(),
        message: format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
    })?;
    Ok(text.strip_prefix('\u{feff}').unwrap_or(&text).to_string())
}

/// The file's field separator, from its first line: a comma, tab or semicolon splits strictly
/// (empty fields stay in place, so an empty `vertex` of a background fixation does not shift
/// the columns); otherwise runs of spaces separate.
pub(super) fn sniff_separator(first_line: &str) -> Option<char> {
    [',', '\t', ';']
        .into_iter()
        .find(|&c| first_line.contains(c))
}

pub(super) fn fields(line: &str, sep: Option<char>) -> Vec<(usize, &str)> {
    // Columns are 1-based character offsets.
    let mut out = Vec::new();
    match sep {
        Some(sep) => {
            let mut start = 0;
            for (i, c) in line.char_indices() {
                if c == sep {
                    out.push((start + 1, line[start..i].trim()));
                    start = i + c.len_utf8();
                }
            }
            out.push((start + 1, line[start..].trim()));
        }
        None => {
            let mut start = None;
            for (i, c) in line.char_indices() {
                match (c.is_whitespace(), start) {
                    (true, Some(s)) => {
                        out.push((s + 1, &line[s..i]));
                        start = None;
                    }
                    (false, None) => start = Some(i),
                    _ => {}
                }
            }
            if let Some(s) = start {
                out.push((s + 1, line[s..].trim_end()));
            }
        }
    }
    out
}

/// A delimited text file being read: its path (for messages), separator and header.
pub(super) struct Table<'a> {
    pub(super) path: &'a Path,
    pub(super) sep: Option<char>,
    /// 0-based line of the first non-empty line.
    pub(super) header_line: usize,
    /// Lower-cased header names, when the first line is a header.
    pub(super) header: Option<&'a [String]>,
}

impl Table<'_> {
    pub(super) fn at(&self, line: usize, column: usize, message: String) -> TruthError {
        TruthError::At {
            path: self.path.to_path_buf(),
            line,
            column,
            message,
        }
    }

    pub(super) fn col(&self, name: &str) -> Option<usize> {
        self.header?.iter().position(|h| h == name)
    }
}

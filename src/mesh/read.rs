use std::path::Path;

use super::{obj, off, ply, LoadReport, Mesh, MeshError};
use crate::file_bytes::{read_maybe_gzipped, ReadError};

/// The mesh file formats meshgaze reads. Any of them may be gzip-compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    /// Wavefront OBJ.
    Obj,
    /// Stanford PLY (ASCII or binary).
    Ply,
    /// Object File Format.
    Off,
}

impl MeshFormat {
    /// From the file name, ignoring a trailing `.gz`.
    pub fn from_path(path: &Path) -> Option<MeshFormat> {
        let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
        let name = name.strip_suffix(".gz").unwrap_or(&name);
        let ext = name.rsplit_once('.')?.1;
        match ext {
            "obj" => Some(MeshFormat::Obj),
            "ply" => Some(MeshFormat::Ply),
            "off" => Some(MeshFormat::Off),
            _ => None,
        }
    }

    /// From the first bytes, for files whose name says nothing.
    fn sniff(bytes: &[u8]) -> Option<MeshFormat> {
        let head = &bytes[..bytes.len().min(64)];
        let trimmed: Vec<u8> = head
            .iter()
            .copied()
            .skip_while(|b| b.is_ascii_whitespace())
            .collect();
        if trimmed.starts_with(b"ply") {
            Some(MeshFormat::Ply)
        } else if trimmed.starts_with(b"OFF")
            || trimmed.starts_with(b"COFF")
            || trimmed.starts_with(b"NOFF")
        {
            Some(MeshFormat::Off)
        } else if trimmed.starts_with(b"v ") || trimmed.starts_with(b"# ") {
            Some(MeshFormat::Obj)
        } else {
            None
        }
    }

    /// `obj`, `ply` or `off`.
    pub fn name(self) -> &'static str {
        match self {
            MeshFormat::Obj => "obj",
            MeshFormat::Ply => "ply",
            MeshFormat::Off => "off",
        }
    }
}

/// Reads an OBJ, PLY or OFF mesh (optionally gzip-compressed, detected by content).
pub fn load_mesh(path: &Path) -> Result<(Mesh, LoadReport), MeshError> {
    let bytes = read_maybe_gzipped(path).map_err(|e| match e {
        ReadError::Io(source) => MeshError::Io {
            path: path.to_path_buf(),
            error: source,
        },
        ReadError::CorruptGzip(e) => MeshError::invalid(path, format!("gzip data is corrupt: {e}")),
    })?;
    let format = MeshFormat::from_path(path)
        .or_else(|| MeshFormat::sniff(&bytes))
        .ok_or_else(|| {
            MeshError::invalid(
                path,
                "unknown mesh format: expected a .obj, .ply or .off file (optionally .gz)",
            )
        })?;
    parse_mesh_bytes(&bytes, path, format)
}

/// Parses mesh bytes already in memory; `path` is used only in messages.
///
/// ```
/// use meshgaze::mesh::{parse_mesh_bytes, MeshFormat};
/// let off = b"OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 2\n";
/// let (mesh, report) = parse_mesh_bytes(off, "square.off".as_ref(), MeshFormat::Off).unwrap();
/// assert_eq!(mesh.positions.len(), 4);     // every vertex kept, in file order
/// assert_eq!(mesh.triangles.len(), 1);     // the face with a repeated corner is skipped...
/// assert_eq!(report.faces_with_repeated_vertex, 1); // ...and counted
/// assert_eq!(report.unreferenced_vertices, 1);
///
/// let err = parse_mesh_bytes(b"v 0 0 0\nv 1 x 0\n", "bad.obj".as_ref(), MeshFormat::Obj).unwrap_err();
/// assert_eq!(err.to_string(), "bad.obj:2:5: expected a number for the y coordinate of vertex 2, found `x`");
/// ```
pub fn parse_mesh_bytes(
    bytes: &[u8],
    path: &Path,
    format: MeshFormat,
) -> Result<(Mesh, LoadReport), MeshError> {
    let mut report = LoadReport {
        format: format.name().to_string(),
        ..Default::default()
    };
    let (positions, faces) = match format {
        MeshFormat::Obj => obj::parse(bytes, path, &mut report)?,
        MeshFormat::Ply => ply::parse(bytes, path, &mut report)?,
        MeshFormat::Off => off::parse(bytes, path, &mut report)?,
    };
    if positions.is_empty() {
        return Err(MeshError::invalid(path, "the file holds no vertices"));
    }
    let mesh = Mesh::from_raw_faces(positions, faces, &mut report);
    if mesh.triangles.is_empty() {
        return Err(MeshError::invalid(
            path,
            format!(
                "no usable triangle: {} faces in the file, {} with a repeated vertex, {} of zero area",
                report.faces_in_file, report.faces_with_repeated_vertex, report.zero_area_faces
            ),
        ));
    }
    Ok((mesh, report))
}

/// Splits a polygon into a triangle fan and checks indices; shared by all readers.
pub(crate) fn push_polygon(corners: &[u32], faces: &mut Vec<[u32; 3]>, report: &mut LoadReport) {
    report.faces_in_file += 1;
    if corners.len() > 3 {
        report.polygons_triangulated += 1;
    }
    for k in 1..corners.len().saturating_sub(1) {
        faces.push([corners[0], corners[k], corners[k + 1]]);
    }
}

/// Whitespace-separated tokens of a text file with their 1-based line and column.
pub(crate) struct Tokens<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
    line_start: usize,
    comment: Option<u8>,
}

#[derive(Debug, Clone, Copy)]
pub(crate) struct Token<'a> {
    pub text: &'a [u8],
    pub line: usize,
    pub column: usize,
}

impl<'a> Token<'a> {
    pub fn as_str(&self) -> String {
        String::from_utf8_lossy(self.text).into_owned()
    }
}

impl<'a> Tokens<'a> {
    pub fn new(data: &'a [u8], comment: Option<u8>) -> Self {
        Tokens {
            data,
            pos: 0,
            line: 1,
            line_start: 0,
            comment,
        }
    }

    /// Bytes not read yet: an upper bound on how many values can still follow.
    pub fn remaining(&self) -> usize {
        self.data.len() - self.pos
    }

    pub fn starting_at_line(mut self, line: usize) -> Self {
        self.line = line;
        self
    }

    pub fn line(&self) -> usize {
        self.line
    }

    pub fn column(&self) -> usize {
        self.pos - self.line_start + 1
    }

    /// Skips blanks; with `cross_lines` also newlines and comments.
    fn skip_blank(&mut self, cross_lines: bool) {
        while self.pos < self.data.len() {
            let b = self.data[self.pos];
            if b == b'\n' {
                if !cross_lines {
                    return;
                }
                self.pos += 1;
                self.line += 1;
                self.line_start = self.pos;
            } else if b == b' ' || b == b'\t' || b == b'\r' || b == 0x0c {
                self.pos += 1;
            } else if Some(b) == self.comment {
                while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
                    self.pos += 1;
                }
            } else {
                return;
            }
        }
    }

    fn take(&mut self) -> Option<Token<'a>> {
        if self.pos >= self.data.len() || self.data[self.pos] == b'\n' {
            return None;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        Some(Token {
            text: &self.data[start..self.pos],
            line: self.line,
            column: start - self.line_start + 1,
        })
    }

    /// The next token anywhere in the file.
    pub fn next_any(&mut self) -> Option<Token<'a>> {
        self.skip_blank(true);
        self.take()
    }

    /// The next token on the current line, `None` at its end.
    pub fn next_on_line(&mut self) -> Option<Token<'a>> {
        self.skip_blank(false);
        self.take()
    }

    /// Moves to the start of the next line.
    pub fn next_line(&mut self) {
        while self.pos < self.data.len() && self.data[self.pos] != b'\n' {
            self.pos += 1;
        }
        if self.pos < self.data.len() {
            self.pos += 1;
            self.line += 1;
            self.line_start = self.pos;
        }
    }

    pub fn at_end(&mut self) -> bool {
        self.skip_blank(true);
        self.pos >= self.data.len()
    }
}

pub(crate) fn parse_f64(tok: &Token, path: &Path, what: &str) -> Result<f64, MeshError> {
    let s = std::str::from_utf8(tok.text).ok();
    let v = s.and_then(|s| s.parse::<f64>().ok()).ok_or_else(|| {
        MeshError::text(
            path,
            tok.line,
            tok.column,
            format!("expected a number for {what}, found `{}`", tok.as_str()),
        )
    })?;
    if !v.is_finite() {
        return Err(MeshError::text(
            path,
            tok.line,
            tok.column,
            format!("{what} is not finite (`{}`)", tok.as_str()),
        ));
    }
    Ok(v)
}

pub(crate) fn parse_i64(tok: &Token, path: &Path, what: &str) -> Result<i64, MeshError> {
    std::str::from_utf8(tok.text)
        .ok()
        .and_then(|s| s.parse::<i64>().ok())
        .ok_or_else(|| {
            MeshError::text(
                path,
                tok.line,
                tok.column,
                format!("expected an integer for {what}, found `{}`", tok.as_str()),
            )
        })
}

/// Checks a 0-based vertex index against the vertex count.
pub(crate) fn check_index(
    idx: i64,
    n_vertices: usize,
    tok: &Token,
    path: &Path,
) -> Result<u32, MeshError> {
    if idx < 0 || idx as usize >= n_vertices {
        return Err(MeshError::text(
            path,
            tok.line,
            tok.column,
            format!(
                "vertex index `{}` is out of range: the file has {n_vertices} vertices",
                tok.as_str()
            ),
        ));
    }
    Ok(idx as u32)
}

//! PLY in all three encodings (ascii, binary little and big endian). Any vertex properties
//! besides x, y, z are skipped; `face` lists are triangulated as fans; `tristrips` lists
//! (triangle strips separated by -1, as in Cyberware's igea.ply) are expanded; unknown
//! elements are read past so their bytes cannot shift what follows.
use std::path::Path;

use glam::DVec3;

use super::read::{push_polygon, Token, Tokens};
use super::{LoadReport, MeshError};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }
    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar {
        name: String,
        ty: Scalar,
    },
    List {
        name: String,
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    BinaryLittle,
    BinaryBig,
}

struct Header {
    encoding: Encoding,
    elements: Vec<Element>,
    body_start: usize,
    body_line: usize,
}

/// One header line after the first, split into words, for parsing and for messages.
struct HeaderLine<'a> {
    path: &'a Path,
    line_no: usize,
    line: &'a str,
    words: Vec<&'a str>,
}

impl HeaderLine<'_> {
    fn err(&self, col: usize, msg: String) -> MeshError {
        MeshError::text(self.path, self.line_no, col, msg)
    }

    /// 1-based column of the k-th word, for messages.
    fn col_of(&self, k: usize) -> usize {
        let mut seen = 0;
        let mut in_word = false;
        for (i, c) in self.line.char_indices() {
            if !c.is_whitespace() && !in_word {
                if seen == k {
                    return i + 1;
                }
                seen += 1;
            }
            in_word = !c.is_whitespace();
        }
        self.line.len() + 1
    }

    /// `format ascii|binary_little_endian|binary_big_endian 1.0`
    fn format(&self) -> Result<Encoding, MeshError> {
        match self.words.get(1).copied() {
            Some("ascii") => Ok(Encoding::Ascii),
            Some("binary_little_endian") => Ok(Encoding::BinaryLittle),
            Some("binary_big_endian") => Ok(Encoding::BinaryBig),
            other => Err(self.err(
                self.col_of(1),
                format!(
                    "unknown PLY format `{}`: expected ascii, binary_little_endian or binary_big_endian",
                    other.unwrap_or("")
                ),
            )),
        }
    }

    /// `element <name> <count>`
    fn element(&self) -> Result<Element, MeshError> {
        let words = &self.words;
        if words.len() != 3 {
            return Err(self.err(1, "expected `element <name> <count>`".into()));
        }
        let count: usize = words[2].parse().map_err(|_| {
            self.err(
                self.col_of(2),
                format!("element count `{}` is not a non-negative integer", words[2]),
            )
        })?;
        Ok(Element {
            name: words[1].to_string(),
            count,
            props: Vec::new(),
        })
    }

    fn scalar_type(&self, k: usize) -> Result<Scalar, MeshError> {
        let name = self.words.get(k).copied().unwrap_or("");
        Scalar::parse(name)
            .ok_or_else(|| self.err(self.col_of(k), format!("unknown property type `{name}`")))
    }

    /// `property <type> <name>` or `property list <count type> <item type> <name>`
    fn property(&self) -> Result<Property, MeshError> {
        let words = &self.words;
        if words.get(1) == Some(&"list") {
            if words.len() != 5 {
                return Err(self.err(
                    1,
                    "expected `property list <count type> <item type> <name>`".into(),
                ));
            }
            let count = self.scalar_type(2)?;
            if !count.is_integer() {
                return Err(self.err(
                    self.col_of(2),
                    "a list count must be an integer type".into(),
                ));
            }
            Ok(Property::List {
                name: words[4].to_string(),
                count,
                item: self.scalar_type(3)?,
            })
        } else {
            if words.len() != 3 {
                return Err(self.err(1, "expected `property <type> <name>`".into()));
            }
            Ok(Property::Scalar {
                name: words[2].to_string(),
                ty: self.scalar_type(1)?,
            })
        }
    }
}

fn parse_header(bytes: &[u8], path: &Path) -> Result<Header, MeshError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(MeshError::text(
                path,
                line_no.max(1),
                1,
                "the header has no `end_header` line",
            ));
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |k| pos + k);
        line_no += 1;
        let text = String::from_utf8_lossy(&bytes[pos..end]);
        let line = text.trim_end_matches('\r');
        pos = (end + 1).min(bytes.len());
        if line_no == 1 {
            if line.trim() != "ply" {
                return Err(MeshError::text(
                    path,
                    1,
                    1,
                    format!("expected `ply` as the first line, found `{line}`"),
                ));
            }
            continue;
        }
        let h = HeaderLine {
            path,
            line_no,
            line,
            words: line.split_whitespace().collect(),
        };
        match h.words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => encoding = Some(h.format()?),
            Some("element") => elements.push(h.element()?),
            Some("property") => {
                let element = elements.last_mut().ok_or_else(|| {
                    h.err(
                        1,
                        "a `property` line comes before any `element` line".into(),
                    )
                })?;
                element.props.push(h.property()?);
            }
            Some("end_header") => break,
            Some(other) => {
                return Err(h.err(1, format!("unexpected header keyword `{other}`")));
            }
        }
    }
    let encoding =
        encoding.ok_or_else(|| MeshError::text(path, 2, 1, "the header has no `format` line"))?;
    Ok(Header {
        encoding,
        elements,
        body_start: pos,
        body_line: line_no + 1,
    })
}

/// Where the values of the body come from: ascii tokens or binary bytes.
enum Body<'a> {
    Ascii(Tokens<'a>),
    Binary {
        data: &'a [u8],
        pos: usize,
        start: usize,
        big_endian: bool,
    },
}

impl<'a> Body<'a> {
    fn read(
        &mut self,
        ty: Scalar,
        path: &Path,
        what: &dyn Fn() -> String,
    ) -> Result<f64, MeshError> {
        match self {
            Body::Ascii(tokens) => {
                let tok: Token = tokens.next_any().ok_or_else(|| {
                    MeshError::text(
                        path,
                        tokens.line(),
                        tokens.column(),
                        format!("the file ends while reading {}", what()),
                    )
                })?;
                let s = std::str::from_utf8(tok.text).unwrap_or("");
                let v = if ty.is_integer() {
                    s.parse::<i64>().ok().map(|v| v as f64)
                } else {
                    s.parse::<f64>().ok()
                };
                v.ok_or_else(|| {
                    MeshError::text(
                        path,
                        tok.line,
                        tok.column,
                        format!(
                            "expected {} for {}, found `{}`",
                            if ty.is_integer() {
                                "an integer"
                            } else {
                                "a number"
                            },
                            what(),
                            tok.as_str()
                        ),
                    )
                })
            }
            Body::Binary {
                data,
                pos,
                start,
                big_endian,
            } => {
                let n = ty.size();
                if *pos + n > data.len() {
                    return Err(MeshError::Binary {
                        path: path.to_path_buf(),
                        offset: *start + *pos,
                        message: format!("the file ends while reading {}", what()),
                    });
                }
                let b = &data[*pos..*pos + n];
                *pos += n;
                let mut a = [0u8; 8];
                a[..n].copy_from_slice(b);
                if *big_endian {
                    a[..n].reverse();
                }
                Ok(match ty {
                    Scalar::I8 => a[0] as i8 as f64,
                    Scalar::U8 => a[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(a),
                })
            }
        }
    }

    /// An error at the current place in the body.
    fn error(&self, path: &Path, message: String) -> MeshError {
        match self {
            Body::Ascii(t) => MeshError::text(path, t.line(), t.column(), message),
            Body::Binary { pos, start, .. } => MeshError::Binary {
                path: path.to_path_buf(),
                offset: start + pos,
                message,
            },
        }
    }

    /// Bytes left: every value takes at least one, so counts above this are impossible
    /// (checked before allocating, so a forged header cannot exhaust memory).
    fn remaining(&self) -> usize {
        match self {
            Body::Ascii(t) => t.remaining(),
            Body::Binary { data, pos, .. } => data.len() - pos,
        }
    }
}

/// Where the positions and the index list are among an element's properties:
/// (x, y, z) for `vertex`, the `vertex_indices` list for `face` and `tristrips`.
fn element_layout(
    element: &Element,
    path: &Path,
) -> Result<(Option<[usize; 3]>, Option<usize>), MeshError> {
    let name = element.name.as_str();
    let xyz = if name == "vertex" {
        let find = |axis: &str| {
            element
                .props
                .iter()
                .position(|p| matches!(p, Property::Scalar { name, .. } if name == axis))
                .ok_or_else(|| {
                    MeshError::invalid(path, format!("the vertex element has no `{axis}` property"))
                })
        };
        Some([find("x")?, find("y")?, find("z")?])
    } else {
        None
    };
    let index_list = if name == "face" || name == "tristrips" {
        let pos = element.props.iter().position(|p| {
            matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
        });
        Some(pos.ok_or_else(|| {
            MeshError::invalid(
                path,
                format!("the `{name}` element has no `vertex_indices` list"),
            )
        })?)
    } else {
        None
    };
    Ok((xyz, index_list))
}

/// Reads row `i` of `element`: scalars into `row` (NaN for each list), the items of list
/// property `index_list` into `list`.
fn read_row(
    body: &mut Body,
    element: &Element,
    index_list: Option<usize>,
    i: usize,
    path: &Path,
    row: &mut Vec<f64>,
    list: &mut Vec<f64>,
) -> Result<(), MeshError> {
    let name = element.name.as_str();
    row.clear();
    for (k, prop) in element.props.iter().enumerate() {
        match prop {
            Property::Scalar { name: pname, ty } => {
                let v = body.read(*ty, path, &|| format!("property `{pname}` of {name} {i}"))?;
                row.push(v);
            }
            Property::List {
                name: pname,
                count,
                item,
            } => {
                let c = body.read(*count, path, &|| {
                    format!("the length of list `{pname}` of {name} {i}")
                })?;
                if c < 0.0 || c as usize > body.remaining() {
                    return Err(body.error(
                        path,
                        format!("list `{pname}` of {name} {i} claims {c} items, more than the file holds"),
                    ));
                }
                let keep = index_list == Some(k);
                if keep {
                    list.clear();
                }
                for j in 0..c as usize {
                    let v = body.read(*item, path, &|| {
                        format!("item {j} of list `{pname}` of {name} {i}")
                    })?;
                    if keep {
                        list.push(v);
                    }
                }
                row.push(f64::NAN);
            }
        }
    }
    Ok(())
}

/// The triangles of row `i` of a `face` (a polygon, fanned) or `tristrips` element (strips
/// split at -1; every other triangle flips orientation), every index checked against the
/// `nv` vertices.
#[allow(clippy::too_many_arguments)]
fn push_index_list(
    name: &str,
    i: usize,
    list: &[f64],
    nv: usize,
    body: &Body,
    path: &Path,
    faces: &mut Vec<[u32; 3]>,
    report: &mut LoadReport,
) -> Result<(), MeshError> {
    let check = |v: f64| -> Result<u32, MeshError> {
        if v < 0.0 || v >= nv as f64 || v.fract() != 0.0 {
            Err(body.error(
                path,
                format!(
                    "{name} {i} uses vertex index {v}, out of range: the file has {nv} vertices"
                ),
            ))
        } else {
            Ok(v as u32)
        }
    };
    if name == "face" {
        if list.len() < 3 {
            return Err(body.error(
                path,
                format!(
                    "face {i} has {} corners; a face needs at least 3",
                    list.len()
                ),
            ));
        }
        let corners = list
            .iter()
            .map(|&v| check(v))
            .collect::<Result<Vec<u32>, _>>()?;
        push_polygon(&corners, faces, report);
        return Ok(());
    }
    for strip in list.split(|&v| v == -1.0) {
        let ids = strip
            .iter()
            .map(|&v| check(v))
            .collect::<Result<Vec<u32>, _>>()?;
        for j in 2..ids.len() {
            let tri = if j % 2 == 0 {
                [ids[j - 2], ids[j - 1], ids[j]]
            } else {
                [ids[j - 1], ids[j - 2], ids[j]]
            };
            report.faces_in_file += 1;
            faces.push(tri);
        }
    }
    Ok(())
}

fn body_of<'a>(bytes: &'a [u8], header: &Header) -> Body<'a> {
    let body_bytes = &bytes[header.body_start..];
    match header.encoding {
        Encoding::Ascii => {
            // Line numbers in messages count from the top of the file, header included.
            Body::Ascii(Tokens::new(body_bytes, None).starting_at_line(header.body_line))
        }
        e => Body::Binary {
            data: body_bytes,
            pos: 0,
            start: header.body_start,
            big_endian: e == Encoding::BinaryBig,
        },
    }
}

pub(crate) fn parse(
    bytes: &[u8],
    path: &Path,
    report: &mut LoadReport,
) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), MeshError> {
    let header = parse_header(bytes, path)?;
    let mut body = body_of(bytes, &header);
    report.format = format!(
        "ply-{}",
        match header.encoding {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLittle => "binary_little_endian",
            Encoding::BinaryBig => "binary_big_endian",
        }
    );
    if !header.elements.iter().any(|e| e.name == "vertex") {
        return Err(MeshError::invalid(
            path,
            "the header declares no `vertex` element",
        ));
    }
    let mut positions: Vec<DVec3> = Vec::new();
    let mut faces = Vec::new();
    let mut vertex_count: Option<usize> = None;
    let (mut row, mut list) = (Vec::new(), Vec::new());
    for element in &header.elements {
        let name = element.name.as_str();
        // A row is at least one byte per property: refuse counts the file cannot hold before
        // allocating for them.
        let min_row = element.props.len().max(1);
        if element.count.saturating_mul(min_row) > body.remaining() {
            return Err(body.error(
                path,
                format!(
                    "the header declares {} `{name}` elements but only {} bytes remain",
                    element.count,
                    body.remaining()
                ),
            ));
        }
        let (xyz, index_list) = element_layout(element, path)?;
        if xyz.is_some() {
            positions.reserve(element.count);
        }
        if index_list.is_some() && vertex_count.is_none() {
            return Err(MeshError::invalid(
                path,
                format!("the `{name}` element comes before the `vertex` element"),
            ));
        }
        for i in 0..element.count {
            read_row(&mut body, element, index_list, i, path, &mut row, &mut list)?;
            if let Some([x, y, z]) = xyz {
                let p = DVec3::new(row[x], row[y], row[z]);
                if !p.is_finite() {
                    return Err(body.error(
                        path,
                        format!(
                            "vertex {i} has a non-finite coordinate ({}, {}, {})",
                            p.x, p.y, p.z
                        ),
                    ));
                }
                positions.push(p);
            } else if index_list.is_some() {
                let nv = vertex_count.unwrap_or(0);
                push_index_list(name, i, &list, nv, &body, path, &mut faces, report)?;
            }
        }
        if name == "vertex" {
            vertex_count = Some(positions.len());
        }
    }
    Ok((positions, faces))
}

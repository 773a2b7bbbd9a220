//! Text-level helpers shared by the SMI readers: lines with numbers, fields with columns,
//! missing-value markers, lenient numbers.

/// The file as text, BOM stripped. Header text comes from Windows: invalid UTF-8 (cp1252
/// bytes) is decoded leniently to U+FFFD instead of failing.
pub fn decode(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    String::from_utf8_lossy(bytes)
}

/// Lines (CRLF / LF / mixed) with 1-based numbers and the trailing `\r` removed.
pub fn lines(text: &str) -> Vec<(usize, &str)> {
    let mut out: Vec<(usize, &str)> = text
        .split('\n')
        .enumerate()
        .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
        .collect();
    if out.last().is_some_and(|(_, l)| l.is_empty()) {
        out.pop(); // the newline that ends the last line
    }
    out
}

/// How a table's fields are separated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Separator {
    Tab,
    Comma,
    Semicolon,
    /// Runs of two or more spaces (files whose TABs were replaced by spaces).
    Spaces,
}

impl Separator {
    /// From a header line holding several column names.
    pub fn sniff(line: &str) -> Separator {
        if line.contains('\t') {
            Separator::Tab
        } else if line.contains(';') {
            Separator::Semicolon
        } else if line.contains(',') {
            Separator::Comma
        } else {
            Separator::Spaces
        }
    }
}

/// The header row of a one-table export (formats B and C2): the separator sniffed from it and
/// the trimmed column names.
pub(crate) fn header_row(
    lines: &[(usize, &str)],
    path: &str,
) -> Result<(Separator, Vec<String>), super::recording::GazeError> {
    let Some(&(_, first)) = lines.first() else {
        return Err(super::recording::GazeError::File {
            path: path.to_string(),
            message: "the file is empty".into(),
        });
    };
    let sep = Separator::sniff(first);
    let columns = split(first, sep)
        .iter()
        .map(|(_, c)| c.trim().to_string())
        .collect();
    Ok((sep, columns))
}

/// The index of the column called `name` of a one-table export, or an error at the header
/// saying the file is not `export`.
pub(crate) fn required_column(
    columns: &[String],
    name: &str,
    path: &str,
    export: &str,
) -> Result<usize, super::recording::GazeError> {
    columns
        .iter()
        .position(|c| c == name)
        .ok_or_else(|| super::recording::GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: format!("no `{name}` column: not a {export}"),
        })
}

/// The fields of a data row of a one-table export, or None after counting the line: as blank,
/// or as unusable when its field count differs from the header's.
pub(crate) fn table_row<'a>(
    line: &'a str,
    no: usize,
    sep: Separator,
    n_columns: usize,
    rows: &mut super::recording::RowAccount,
) -> Option<Vec<(usize, &'a str)>> {
    if line.trim().is_empty() {
        rows.blank_lines += 1;
        return None;
    }
    let f = split(line, sep);
    if f.len() != n_columns {
        let reason = format!("row with a field count other than the header's {n_columns}");
        rows.reject(&reason, no, 1, line);
        return None;
    }
    Some(f)
}

/// Fields of a line with their 1-based starting columns; not trimmed (empty fields kept).
pub fn split(line: &str, sep: Separator) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    match sep {
        Separator::Spaces => {
            let bytes = line.as_bytes();
            let mut start = 0;
            let mut i = 0;
            while i < bytes.len() {
                if bytes[i] == b' ' && i + 1 < bytes.len() && bytes[i + 1] == b' ' {
                    let end = i;
                    while i < bytes.len() && bytes[i] == b' ' {
                        i += 1;
                    }
                    out.push((start + 1, &line[start..end]));
                    start = i;
                } else {
                    i += 1;
                }
            }
            out.push((start + 1, &line[start..]));
        }
        _ => {
            let c = match sep {
                Separator::Tab => '\t',
                Separator::Comma => ',',
                _ => ';',
            };
            // The separator is one ASCII byte, so every split point is a char boundary; a
            // byte loop beats a char search on rows of many short fields.
            let sep_byte = c as u8;
            let mut start = 0;
            for (i, &b) in line.as_bytes().iter().enumerate() {
                if b == sep_byte {
                    out.push((start + 1, &line[start..i]));
                    start = i + 1;
                }
            }
            out.push((start + 1, &line[start..]));
        }
    }
    out
}

/// SMI's missing-value markers: empty, `-`, `NA`, `###`.
pub fn is_missing(field: &str) -> bool {
    matches!(field.trim(), "" | "-" | "NA" | "###")
}

/// A number, accepting a decimal comma when the separator is not a comma; None if missing.
pub(crate) fn number(field: &str, sep: Separator) -> Result<Option<f64>, ()> {
    let f = field.trim();
    if is_missing(f) {
        return Ok(None);
    }
    let parsed = f.parse::<f64>().or_else(|_| {
        if sep != Separator::Comma && f.contains(',') && !f.contains('.') {
            f.replace(',', ".").parse::<f64>()
        } else {
            f.parse::<f64>()
        }
    });
    match parsed {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(()),
    }
}

/// An integer (timestamps in µs, trial and event numbers).
pub(crate) fn integer(field: &str) -> Result<Option<i64>, ()> {
    let f = field.trim();
    if is_missing(f) {
        return Ok(None);
    }
    f.parse::<i64>().map(Some).map_err(|_| ())
}

/// The text of a `# Message: …` description.
pub fn message_text(field: &str) -> String {
    let t = field.trim();
    t.strip_prefix("# Message:")
        .map(|m| m.trim_start().to_string())
        .unwrap_or_else(|| t.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitting_keeps_empty_fields_and_columns() {
        assert_eq!(
            split("a\t\tb\t", Separator::Tab),
            vec![(1, "a"), (3, ""), (4, "b"), (6, "")]
        );
        assert_eq!(
            split("Fixation L        1        12.5", Separator::Spaces),
            vec![(1, "Fixation L"), (19, "1"), (28, "12.5")]
        );
        assert_eq!(number(" 12,5 ", Separator::Tab), Ok(Some(12.5)));
        assert_eq!(number("-", Separator::Tab), Ok(None));
        assert_eq!(number("x", Separator::Tab), Err(()));
        assert_eq!(number("nan", Separator::Tab), Err(()));
        assert_eq!(
            message_text("# Message: UE-mouseclick left x=407 y=378"),
            "UE-mouseclick left x=407 y=378"
        );
    }
}

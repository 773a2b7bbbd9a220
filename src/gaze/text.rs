//! Text-level helpers shared by the SMI readers: lines with numbers, fields with columns,
//! missing-value markers, lenient numbers.

/// The file as text, BOM stripped. Header text comes from Windows: invalid UTF-8 (cp1252
/// bytes) is decoded leniently to U+FFFD instead of failing.
pub fn decode(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    // The strict check skips ASCII a word at a time; the lossy decoder walks byte by byte, so
    // it runs only on the rare file that needs it (a quarter of a large export's parse time).
    // Exports are nearly always pure ASCII, which a 16-byte-wide check confirms faster than a
    // UTF-8 validator walks it.
    if bytes.is_ascii() {
        // SAFETY: every ASCII byte sequence is valid UTF-8.
        return std::borrow::Cow::Borrowed(unsafe { std::str::from_utf8_unchecked(bytes) });
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => std::borrow::Cow::Borrowed(text),
        Err(_) => String::from_utf8_lossy(bytes),
    }
}

/// Lines (CRLF / LF / mixed) with 1-based numbers and the trailing `\r` removed.
pub fn lines(text: &str) -> Vec<(usize, &str)> {
    let bytes = text.as_bytes();
    let mut out: Vec<(usize, &str)> = Vec::with_capacity(bytes.len() / 256 + 1);
    let mut start = 0;
    let mut push = |start: usize, end: usize| {
        let l = &text[start..end];
        out.push((out.len() + 1, l.strip_suffix('\r').unwrap_or(l)));
    };
    // Newlines found 64 bytes at a time (a 600-byte row is ten block steps, not a byte-wise
    // search); `\n` is one ASCII byte, so every cut is a char boundary.
    let mut base = 0;
    while base < bytes.len() {
        let (mut newlines, _) = separator_and_quote_masks(&bytes[base..], b'\n');
        while newlines != 0 {
            let i = base + newlines.trailing_zeros() as usize;
            push(start, i);
            start = i + 1;
            newlines &= newlines - 1;
        }
        base += 64;
    }
    // The text after the last newline, unless nothing but a `\r` (or nothing) is left.
    if !matches!(&bytes[start..], b"" | b"\r") {
        push(start, bytes.len());
    }
    out
}

/// How a table's fields are separated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Separator {
    /// TAB.
    Tab,
    /// `,`.
    Comma,
    /// `;`.
    Semicolon,
    /// Runs of two or more spaces (files whose TABs were replaced by spaces).
    Spaces,
}

impl Separator {
    /// The one byte between fields; None for runs of spaces.
    pub(crate) fn byte(self) -> Option<u8> {
        match self {
            Separator::Tab => Some(b'\t'),
            Separator::Comma => Some(b','),
            Separator::Semicolon => Some(b';'),
            Separator::Spaces => None,
        }
    }

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

/// Calls `at` with the byte offset of every `sep` in `bytes`, in order. Eight bytes at a time
/// (a word compare that flags exactly the bytes equal to `sep`), so a 600-byte row of 100
/// fields costs ~75 word steps instead of 600 byte compares; plain safe code, the same
/// offsets as a byte loop (tested).
#[inline]
pub(crate) fn for_each_separator(bytes: &[u8], sep: u8, mut at: impl FnMut(usize)) {
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    let pattern = u64::from_ne_bytes([sep; 8]);
    let mut chunks = bytes.chunks_exact(8);
    let mut base = 0;
    for chunk in &mut chunks {
        let word = u64::from_le_bytes(chunk.try_into().expect("chunks of eight"));
        let x = word ^ pattern;
        // High bit of each byte set exactly where that byte of x is zero (no borrow between
        // bytes, unlike the shorter has-zero trick).
        let mut zero = !(((x & LOW7) + LOW7) | x | LOW7);
        while zero != 0 {
            at(base + (zero.trailing_zeros() / 8) as usize);
            zero &= zero - 1;
        }
        base += 8;
    }
    for (i, &b) in chunks.remainder().iter().enumerate() {
        if b == sep {
            at(base + i);
        }
    }
}

/// Fields of a line with their 1-based starting columns; not trimmed (empty fields kept).
pub fn split(line: &str, sep: Separator) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    split_into(line, sep, &mut out);
    out
}

/// [`split`] into `out` (cleared first), so a reader can keep one buffer for every row of a
/// file instead of growing a new one per row (rows of ~90 fields reallocated six times).
pub fn split_into<'a>(line: &'a str, sep: Separator, out: &mut Vec<(usize, &'a str)>) {
    out.clear();
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
        Separator::Tab | Separator::Comma | Separator::Semicolon => {
            let c = sep.byte().expect("a one-byte separator");
            // The separator is one ASCII byte, so every split point is a char boundary.
            let mut start = 0;
            for_each_separator(line.as_bytes(), c, |i| {
                out.push((start + 1, &line[start..i]));
                start = i + 1;
            });
            out.push((start + 1, &line[start..]));
        }
    }
}

/// [`split_into`] for a reader that looks at a few columns of a wide row: the fields of
/// `wanted` columns are stored (the others stay empty), and the row's field count is returned. Fields past the last wanted column are only
/// counted: Tobii Pro Lab writes ~100 columns and its reader's last is the 86th.
/// `out` keeps `wanted.len()` entries across rows; the caller reads `&out[..count.min(len)]`.
/// A `"` is an ordinary byte here (`table_scan::for_each_row` can stop at quotes for CSV).
pub(crate) fn split_wanted<'a>(
    line: &'a str,
    sep: Separator,
    wanted: &[bool],
    out: &mut Vec<(usize, &'a str)>,
) -> usize {
    let Some(sep_byte) = sep.byte() else {
        split_into(line, sep, out);
        let count = out.len();
        out.resize(wanted.len().max(count), (0, ""));
        return count;
    };
    split_wanted_at(line, sep_byte, wanted, out)
}

/// The splitter of [`split_wanted`]: 64 bytes at a time as bit masks of separators; fields are walked bit by bit only up to the last wanted column,
/// the rest of the row's separators are counted by popcount.
fn split_wanted_at<'a>(
    line: &'a str,
    sep: u8,
    wanted: &[bool],
    out: &mut Vec<(usize, &'a str)>,
) -> usize {
    if out.len() != wanted.len() {
        out.clear();
        out.resize(wanted.len(), (0, ""));
    }
    // Fields past the last wanted one are only counted.
    let last_wanted = wanted.iter().rposition(|&w| w);
    let bytes = line.as_bytes();
    let (mut k, mut start, mut base) = (0usize, 0usize, 0usize);
    while base < bytes.len() {
        let (mut seps, _) = separator_and_quote_masks(&bytes[base..], sep);
        if let Some(last) = last_wanted.filter(|&last| k <= last) {
            while seps != 0 {
                let i = base + seps.trailing_zeros() as usize;
                if wanted[k] {
                    out[k] = (start + 1, &line[start..i]);
                }
                k += 1;
                start = i + 1;
                seps &= seps - 1;
                if k > last {
                    k += seps.count_ones() as usize;
                    break;
                }
            }
        } else {
            k += seps.count_ones() as usize;
        }
        base += 64;
    }
    if wanted.get(k) == Some(&true) {
        out[k] = (start + 1, &line[start..]);
    }
    k + 1
}

/// Bit i of the first mask is set where byte i of the (up to) 64 leading bytes of `bytes` is
/// `sep`, of the second where it is `"`. SSE2 (part of every x86-64) compares 16 bytes at once;
/// elsewhere a byte loop gives the same bits (tested against it).
#[inline]
fn separator_and_quote_masks(bytes: &[u8], sep: u8) -> (u64, u64) {
    let mut padded = [0u8; 64];
    let block: &[u8; 64] = match bytes.get(..64) {
        Some(b) => b.try_into().expect("64 bytes"),
        None => {
            // Zero bytes are neither a separator nor a quote.
            padded[..bytes.len()].copy_from_slice(bytes);
            &padded
        }
    };
    #[cfg(target_arch = "x86_64")]
    {
        masks_sse2(block, sep)
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        masks_bytewise(block, sep)
    }
}

#[cfg(target_arch = "x86_64")]
#[inline]
fn masks_sse2(block: &[u8; 64], sep: u8) -> (u64, u64) {
    use std::arch::x86_64::{
        __m128i, _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8,
    };
    // SAFETY: SSE2 is part of the x86-64 baseline, so every x86-64 CPU has these
    // instructions; block holds 64 bytes and bytes 16k..16k+16 are inside it for k < 4, and
    // loadu has no alignment requirement.
    unsafe {
        let (s, q) = (_mm_set1_epi8(sep as i8), _mm_set1_epi8(b'"' as i8));
        let (mut seps, mut quotes) = (0u64, 0u64);
        for k in 0..4 {
            let v = _mm_loadu_si128(block.as_ptr().add(16 * k).cast::<__m128i>());
            seps |= u64::from(_mm_movemask_epi8(_mm_cmpeq_epi8(v, s)) as u16) << (16 * k);
            quotes |= u64::from(_mm_movemask_epi8(_mm_cmpeq_epi8(v, q)) as u16) << (16 * k);
        }
        (seps, quotes)
    }
}

#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn masks_bytewise(block: &[u8; 64], sep: u8) -> (u64, u64) {
    let (mut seps, mut quotes) = (0u64, 0u64);
    for (i, &b) in block.iter().enumerate() {
        seps |= u64::from(b == sep) << i;
        quotes |= u64::from(b == b'"') << i;
    }
    (seps, quotes)
}

/// `field.trim()`, without the trim's general walk for the usual field that starts and ends
/// with a visible ASCII character (a tenth of a wide export's read went to trims).
#[inline]
pub(crate) fn trimmed(field: &str) -> &str {
    match field.as_bytes() {
        [first, .., last] if first.is_ascii_graphic() && last.is_ascii_graphic() => field,
        [only] if only.is_ascii_graphic() => field,
        _ => field.trim(),
    }
}

/// SMI's missing-value markers: empty, `-`, `NA`, `###`.
pub fn is_missing(field: &str) -> bool {
    matches!(field.trim(), "" | "-" | "NA" | "###")
}

/// A plain decimal (`-12.345`, at most 15 digits, no exponent) as the f64 `str::parse`
/// gives, found faster; None for anything else, which the caller parses the usual way.
/// Exact by Clinger's fast path: the digits make an integer below 2^53 and the power of ten is
/// at most 10^15, both exact doubles, and one IEEE division of exact operands is correctly
/// rounded, which is what `parse` returns (tested against it). Trackers write every sample's
/// positions this way, a dozen numbers per row.
pub(crate) fn plain_decimal(text: &str) -> Option<f64> {
    const POWERS: [f64; 16] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
    ];
    let bytes = text.as_bytes();
    let (negative, digits) = match bytes.first()? {
        b'-' => (true, &bytes[1..]),
        b'+' => (false, &bytes[1..]),
        _ => (false, bytes),
    };
    let mut mantissa: u64 = 0;
    let mut count = 0usize;
    let mut fraction: Option<usize> = None;
    for &b in digits {
        match b {
            b'0'..=b'9' => {
                mantissa = mantissa * 10 + u64::from(b - b'0');
                count += 1;
                if let Some(f) = fraction.as_mut() {
                    *f += 1;
                }
            }
            b'.' if fraction.is_none() => fraction = Some(0),
            _ => return None,
        }
        if count > 15 {
            return None;
        }
    }
    if count == 0 {
        return None;
    }
    let value = mantissa as f64 / POWERS[fraction.unwrap_or(0)];
    Some(if negative { -value } else { value })
}

/// A number, accepting a decimal comma when the separator is not a comma; None if missing.
pub(crate) fn number(field: &str, sep: Separator) -> Result<Option<f64>, ()> {
    // Nearly every field is a bare decimal: no trim and no missing-marker compares for it.
    if let Some(v) = plain_decimal(field) {
        return Ok(Some(v));
    }
    let f = field.trim();
    if is_missing(f) {
        return Ok(None);
    }
    if let Some(v) = plain_decimal(f) {
        return Ok(Some(v));
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

    /// Every field of a byte-by-byte split, for any text: the word-at-a-time scanner must
    /// find exactly the separators a byte loop finds (bytes ≥ 0x80 and separators at word
    /// edges included).
    fn byte_loop_split(line: &str, sep: u8) -> Vec<(usize, &str)> {
        let mut out = Vec::new();
        let mut start = 0;
        for (i, &b) in line.as_bytes().iter().enumerate() {
            if b == sep {
                out.push((start + 1, &line[start..i]));
                start = i + 1;
            }
        }
        out.push((start + 1, &line[start..]));
        out
    }

    proptest::proptest! {
        #[test]
        fn the_word_scanner_splits_as_a_byte_loop(
            line in "[a\\t,;\"\u{7f}\u{80}\u{ff}é0-9 .]{0,200}",
            wanted_bits in proptest::collection::vec(proptest::bool::ANY, 0..40),
        ) {
            for (sep, byte) in [(Separator::Tab, b'\t'), (Separator::Comma, b','), (Separator::Semicolon, b';')] {
                let expected = byte_loop_split(&line, byte);
                proptest::prop_assert_eq!(&split(&line, sep), &expected);
                let mut out = Vec::new();
                let count = split_wanted(&line, sep, &wanted_bits, &mut out);
                proptest::prop_assert_eq!(count, expected.len());
                for (k, &want) in wanted_bits.iter().enumerate().take(count) {
                    if want {
                        proptest::prop_assert_eq!(out[k], expected[k]);
                    }
                }
            }
        }
    }

    proptest::proptest! {
        #[test]
        fn lines_are_those_of_a_split_at_newlines(text in "[a\\r\\n,é ]{0,300}") {
            let mut expected: Vec<(usize, &str)> = text
                .split('\n')
                .enumerate()
                .map(|(i, l)| (i + 1, l.strip_suffix('\r').unwrap_or(l)))
                .collect();
            if expected.last().is_some_and(|(_, l)| l.is_empty()) {
                expected.pop();
            }
            proptest::prop_assert_eq!(lines(&text), expected);
        }
    }

    proptest::proptest! {
        #[test]
        fn the_block_masks_are_the_byte_loops(
            bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..64),
            sep in proptest::sample::select(vec![b'\t', b',', b';']),
        ) {
            let mut block = [0u8; 64];
            block[..bytes.len()].copy_from_slice(&bytes);
            proptest::prop_assert_eq!(separator_and_quote_masks(&bytes, sep), masks_bytewise(&block, sep));
        }
    }

    proptest::proptest! {
        #[test]
        fn a_plain_decimal_parses_to_the_bits_str_parse_gives(
            text in "[-+]?[0-9]{0,17}(\\.[0-9]{0,17})?",
            value in proptest::num::f64::ANY,
            places in 0usize..12,
        ) {
            // Random digit strings, and printed doubles (the form trackers write).
            let printed = format!("{value:.places$}");
            for t in [text.as_str(), printed.as_str()] {
                if let Some(fast) = plain_decimal(t) {
                    let slow: f64 = t.parse().expect("a plain decimal parses");
                    proptest::prop_assert_eq!(fast.to_bits(), slow.to_bits(), "{}", t);
                }
            }
        }
    }

    #[test]
    fn plain_decimals_leave_other_forms_to_the_full_parser() {
        for t in [
            "",
            "-",
            ".",
            "1e5",
            "1,5",
            "nan",
            "inf",
            "0x10",
            "1.2.3",
            "1234567890123456",
        ] {
            assert_eq!(plain_decimal(t), None, "{t}");
        }
        assert_eq!(
            plain_decimal("-0.0").map(f64::to_bits),
            Some((-0.0f64).to_bits())
        );
        assert_eq!(plain_decimal(".5"), Some(0.5));
        assert_eq!(plain_decimal("12."), Some(12.0));
        assert_eq!(plain_decimal("0.45310"), Some(0.4531));
    }
}

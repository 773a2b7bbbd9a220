//! One pass over a table export's bytes: lines, their fields and their text checked together.
//!
//! Reading a wide export as "decode the file, cut it into lines, split each line" walks its
//! bytes three times; a Tobii Pro Lab export of an hour at 120 Hz is ~270 MB of 600-byte rows,
//! and each walk streams all of it from memory. Here every 64-byte block is loaded once and
//! turned into four bit masks (separators, quotes, newlines, non-ASCII bytes), from which the
//! rows, their wanted fields and whether a row needs a UTF-8 check all follow. The lines, line
//! numbers, fields and lossy decoding are those of `text::decode`, `text::lines` and
//! `text::split_wanted` (tested against them).

use std::borrow::Cow;

use super::text::{split_wanted, Separator};

/// A line of a table's body as [`for_each_row`] hands it out.
pub(crate) struct Row<'r> {
    /// 1-based line number in the file.
    pub no: usize,
    /// The line, its `\r` removed; invalid UTF-8 replaced by U+FFFD as `text::decode` does.
    pub line: &'r str,
    /// The wanted columns' fields with their 1-based starting columns (the others empty), to
    /// be read as `&fields[..count.min(fields.len())]`; None when the caller asked quotes to
    /// stop the split and the line holds a `"` (a quoted CSV field may hold the separator: the
    /// caller splits such a line itself).
    pub fields: Option<&'r [(usize, &'r str)]>,
    /// The line's field count (separators + 1); meaningless when `fields` is None.
    pub count: usize,
    /// The line's last field, whatever its column (Studio and Gazepoint end rows with a
    /// separator: the field after it is the empty one).
    pub last: &'r str,
}

/// The first line of `bytes` (a UTF-8 BOM skipped, `\r` removed, decoded leniently) and the
/// byte offset where the next line starts; None for a file with no line at all.
pub(crate) fn first_line(bytes: &[u8]) -> Option<(Cow<'_, str>, usize)> {
    let skip = if bytes.starts_with(b"\xEF\xBB\xBF") {
        3
    } else {
        0
    };
    let rest = &bytes[skip..];
    let (line, next) = match rest.iter().position(|&b| b == b'\n') {
        Some(i) => (&rest[..i], skip + i + 1),
        // Nothing, or a lone `\r`: `text::lines` sees no line there.
        None if matches!(rest, b"" | b"\r") => return None,
        None => (rest, bytes.len()),
    };
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    Some((String::from_utf8_lossy(line), next))
}

/// The lines of `body` (from a line start to the end of the file), `\r` removed and decoded
/// leniently, for the few readers' checks that look at some rows before the pass (the time
/// unit from the first rows and the last). A trailing empty piece after the last newline is
/// included; it is blank, like the lines those checks skip.
pub(crate) fn body_lines(body: &[u8]) -> impl DoubleEndedIterator<Item = Cow<'_, str>> {
    body.split(|&b| b == b'\n').map(|l| {
        let l = l.strip_suffix(b"\r").unwrap_or(l);
        String::from_utf8_lossy(l)
    })
}

/// A guess of how many lines `body` holds, from the lines of its first 256 kB, for reserving
/// a reader's sample list once (a guess too high reserves address space that is never
/// touched; too low, the list grows as usual).
pub(crate) fn lines_estimate(body: &[u8]) -> usize {
    let head = &body[..body.len().min(1 << 18)];
    let newlines = head.iter().filter(|&&b| b == b'\n').count().max(1);
    let per_line = head.len() / newlines;
    body.len() / per_line.max(1) * 9 / 8 + 16
}

/// Calls `each` with every line of `bytes` from byte `from` (the start of line `first_no`)
/// on: blank ones too, which the caller counts. Returns the number of the file's last line
/// (`text::lines(..).len()` of the whole file). Fields of `wanted` columns are cut from the
/// line; columns past the last wanted one are only counted. With `stop_at_quote`, a line
/// holding a `"` comes with no fields.
pub(crate) fn for_each_row(
    bytes: &[u8],
    from: usize,
    first_no: usize,
    sep: Separator,
    wanted: &[bool],
    stop_at_quote: bool,
    each: impl FnMut(Row<'_>),
) -> usize {
    let Some(plan) = Plan::new(sep, wanted, stop_at_quote) else {
        return each_row_by_line(bytes, from, first_no, sep, wanted, stop_at_quote, each);
    };
    if bytes.len().saturating_sub(from) >= PIPELINE_MIN_BYTES && rayon::current_num_threads() > 1 {
        return rows_pipelined(&plan, bytes, from, first_no, BATCH_LINES, each);
    }
    rows_in_this_thread(&plan, bytes, from, first_no, each)
}

/// The scan and the rows on the calling thread.
fn rows_in_this_thread(
    plan: &Plan<'_>,
    bytes: &[u8],
    from: usize,
    first_no: usize,
    mut each: impl FnMut(Row<'_>),
) -> usize {
    let mut fields = vec![(0, ""); plan.wanted.len()];
    let mut spans = Vec::with_capacity(plan.wanted_columns.len());
    scan_lines(plan, bytes, from, first_no, |line, end, seps| {
        spans.clear();
        let cut_line = cut(plan, bytes, line, end, seps, &mut spans);
        hand_out(plan, bytes, &cut_line, &spans, &mut fields, &mut each)
    })
}

/// Below this many bytes a file is read on one thread: a second thread's start and hand-offs
/// would cost more than they save.
const PIPELINE_MIN_BYTES: usize = 2 << 20;

/// Lines per hand-off from the scanning thread to the rows' thread.
const BATCH_LINES: usize = 1024;

/// Lines cut by the scanning thread, waiting for the rows' thread.
#[derive(Default)]
struct LineBatch {
    lines: Vec<(CutLine, usize)>,
    /// Each line's wanted fields' ranges, in line order; a line's start at the offset beside
    /// it and end at the next line's.
    spans: Vec<(usize, usize)>,
}

/// The scan on a second thread, the rows (`each`, the reader's own logic) on the calling one,
/// lines handed over in batches: the same rows in the same order as [`rows_in_this_thread`],
/// in the time of the slower half instead of the sum of both. (A Tobii Pro Lab row of 100
/// fields spends about a third of its reading time in the scan.) If the thread cannot be
/// started, everything runs on the calling thread.
fn rows_pipelined(
    plan: &Plan<'_>,
    bytes: &[u8],
    from: usize,
    first_no: usize,
    batch_lines: usize,
    mut each: impl FnMut(Row<'_>),
) -> usize {
    use std::sync::mpsc::{channel, sync_channel};
    let (full_tx, full_rx) = sync_channel::<LineBatch>(2);
    let (empty_tx, empty_rx) = channel::<LineBatch>();
    std::thread::scope(|scope| {
        let scanning = std::thread::Builder::new()
            .name("meshgaze-scan".into())
            .spawn_scoped(scope, move || {
                let mut batch = LineBatch::default();
                let last_no = scan_lines(plan, bytes, from, first_no, |line, end, seps| {
                    let at = batch.spans.len();
                    let cut_line = cut(plan, bytes, line, end, seps, &mut batch.spans);
                    batch.lines.push((cut_line, at));
                    if batch.lines.len() >= batch_lines {
                        let next = empty_rx.try_recv().unwrap_or_default();
                        // A send fails only when the rows' side has stopped (it panicked):
                        // the scan finishes unheard and the panic is passed on.
                        let _ = full_tx.send(std::mem::replace(&mut batch, next));
                    }
                });
                let _ = full_tx.send(batch);
                last_no
            });
        let Ok(scanning) = scanning else {
            return rows_in_this_thread(plan, bytes, from, first_no, each);
        };
        let mut fields = vec![(0, ""); plan.wanted.len()];
        for mut batch in full_rx {
            for (i, (line, at)) in batch.lines.iter().enumerate() {
                let to = batch
                    .lines
                    .get(i + 1)
                    .map_or(batch.spans.len(), |next| next.1);
                hand_out(
                    plan,
                    bytes,
                    line,
                    &batch.spans[*at..to],
                    &mut fields,
                    &mut each,
                );
            }
            batch.lines.clear();
            batch.spans.clear();
            let _ = empty_tx.send(batch);
        }
        scanning
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))
    })
}

/// Calls `line_end(line, end, seps)` for every line of `bytes` from `from` on, `seps` being
/// the line's listed separators, with the fastest block masks this CPU has; returns the
/// number of the file's last line.
fn scan_lines(
    plan: &Plan<'_>,
    bytes: &[u8],
    from: usize,
    first_no: usize,
    line_end: impl FnMut(&LineState, usize, &[usize]),
) -> usize {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::is_x86_feature_detected as has;
        if has!("popcnt") && has!("bmi1") && has!("lzcnt") {
            if has!("avx512bw") {
                // SAFETY: this CPU has AVX-512BW, POPCNT, BMI1 and LZCNT, checked just above.
                return unsafe { scan_avx512(plan, bytes, from, first_no, line_end) };
            }
            // SAFETY: this CPU has POPCNT, BMI1 and LZCNT, checked just above.
            return unsafe { scan_bit_counts(plan, bytes, from, first_no, line_end) };
        }
    }
    scan::<PortableMasks, _>(plan, bytes, from, first_no, line_end)
}

/// What [`for_each_row`] looks for, worked out once per file.
struct Plan<'w> {
    sep: Separator,
    sep_byte: u8,
    wanted: &'w [bool],
    wanted_columns: Vec<usize>,
    stop_at_quote: bool,
}

impl<'w> Plan<'w> {
    /// None for a separator that is not one byte (runs of spaces), which no mask finds.
    fn new(sep: Separator, wanted: &'w [bool], stop_at_quote: bool) -> Option<Plan<'w>> {
        let sep_byte = sep.byte()?;
        Some(Plan {
            sep,
            sep_byte,
            wanted,
            wanted_columns: (0..wanted.len()).filter(|&k| wanted[k]).collect(),
            stop_at_quote,
        })
    }
}

/// How far ahead of the block being split its bytes are asked for: the walk over a row's
/// fields leaves the memory stream idle long enough that the hardware prefetcher alone lags
/// (a third of the scan's time was spent waiting on block loads).
const PREFETCH_AHEAD: usize = 2048;

/// Asks the CPU to start loading the cache line at `bytes[at]` (nothing past the end).
#[inline(always)]
fn prefetch(bytes: &[u8], at: usize) {
    #[cfg(target_arch = "x86_64")]
    if at < bytes.len() {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        // SAFETY: SSE is part of the x86-64 baseline; a prefetch never faults, and the
        // address is inside `bytes`.
        unsafe { _mm_prefetch::<_MM_HINT_T0>(bytes.as_ptr().add(at).cast::<i8>()) };
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (bytes, at);
}

/// [`scan`] compiled for the bit-count instructions x86-64 CPUs have had since 2013 (the
/// x86-64 baseline counts a mask's bits with a dozen shifts and masks): a tenth faster.
///
/// # Safety
/// The CPU must have POPCNT, BMI1 and LZCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "popcnt,bmi1,lzcnt")]
unsafe fn scan_bit_counts(
    plan: &Plan<'_>,
    bytes: &[u8],
    from: usize,
    first_no: usize,
    line_end: impl FnMut(&LineState, usize, &[usize]),
) -> usize {
    scan::<PortableMasks, _>(plan, bytes, from, first_no, line_end)
}

/// [`scan`] compiled for AVX-512BW as well, whose 64-byte compares give a block's masks in
/// one instruction each (SSE2 takes four compares, four moves and shifts per mask).
/// (AVX2 between the two was tried: with its two 32-bit movemasks joined into a u64, LLVM
/// took the join apart lane by lane, 0.58 s on the bench's Tobii parse; with the join hidden
/// from it, 0.42-0.45 s, no better than SSE2 with bit counts, 0.43-0.45 s. Not kept.)
///
/// # Safety
/// The CPU must have AVX-512BW, POPCNT, BMI1 and LZCNT.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512bw,popcnt,bmi1,lzcnt")]
unsafe fn scan_avx512(
    plan: &Plan<'_>,
    bytes: &[u8],
    from: usize,
    first_no: usize,
    line_end: impl FnMut(&LineState, usize, &[usize]),
) -> usize {
    scan::<Avx512Masks, _>(plan, bytes, from, first_no, line_end)
}

/// The block walk of [`for_each_row`], with the block masks of `M`.
///
/// A line's separators, up to the end of the last wanted column, are written to a list as
/// the blocks go by (those after it only counted), and `line_end` gets the list at the
/// line's end: the wanted fields are cut from it there, on whichever thread runs the cut.
/// (On one thread this is as fast as the earlier walk that skipped unwanted columns by bit
/// counts; it is what lets the scan and the rows run on two.)
#[inline(always)]
fn scan<M: Masks, F: FnMut(&LineState, usize, &[usize])>(
    plan: &Plan<'_>,
    bytes: &[u8],
    from: usize,
    first_no: usize,
    mut line_end: F,
) -> usize {
    let sep_byte = plan.sep_byte;
    // Separators past the end of the last wanted column are only counted: the fields after
    // it are never cut (a Pro Lab row's last 15 columns), and a damaged line of millions of
    // separators must not grow the list with it.
    let listed_max = plan.wanted_columns.last().map_or(0, |&k| k + 1);
    let mut seps_at: Vec<usize> = vec![0; listed_max + 72];
    let mut line = LineState {
        no: first_no,
        start: from,
        listed: 0,
        unlisted: 0,
        last_sep: 0,
        quoted: false,
        non_ascii: false,
    };
    let mut base = from;
    while base < bytes.len() {
        prefetch(bytes, base + PREFETCH_AHEAD);
        let m = M::masks(&bytes[base..], sep_byte);
        let (mut seps, mut quotes, mut newlines, mut high) = (m.seps, m.quotes, m.newlines, m.high);
        loop {
            let nl = newlines.trailing_zeros();
            let before = if nl >= 64 { u64::MAX } else { (1u64 << nl) - 1 };
            line.quoted |= quotes & before != 0;
            line.non_ascii |= high & before != 0;
            let mut s = seps & before;
            if s != 0 {
                let c = s.count_ones() as usize;
                if line.listed < listed_max {
                    // The list holds listed_max + 72 slots: up to listed_max - 1 listed, 64
                    // more from this block, and the 8-wide writes' slack past them.
                    let out = &mut seps_at[line.listed..line.listed + c];
                    for slot in out {
                        *slot = base + s.trailing_zeros() as usize;
                        s &= s.wrapping_sub(1);
                    }
                    line.listed += c;
                } else {
                    line.unlisted += c;
                    line.last_sep = base + 63 - s.leading_zeros() as usize;
                }
            }
            if nl >= 64 {
                break;
            }
            let end = base + nl as usize;
            line_end(&line, end, &seps_at[..line.listed]);
            line = LineState {
                no: line.no + 1,
                start: end + 1,
                listed: 0,
                unlisted: 0,
                last_sep: 0,
                quoted: false,
                non_ascii: false,
            };
            let done = !(before | (1u64 << nl));
            seps &= done;
            quotes &= done;
            newlines &= done;
            high &= done;
        }
        base += 64;
    }
    // Text after the last newline is a line unless nothing or only a `\r` is left.
    if !matches!(&bytes[line.start.min(bytes.len())..], b"" | b"\r") {
        line_end(&line, bytes.len(), &seps_at[..line.listed]);
        line.no += 1;
    }
    line.no - 1
}

/// Where the scan is within the current line.
#[derive(Clone, Copy)]
struct LineState {
    no: usize,
    /// Byte offset of the line's start.
    start: usize,
    /// Separators of the line written to the list, and those past the list only counted
    /// (the last of which is at `last_sep`).
    listed: usize,
    unlisted: usize,
    last_sep: usize,
    quoted: bool,
    non_ascii: bool,
}

impl LineState {
    /// Where the line's last field starts.
    fn last_field_start(&self, seps_at: &[usize]) -> usize {
        if self.unlisted > 0 {
            self.last_sep + 1
        } else if self.listed > 0 {
            seps_at[self.listed - 1] + 1
        } else {
            self.start
        }
    }
}

/// A line cut into the byte ranges of its wanted fields (kept beside it), ready to be handed
/// out as a [`Row`].
#[derive(Clone, Copy)]
struct CutLine {
    no: usize,
    start: usize,
    /// Where the line ends, its `\r` removed.
    end: usize,
    last_start: usize,
    count: usize,
    quoted: bool,
    /// Whether the line is valid UTF-8 (an ASCII line is, unchecked); its fields are cut
    /// only if so.
    utf8: bool,
}

/// Cuts the line ending at byte `end` (its newline, or the end of the file): `seps` lists its
/// first separators (`line.listed` of them); the wanted fields' ranges are pushed to `spans`,
/// those of `plan.wanted_columns` in order, as far as the line has them.
#[inline]
fn cut(
    plan: &Plan<'_>,
    bytes: &[u8],
    line: &LineState,
    end: usize,
    seps: &[usize],
    spans: &mut Vec<(usize, usize)>,
) -> CutLine {
    let line_end = if end > line.start && bytes[end - 1] == b'\r' {
        end - 1
    } else {
        end
    };
    let utf8 = !line.non_ascii || std::str::from_utf8(&bytes[line.start..line_end]).is_ok();
    let quoted = line.quoted && plan.stop_at_quote;
    if utf8 && !quoted {
        // A line with unlisted separators has listed every wanted column's end.
        for &k in &plan.wanted_columns {
            if k > seps.len() {
                break;
            }
            let start = if k == 0 { line.start } else { seps[k - 1] + 1 };
            let field_end = seps.get(k).copied().unwrap_or(line_end);
            spans.push((start.min(field_end), field_end));
        }
    }
    CutLine {
        no: line.no,
        start: line.start,
        end: line_end,
        last_start: line.last_field_start(seps).min(line_end),
        count: line.listed + line.unlisted + 1,
        quoted,
        utf8,
    }
}

/// Hands a cut line to `each`, its wanted fields' ranges in `spans`.
#[inline]
fn hand_out<'b>(
    plan: &Plan<'_>,
    bytes: &'b [u8],
    line: &CutLine,
    spans: &[(usize, usize)],
    fields: &mut [(usize, &'b str)],
    each: &mut impl FnMut(Row<'_>),
) {
    if !line.utf8 {
        // Rare (a cp1252 export): decode this line alone and split it the plain way.
        let text = String::from_utf8_lossy(&bytes[line.start..line.end]);
        let quoted = plan.stop_at_quote && text.contains('"');
        let mut local = Vec::new();
        let count = if quoted {
            0
        } else {
            split_wanted(&text, plan.sep, plan.wanted, &mut local)
        };
        let last = text.rsplit(char::from(plan.sep_byte)).next().unwrap_or("");
        each(Row {
            no: line.no,
            line: &text,
            fields: (!quoted).then_some(&local[..]),
            count,
            last,
        });
        return;
    }
    let text = |a: usize, b: usize| -> &'b str {
        // SAFETY: the line is valid UTF-8 (ASCII, or checked in `cut`), and a and b lie on
        // its separators, newline or ends, all ASCII bytes, so on char boundaries.
        unsafe { std::str::from_utf8_unchecked(&bytes[a..b]) }
    };
    for (&k, &(a, b)) in plan.wanted_columns.iter().zip(spans) {
        fields[k] = (a - line.start + 1, text(a, b));
    }
    each(Row {
        no: line.no,
        line: text(line.start, line.end),
        fields: (!line.quoted).then_some(&fields[..]),
        count: line.count,
        last: text(line.last_start, line.end),
    });
}

/// The per-line path for fields split at runs of spaces, which no byte mask finds.
fn each_row_by_line(
    bytes: &[u8],
    from: usize,
    first_no: usize,
    sep: Separator,
    wanted: &[bool],
    stop_at_quote: bool,
    mut each: impl FnMut(Row<'_>),
) -> usize {
    let mut no = first_no;
    let body = &bytes[from.min(bytes.len())..];
    let mut pieces = body.split(|&b| b == b'\n').peekable();
    while let Some(piece) = pieces.next() {
        if pieces.peek().is_none() && matches!(piece, b"" | b"\r") {
            break;
        }
        let raw = piece.strip_suffix(b"\r").unwrap_or(piece);
        let text = String::from_utf8_lossy(raw);
        let quoted = stop_at_quote && text.contains('"');
        let mut buffer = Vec::new();
        let count = if quoted {
            0
        } else {
            split_wanted(&text, sep, wanted, &mut buffer)
        };
        let last = super::text::split(&text, sep).last().map_or("", |f| f.1);
        each(Row {
            no,
            line: &text,
            fields: (!quoted).then_some(&buffer[..]),
            count,
            last,
        });
        no += 1;
    }
    no - 1
}

/// Bit masks of a block of (up to) 64 bytes.
struct BlockMasks {
    seps: u64,
    quotes: u64,
    newlines: u64,
    /// Bytes with the high bit set (not ASCII).
    high: u64,
}

/// How a block's masks are found.
trait Masks {
    /// The masks of the leading (up to) 64 bytes of `bytes`; missing bytes count as zeros,
    /// which are none of the four.
    fn masks(bytes: &[u8], sep: u8) -> BlockMasks;
}

/// Calls `$masks(&[u8; 64], sep)` on the leading 64 bytes of `$bytes`, zero-padded when fewer
/// are left. A macro, not a function taking a closure: a closure is compiled without the
/// caller's target features, and AVX2 code inside one would be emulated byte by byte.
macro_rules! on_block {
    ($bytes:expr, $sep:expr, $masks:expr) => {{
        let bytes: &[u8] = $bytes;
        match bytes.get(..64) {
            Some(b) => $masks(b.try_into().expect("64 bytes"), $sep),
            None => {
                let mut padded = [0u8; 64];
                padded[..bytes.len()].copy_from_slice(bytes);
                $masks(&padded, $sep)
            }
        }
    }};
}

/// SSE2 (part of every x86-64) compares 16 bytes at once; elsewhere a byte loop gives the
/// same bits (tested against it).
struct PortableMasks;

impl Masks for PortableMasks {
    #[inline(always)]
    fn masks(bytes: &[u8], sep: u8) -> BlockMasks {
        #[cfg(target_arch = "x86_64")]
        {
            on_block!(bytes, sep, block_masks_sse2)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            on_block!(bytes, sep, block_masks_bytewise)
        }
    }
}

/// AVX-512BW's 64-byte compares: only for code compiled with AVX-512BW on a CPU that has
/// it ([`scan_avx512`]).
#[cfg(target_arch = "x86_64")]
struct Avx512Masks;

#[cfg(target_arch = "x86_64")]
impl Masks for Avx512Masks {
    #[inline(always)]
    fn masks(bytes: &[u8], sep: u8) -> BlockMasks {
        // SAFETY: Avx512Masks is used only inside `scan_avx512`, entered after checking the
        // CPU has AVX-512BW.
        unsafe { on_block!(bytes, sep, block_masks_avx512) }
    }
}

/// # Safety
/// The CPU must have AVX-512BW.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512bw")]
#[inline]
unsafe fn block_masks_avx512(block: &[u8; 64], sep: u8) -> BlockMasks {
    use std::arch::x86_64::{
        __m512i, _mm512_cmpeq_epi8_mask, _mm512_loadu_si512, _mm512_movepi8_mask, _mm512_set1_epi8,
    };
    // SAFETY: block holds 64 bytes; loadu has no alignment requirement.
    let v = unsafe { _mm512_loadu_si512(block.as_ptr().cast::<__m512i>()) };
    BlockMasks {
        seps: _mm512_cmpeq_epi8_mask(v, _mm512_set1_epi8(sep as i8)),
        quotes: _mm512_cmpeq_epi8_mask(v, _mm512_set1_epi8(b'"' as i8)),
        newlines: _mm512_cmpeq_epi8_mask(v, _mm512_set1_epi8(b'\n' as i8)),
        high: _mm512_movepi8_mask(v),
    }
}

#[cfg(target_arch = "x86_64")]
#[inline]
fn block_masks_sse2(block: &[u8; 64], sep: u8) -> BlockMasks {
    use std::arch::x86_64::{
        __m128i, _mm_cmpeq_epi8, _mm_loadu_si128, _mm_movemask_epi8, _mm_set1_epi8,
    };
    // SAFETY: SSE2 is part of the x86-64 baseline; block holds 64 bytes, so the four 16-byte
    // loads at 16k (k < 4) are inside it, and loadu has no alignment requirement.
    unsafe {
        let s = _mm_set1_epi8(sep as i8);
        let q = _mm_set1_epi8(b'"' as i8);
        let n = _mm_set1_epi8(b'\n' as i8);
        let mut m = BlockMasks {
            seps: 0,
            quotes: 0,
            newlines: 0,
            high: 0,
        };
        for k in 0..4 {
            let v = _mm_loadu_si128(block.as_ptr().add(16 * k).cast::<__m128i>());
            let bits = |x| u64::from(_mm_movemask_epi8(x) as u16) << (16 * k);
            m.seps |= bits(_mm_cmpeq_epi8(v, s));
            m.quotes |= bits(_mm_cmpeq_epi8(v, q));
            m.newlines |= bits(_mm_cmpeq_epi8(v, n));
            m.high |= bits(v);
        }
        m
    }
}

#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn block_masks_bytewise(block: &[u8; 64], sep: u8) -> BlockMasks {
    let mut m = BlockMasks {
        seps: 0,
        quotes: 0,
        newlines: 0,
        high: 0,
    };
    for (i, &b) in block.iter().enumerate() {
        m.seps |= u64::from(b == sep) << i;
        m.quotes |= u64::from(b == b'"') << i;
        m.newlines |= u64::from(b == b'\n') << i;
        m.high |= u64::from(b >= 0x80) << i;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gaze::text::{decode, lines, split};
    use proptest::prelude::*;

    /// What the three-pass reading gives for each body line: number, line, the wanted
    /// fields (None when quoted and asked to stop), count, last field.
    type Expected = (usize, String, Option<Vec<(usize, String)>>, usize, String);

    fn three_pass(bytes: &[u8], sep: Separator, wanted: &[bool], stop: bool) -> Vec<Expected> {
        let text = decode(bytes);
        let all = lines(&text);
        let mut out = Vec::new();
        let mut buffer = Vec::new();
        for &(no, line) in all.iter().skip(1) {
            let all_fields = split(line, sep);
            let quoted = stop && line.contains('"');
            let fields = (!quoted).then(|| {
                let count = split_wanted(line, sep, wanted, &mut buffer);
                buffer[..count.min(buffer.len())]
                    .iter()
                    .enumerate()
                    .filter(|(k, _)| wanted.get(*k) == Some(&true))
                    .map(|(_, (c, f))| (*c, f.to_string()))
                    .collect()
            });
            let count = if quoted { 0 } else { all_fields.len() };
            let last = all_fields.last().map_or("", |f| f.1).to_string();
            out.push((no, line.to_string(), fields, count, last));
        }
        out
    }

    /// A row as owned text: number, line, its wanted fields (None when it came without
    /// fields), count (0 then), last field.
    fn owned(r: &Row<'_>, wanted: &[bool]) -> Expected {
        let fields = r.fields.map(|f| {
            f[..r.count.min(f.len())]
                .iter()
                .enumerate()
                .filter(|(k, _)| wanted.get(*k) == Some(&true))
                .map(|(_, (c, f))| (*c, f.to_string()))
                .collect()
        });
        let count = if r.fields.is_none() { 0 } else { r.count };
        (r.no, r.line.to_string(), fields, count, r.last.to_string())
    }

    /// Which compiled scan reads the rows: 0 as the CPU allows, 1 portable, 2 bit counts,
    /// 3 AVX-512, 4 the scan on a second thread in batches of two lines (1–4 only for byte
    /// separators; 2 and 3 only where the CPU has them).
    fn one_pass(
        bytes: &[u8],
        sep: Separator,
        wanted: &[bool],
        stop: bool,
        kernel: u8,
    ) -> (Vec<Expected>, usize) {
        let Some((_, from)) = first_line(bytes) else {
            return (Vec::new(), 0);
        };
        let mut out = Vec::new();
        let each = |r: Row<'_>| out.push(owned(&r, wanted));
        let Some(plan) = Plan::new(sep, wanted, stop).filter(|_| kernel > 0) else {
            let last_no = for_each_row(bytes, from, 2, sep, wanted, stop, each);
            return (out, last_no);
        };
        if kernel == 4 {
            // Batches of two lines: every hand-off path is crossed on small inputs.
            let last_no = rows_pipelined(&plan, bytes, from, 2, 2, each);
            return (out, last_no);
        }
        let mut each = each;
        let mut fields = vec![(0, ""); wanted.len()];
        let mut spans = Vec::new();
        let sink = |line: &LineState, end: usize, seps: &[usize]| {
            spans.clear();
            let cut_line = cut(&plan, bytes, line, end, seps, &mut spans);
            hand_out(&plan, bytes, &cut_line, &spans, &mut fields, &mut each)
        };
        let last_no = match kernel {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: called only where the CPU has these (see `kernels`).
            2 => unsafe { scan_bit_counts(&plan, bytes, from, 2, sink) },
            #[cfg(target_arch = "x86_64")]
            3 => unsafe { scan_avx512(&plan, bytes, from, 2, sink) },
            _ => scan::<PortableMasks, _>(&plan, bytes, from, 2, sink),
        };
        (out, last_no)
    }

    /// The compiled scans this CPU can run, beside the dispatching entry (0).
    fn kernels(sep: Separator) -> Vec<u8> {
        let mut k = vec![0];
        if sep == Separator::Spaces {
            return k;
        }
        k.push(1);
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("popcnt") && has!("bmi1") && has!("lzcnt") {
                k.push(2);
                if has!("avx512bw") {
                    k.push(3);
                }
            }
        }
        k.push(4);
        k
    }

    fn check(bytes: &[u8], sep: Separator, wanted: &[bool], stop: bool) {
        let expected = three_pass(bytes, sep, wanted, stop);
        let text = decode(bytes);
        for kernel in kernels(sep) {
            let (got, last_no) = one_pass(bytes, sep, wanted, stop, kernel);
            assert_eq!(got, expected, "kernel {kernel}: {:?}", text);
            assert_eq!(last_no, lines(&text).len(), "kernel {kernel}");
        }
    }

    #[test]
    fn rows_are_those_of_decode_lines_and_split() {
        let wanted = [true, false, true, false, false];
        for sep in [Separator::Comma, Separator::Tab, Separator::Spaces] {
            let s = match sep {
                Separator::Comma => ",",
                Separator::Tab => "\t",
                _ => "  ",
            };
            let file = format!(
                "\u{feff}a{s}b{s}c\r\n1{s}2{s}3\r\n\r\n4{s}5\n6{s}\"7{s}8\"{s}9\n\u{e9}{s}x{s}y{s}z{s}w{s}v\n10{s}11{s}12"
            );
            for stop in [false, true] {
                check(file.as_bytes(), sep, &wanted, stop);
            }
        }
        // Invalid UTF-8 (cp1252 bytes) on one line, a trailing lone `\r`, a line of 200 bytes
        // crossing blocks.
        let long = "x,".repeat(100);
        let mut bytes = b"h1,h2\n1,\xe92\n".to_vec();
        bytes.extend_from_slice(long.as_bytes());
        bytes.extend_from_slice(b"\n3,4\r");
        check(&bytes, Separator::Comma, &[false, true, true], true);
        check(b"", Separator::Comma, &[true], false);
        check(b"h\n", Separator::Comma, &[true], false);
        check(b"\r", Separator::Comma, &[true], false);
    }

    #[test]
    fn masks_match_a_byte_loop() {
        let mut block = [0u8; 64];
        for (i, b) in block.iter_mut().enumerate() {
            *b = [b',', b'"', b'\n', 0xC3, b'a', 0x80, b'\t'][i % 7];
        }
        let b = block_masks_bytewise(&block, b',');
        let a = PortableMasks::masks(&block, b',');
        assert_eq!(
            (a.seps, a.quotes, a.newlines, a.high),
            (b.seps, b.quotes, b.newlines, b.high)
        );
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx512bw") {
            let a = Avx512Masks::masks(&block, b',');
            assert_eq!(
                (a.seps, a.quotes, a.newlines, a.high),
                (b.seps, b.quotes, b.newlines, b.high)
            );
        }
    }

    /// Every row a reader sees, as owned text, from the scan on the calling thread or on a
    /// second one (with the production batch size).
    fn rows_by(bytes: &[u8], sep: Separator, wanted: &[bool], pipelined: bool) -> Vec<Expected> {
        let (_, from) = first_line(bytes).expect("a header line");
        let plan = Plan::new(sep, wanted, true).expect("a byte separator");
        let mut out = Vec::new();
        let each = |r: Row<'_>| out.push(owned(&r, wanted));
        let last_no = if pipelined {
            rows_pipelined(&plan, bytes, from, 2, BATCH_LINES, each)
        } else {
            rows_in_this_thread(&plan, bytes, from, 2, each)
        };
        assert_eq!(last_no, out.last().map_or(1, |r| r.0));
        out
    }

    /// Real exports, repeated past the size that turns the second thread on (many batches):
    /// the same rows, in the same order, as on one thread. Needs ../shared/data.
    #[test]
    fn real_exports_read_the_same_on_two_threads() {
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/trackers");
        for (file, sep) in [
            ("tobii/tobii-pro__all_gaze.csv", Separator::Comma),
            ("tobii/d2lab__studio_data.tsv", Separator::Tab),
            ("gazepoint/d2lab__User_1_all_gaze.csv", Separator::Comma),
        ] {
            let path = data.join(file);
            let one = std::fs::read(&path).unwrap_or_else(|e| {
                panic!(
                    "this test reads {} (../shared/data, see its SOURCES.md): {e}",
                    path.display()
                )
            });
            let (_, from) = first_line(&one).expect("a header line");
            let mut bytes = one.clone();
            while bytes.len() < PIPELINE_MIN_BYTES + 1 {
                bytes.extend_from_slice(&one[from..]);
            }
            let columns = first_line(&one)
                .unwrap()
                .0
                .split(char::from(sep.byte().unwrap()))
                .count();
            // Every third column wanted, and the last one.
            let wanted: Vec<bool> = (0..columns)
                .map(|k| k % 3 == 0 || k + 1 == columns)
                .collect();
            let alone = rows_by(&bytes, sep, &wanted, false);
            assert!(
                alone.len() > 2 * BATCH_LINES,
                "{file}: {} rows",
                alone.len()
            );
            assert!(
                alone.iter().all(|r| r.2.is_some()),
                "{file}: a row came without fields"
            );
            assert!(
                rows_by(&bytes, sep, &wanted, true) == alone,
                "{file}: rows differ on two threads"
            );
        }
    }

    proptest! {
        #[test]
        fn any_bytes_read_as_the_three_passes_read_them(
            bytes in proptest::collection::vec(
                prop_oneof![
                    Just(b','), Just(b'\t'), Just(b'\n'), Just(b'\r'), Just(b'"'), Just(b' '),
                    Just(0xC3u8), Just(0xA9u8), Just(0xFFu8), b'0'..=b'9'
                ],
                0..400,
            ),
            wanted in proptest::collection::vec(any::<bool>(), 0..12),
            stop in any::<bool>(),
            tab in any::<bool>(),
        ) {
            let sep = if tab { Separator::Tab } else { Separator::Comma };
            check(&bytes, sep, &wanted, stop);
        }
    }
}

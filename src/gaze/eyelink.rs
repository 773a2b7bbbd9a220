//! SR Research EyeLink ASC files (edf2asc / EDF Converter text, plain or gzipped) into the one
//! record model the SMI readers fill.
//!
//! An ASC file is a `**` preamble, then recording blocks from `START` to `END`. Each block's
//! `SAMPLES` line says which eyes the sample rows carry and in which order the optional
//! columns follow (`VEL`, `RES`, `INPUT`, `HTARGET` in remote mode) and whether positions are
//! screen gaze (`GAZE`) or head-referenced / raw camera values (`HREF`, `PUPIL`), which are
//! not pixels and are never read as such. Events are the tracker's own parser output (`EFIX`,
//! `ESACC`, `EBLINK`, each per eye); `MSG` lines are whatever the experiment logged, with an
//! optional integer offset that moves the logged time to the event's (`MSG 1000 -14 text`
//! happened at 1014). Times are milliseconds, with a `.5` at 2,000 Hz: both are exact as
//! integer µs. `.` marks a lost value.
//!
//! The screen is the gaze coordinate space of `GAZE_COORDS` (else `DISPLAY_COORDS`), whose
//! right and bottom bounds are the last pixel (`0 0 1023 767` is a 1024 × 768 screen), or the
//! size where a program wrote it so (`0 0 1920 1080`, see `pixels_across`).
//!
//! Trials: the lines of the n-th block, and those between its preceding `END` and its
//! `START` (where experiment programs log `TRIALID` and often the stimulus), are trial n.
use super::recording::{
    Event, EventKind, Eye, EyeSample, GazeError, GazeFormat, Header, Message, Recording,
    RowAccount, Sample,
};
use super::text::{decode, lines, plain_decimal};

/// Whether `bytes` (the file's start) is an EyeLink EDF binary rather than its ASC text.
pub(crate) fn looks_like_edf(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(4096)];
    let binary = head.iter().take(1024).any(|&b| b == 0);
    let text = String::from_utf8_lossy(head);
    binary && (text.contains("SR_RESEARCH") || text.contains("EDF_FILE"))
}

/// Whether `head` (the file's first lines) is an EyeLink ASC file.
pub(crate) fn looks_like(head: &str) -> bool {
    let mut keyed = 0;
    for line in head.lines().take(400) {
        let line = line.trim_end_matches('\r');
        if line.starts_with("** CONVERTED FROM") && line.contains("edf") {
            return true;
        }
        let key = line.split(['\t', ' ']).next().unwrap_or("");
        if matches!(
            key,
            "MSG" | "START" | "SAMPLES" | "EVENTS" | "SFIX" | "EFIX"
        ) {
            keyed += 1;
        }
    }
    keyed >= 2
}

/// What a block's `SAMPLES` line declares.
#[derive(Debug, Clone, PartialEq)]
struct SampleLayout {
    left: bool,
    right: bool,
    /// `GAZE`, `HREF` or `PUPIL`.
    kind: String,
    velocity: bool,
    resolution: bool,
    input: bool,
    /// Remote mode: target x, y and distance after the eyes.
    target: bool,
    rate_hz: Option<f64>,
}

impl SampleLayout {
    fn parse(fields: &[&str]) -> SampleLayout {
        let has = |w: &str| fields.contains(&w);
        let kind = ["GAZE", "HREF", "PUPIL"]
            .iter()
            .find(|k| has(k))
            .unwrap_or(&"GAZE")
            .to_string();
        let rate_hz = fields
            .iter()
            .position(|f| *f == "RATE")
            .and_then(|i| fields.get(i + 1))
            .and_then(|r| r.trim().parse().ok());
        SampleLayout {
            left: has("LEFT"),
            right: has("RIGHT"),
            kind,
            velocity: has("VEL"),
            resolution: has("RES"),
            input: has("INPUT"),
            target: has("HTARGET"),
            rate_hz,
        }
    }

    /// From the eyes of a `START` line, when no `SAMPLES` line came (edf2asc -ns -s files).
    fn from_start(fields: &[&str]) -> SampleLayout {
        SampleLayout {
            left: fields.contains(&"LEFT"),
            right: fields.contains(&"RIGHT"),
            kind: "GAZE".into(),
            velocity: false,
            resolution: false,
            input: false,
            target: false,
            rate_hz: None,
        }
    }

    fn eyes(&self) -> usize {
        self.left as usize + self.right as usize
    }

    /// Numeric fields of a sample row, time included.
    fn numeric_fields(&self) -> usize {
        let e = self.eyes();
        1 + 3 * e
            + if self.velocity { 2 * e } else { 0 }
            + if self.resolution { 2 } else { 0 }
            + self.input as usize
            + if self.target { 3 } else { 0 }
    }

    fn columns(&self) -> Vec<String> {
        let mut c = vec!["time".to_string()];
        for (on, eye) in [(self.left, "left"), (self.right, "right")] {
            if on {
                c.extend(["x", "y", "pupil"].map(|v| format!("{eye} {v}")));
            }
        }
        if self.velocity {
            for (on, eye) in [(self.left, "left"), (self.right, "right")] {
                if on {
                    c.extend(["x velocity", "y velocity"].map(|v| format!("{eye} {v}")));
                }
            }
        }
        if self.resolution {
            c.extend(["x resolution".into(), "y resolution".into()]);
        }
        if self.input {
            c.push("input".into());
        }
        if self.target {
            c.extend([
                "target x".into(),
                "target y".into(),
                "target distance".into(),
            ]);
        }
        c.push("flags".into());
        c
    }
}

/// An EyeLink time in ms (`2154556`, `2154556.5`) as exact integer µs.
fn time_us(field: &str) -> Option<i64> {
    let f = field.trim();
    let (int, frac) = match f.split_once('.') {
        Some((i, fr)) => (i, fr),
        None => (f, ""),
    };
    if int.is_empty() || !int.bytes().all(|b| b.is_ascii_digit()) || int.len() > 12 {
        return None;
    }
    if !frac.bytes().all(|b| b.is_ascii_digit()) || frac.len() > 3 {
        return None;
    }
    let mut us: i64 = int.parse::<i64>().ok()? * 1000;
    let mut scale = 100;
    for b in frac.bytes() {
        us += (b - b'0') as i64 * scale;
        scale /= 10;
    }
    Some(us)
}

/// A duration in ms (`828`, `132.5`) as µs.
fn duration_us(field: &str) -> Option<i64> {
    time_us(field)
}

/// A value that may be `.` (lost); Err when it is neither a number nor `.`.
fn value(field: &str) -> Result<Option<f64>, ()> {
    // Nearly every value is a bare decimal (the same f64 as the full parser gives it).
    if let Some(v) = plain_decimal(field) {
        return Ok(Some(v));
    }
    let f = field.trim();
    if f == "." || f.is_empty() {
        return Ok(None);
    }
    // `inf` and `NaN` parse as f64 but are no position EyeLink writes.
    match f.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(Some(v)),
        _ => Err(()),
    }
}

/// Whitespace-separated fields with their 1-based columns.
fn fields_of(line: &str) -> Vec<(usize, &str)> {
    whitespace_fields(line).collect()
}

/// The fields of [`fields_of`], one by one. Bytes, not chars, are walked: a space or TAB byte
/// is never part of a multi-byte character, so every cut is on a char boundary.
fn whitespace_fields(line: &str) -> impl Iterator<Item = (usize, &str)> {
    let bytes = line.as_bytes();
    let mut at = 0;
    std::iter::from_fn(move || {
        let gap = |b: &u8| *b == b' ' || *b == b'\t';
        let start = at + bytes[at..].iter().position(|b| !gap(b))?;
        let end = bytes[start..]
            .iter()
            .position(gap)
            .map_or(bytes.len(), |k| start + k);
        at = end;
        Some((start + 1, &line[start..end]))
    })
}

/// A sample line has at most this many value fields (time, 3 per eye, 2 velocities per eye,
/// resolution, input, 3 target values: 17); more are counted but not kept.
const MAX_SAMPLE_VALUES: usize = 24;

/// The screen's size along one axis from a `*_COORDS` pair. SR Research writes the last
/// pixel (`0 0 1023 767`: 1024 wide), while experiment programs that set
/// `screen_pixel_coords` themselves often write the size (`0 0 1920 1080`). Screens are an
/// even number of pixels across, so an odd span is the last-pixel form.
fn pixels_across(lo: f64, hi: f64) -> f64 {
    let span = hi - lo;
    if span.fract() == 0.0 && (span as i64) % 2 == 1 {
        span + 1.0
    } else {
        span
    }
}

/// A sample's flag field: EyeLink writes `.` or a letter per flag, so more than one
/// character and no digit (a lone `.` is a lost value).
fn is_flags(field: &str) -> bool {
    field.len() > 1 && !field.bytes().any(|b| b.is_ascii_digit())
}

fn eye_of(letter: &str) -> Option<Eye> {
    match letter {
        "L" => Some(Eye::Left),
        "R" => Some(Eye::Right),
        _ => None,
    }
}

/// The reader's state between lines.
struct Reader<'a> {
    path: &'a str,
    header: Header,
    rows: RowAccount,
    samples: Vec<Sample>,
    messages: Vec<Message>,
    events: Vec<Event>,
    notes: Vec<String>,
    layout: Option<SampleLayout>,
    /// `EVENTS` line's position kind (`GAZE`, `HREF`), for the block's event positions.
    event_kind: String,
    trial: u32,
    in_block: bool,
    block_start_us: Option<i64>,
    columns: Vec<String>,
    event_numbers: [u64; 2],
    events_before_start: usize,
    /// The `!CAL` report's continuation lines follow a `!CAL` message.
    in_calibration: bool,
    gaze_coords: Option<[f64; 2]>,
    display_coords: Option<[f64; 2]>,
}

impl<'a> Reader<'a> {
    fn new(path: &'a str, lines: usize) -> Reader<'a> {
        Reader {
            path,
            header: Header::default(),
            rows: RowAccount {
                lines,
                ..Default::default()
            },
            samples: Vec::new(),
            messages: Vec::new(),
            events: Vec::new(),
            notes: Vec::new(),
            layout: None,
            event_kind: "GAZE".into(),
            trial: 1,
            in_block: false,
            block_start_us: None,
            columns: Vec::new(),
            event_numbers: [0; 2],
            events_before_start: 0,
            in_calibration: false,
            gaze_coords: None,
            display_coords: None,
        }
    }

    fn line(&mut self, no: usize, line: &str) {
        if line.trim().is_empty() {
            self.rows.blank_lines += 1;
            return;
        }
        let first = line.as_bytes()[0];
        if first.is_ascii_digit() {
            self.in_calibration = false;
            self.sample(no, line);
            return;
        }
        if first == b' ' || first == b'\t' || line.starts_with(">>>>") {
            // The calibration report's continuation lines (coefficients, boxes).
            if self.in_calibration || line.starts_with(">>>>") {
                self.rows.header_lines += 1;
            } else {
                self.rows
                    .reject("indented line outside a calibration report", no, 1, line);
            }
            return;
        }
        let f = fields_of(line);
        let key = f[0].1;
        if key != "MSG" {
            self.in_calibration = false;
        }
        match key {
            "**" => self.preamble(line),
            "MSG" => self.message(no, line, &f),
            "START" => self.start(no, line, &f),
            "END" => {
                self.rows.header_lines += 1;
                self.in_block = false;
            }
            "SAMPLES" => {
                self.rows.header_lines += 1;
                let words: Vec<&str> = f.iter().map(|x| x.1).collect();
                let layout = SampleLayout::parse(&words);
                if layout.rate_hz.is_some() {
                    self.header.sample_rate_hz = layout.rate_hz;
                }
                self.note_layout(&layout);
                self.layout = Some(layout);
            }
            "EVENTS" => {
                self.rows.header_lines += 1;
                let words: Vec<&str> = f.iter().map(|x| x.1).collect();
                self.event_kind = SampleLayout::parse(&words).kind;
                if self.header.sample_rate_hz.is_none() {
                    self.header.sample_rate_hz = SampleLayout::parse(&words).rate_hz;
                }
            }
            "PRESCALER" | "VPRESCALER" | "PUPIL" => self.rows.header_lines += 1,
            "SFIX" | "SSACC" | "SBLINK" => self.rows.events += 1,
            "EFIX" | "ESACC" | "EBLINK" => self.event(no, line, &f),
            "INPUT" | "BUTTON" => self.input(no, line, &f),
            _ => self.rows.reject("line of an unknown kind", no, 1, line),
        }
    }

    fn preamble(&mut self, line: &str) {
        self.rows.header_lines += 1;
        let body = line.trim_start_matches('*').trim();
        if body.is_empty() {
            return;
        }
        if self.header.banner.is_none() && body.starts_with("CONVERTED FROM") {
            self.header.banner = Some(body.to_string());
        }
        if let Some((k, v)) = body.split_once(':') {
            let (k, v) = (k.trim(), v.trim());
            match k {
                "DATE" => {
                    let squeezed: String = v.split_whitespace().collect::<Vec<_>>().join(" ");
                    self.header.date =
                        chrono::NaiveDateTime::parse_from_str(&squeezed, "%a %b %d %H:%M:%S %Y")
                            .ok();
                }
                "VERSION" => self.header.version = Some(v.to_string()),
                _ => {}
            }
            self.header.entries.push((k.to_string(), v.to_string()));
        } else {
            self.header.entries.push((body.to_string(), String::new()));
        }
    }

    fn note_layout(&mut self, layout: &SampleLayout) {
        let columns = layout.columns();
        if self.columns.is_empty() {
            self.columns = columns;
        } else if self.columns != columns {
            let note = "blocks differ in their sample columns (eyes or optional columns); each block is read with its own SAMPLES line".to_string();
            if !self.notes.contains(&note) {
                self.notes.push(note);
            }
        }
        let mut items = vec![layout.kind.clone()];
        if layout.left {
            items.push("LEFT".into());
        }
        if layout.right {
            items.push("RIGHT".into());
        }
        for it in items {
            if !self.header.format_items.contains(&it) {
                self.header.format_items.push(it);
            }
        }
    }

    fn start(&mut self, no: usize, line: &str, f: &[(usize, &str)]) {
        let Some(t) = f.get(1).and_then(|x| time_us(x.1)) else {
            self.rows.reject(
                "START line without a time",
                no,
                f.get(1).map_or(1, |x| x.0),
                line,
            );
            return;
        };
        self.rows.header_lines += 1;
        self.in_block = true;
        self.block_start_us = Some(t);
        self.event_numbers = [0; 2];
        // A block's layout comes from its own SAMPLES line; until then, the START line's eyes.
        let words: Vec<&str> = f.iter().map(|x| x.1).collect();
        self.layout = Some(SampleLayout::from_start(&words));
    }

    /// Trial numbers: a block's END closes its trial; the lines up to the next START belong to
    /// the next trial, where TRIALID and stimulus messages usually stand.
    fn trial_of_line(&self) -> u32 {
        self.trial
    }

    fn message(&mut self, no: usize, line: &str, f: &[(usize, &str)]) {
        let Some(&(tcol, tfield)) = f.get(1) else {
            self.rows.reject("MSG line without a time", no, 1, line);
            return;
        };
        let Some(mut t) = time_us(tfield) else {
            self.rows
                .reject("MSG time is not a number of milliseconds", no, tcol, line);
            return;
        };
        // The text starts after the time field; a leading integer followed by more text is
        // Experiment Builder's offset (event time = logged time − offset).
        let after_time = &line[tcol - 1 + tfield.len()..];
        let mut text = after_time.trim_start_matches([' ', '\t']);
        if let Some((first, rest)) = text.split_once([' ', '\t']) {
            let is_offset = !rest.trim().is_empty()
                && first
                    .strip_prefix('-')
                    .unwrap_or(first)
                    .bytes()
                    .all(|b| b.is_ascii_digit())
                && !first.strip_prefix('-').unwrap_or(first).is_empty()
                && first.len() <= 9;
            if is_offset {
                if let Ok(offset_ms) = first.parse::<i64>() {
                    t -= offset_ms * 1000;
                    text = rest.trim_start_matches([' ', '\t']);
                }
            }
        }
        let text = text.trim_end().to_string();
        self.screen_from_message(&text);
        self.in_calibration = text.starts_with("!CAL");
        self.rows.messages += 1;
        self.messages.push(Message {
            time_us: t,
            trial: self.trial_of_line(),
            text,
        });
    }

    fn screen_from_message(&mut self, text: &str) {
        let coords = |rest: &str| -> Option<[f64; 2]> {
            let v: Vec<f64> = rest
                .split_whitespace()
                .map(|x| x.parse::<f64>())
                .collect::<Result<_, _>>()
                .ok()?;
            (v.len() == 4 && v[2] > v[0] && v[3] > v[1])
                .then(|| [pixels_across(v[0], v[2]), pixels_across(v[1], v[3])])
        };
        if let Some(rest) = text.strip_prefix("GAZE_COORDS") {
            self.gaze_coords = coords(rest).or(self.gaze_coords);
        } else if let Some(rest) = text.strip_prefix("DISPLAY_COORDS") {
            self.display_coords = coords(rest).or(self.display_coords);
        }
    }

    fn input(&mut self, no: usize, line: &str, f: &[(usize, &str)]) {
        let Some(t) = f.get(1).and_then(|x| time_us(x.1)) else {
            self.rows.reject(
                "INPUT/BUTTON line without a time",
                no,
                f.get(1).map_or(1, |x| x.0),
                line,
            );
            return;
        };
        let rest: Vec<&str> = f[2..].iter().map(|x| x.1).collect();
        self.rows.messages += 1;
        self.messages.push(Message {
            time_us: t,
            trial: self.trial_of_line(),
            text: format!("{} {}", f[0].1, rest.join(" "))
                .trim_end()
                .to_string(),
        });
    }

    fn sample(&mut self, no: usize, line: &str) {
        let Some(layout) = self.layout.as_ref() else {
            self.rows
                .reject("sample before any START or SAMPLES line", no, 1, line);
            return;
        };
        if layout.kind != "GAZE" {
            let reason = format!(
                "{} sample: {} values are not screen pixels (convert the EDF with `edf2asc -sg` for gaze positions)",
                layout.kind,
                if layout.kind == "HREF" { "head-referenced" } else { "raw pupil-camera" }
            );
            self.rows.reject(&reason, no, 1, line);
            return;
        }
        let (left, right, n) = (layout.left, layout.right, layout.numeric_fields());
        // Flag columns (`...`, `.....`, remote mode's 13 characters before or after the
        // target columns) are told from values by having no digit and more than one character.
        // A million samples are read without allocating: the values go to an array.
        let mut kept = [(0usize, ""); MAX_SAMPLE_VALUES];
        let (mut values, mut flags) = (0usize, 0usize);
        for (col, v) in whitespace_fields(line) {
            if is_flags(v) {
                flags += 1;
            } else {
                if let Some(slot) = kept.get_mut(values) {
                    *slot = (col, v);
                }
                values += 1;
            }
        }
        if values != n || flags > 2 {
            let reason = format!(
                "sample with {values} values and {flags} flag fields where the block's SAMPLES line gives {n} values"
            );
            self.rows.reject(&reason, no, 1, line);
            return;
        }
        let f = &kept[..n];
        let Some(t) = time_us(f[0].1) else {
            self.rows
                .reject("sample time is not a number of milliseconds", no, 1, line);
            return;
        };
        let mut eyes = [None, None];
        let mut i = 1;
        for (slot, on) in [(0, left), (1, right)] {
            if !on {
                continue;
            }
            let parsed = (value(f[i].1), value(f[i + 1].1), value(f[i + 2].1));
            let (x, y, p) = match parsed {
                (Ok(x), Ok(y), Ok(p)) => (x, y, p),
                _ => {
                    let bad = [i, i + 1, i + 2]
                        .into_iter()
                        .find(|&k| value(f[k].1).is_err())
                        .unwrap_or(i);
                    self.rows.reject(
                        "sample value is neither a number nor `.`",
                        no,
                        f[bad].0,
                        line,
                    );
                    return;
                }
            };
            eyes[slot] = Some(match (x, y) {
                (Some(x), Some(y)) => EyeSample {
                    x,
                    y,
                    pupil: p.filter(|p| *p > 0.0),
                    valid: true,
                    flag_lost: false,
                },
                _ => EyeSample {
                    x: 0.0,
                    y: 0.0,
                    pupil: None,
                    valid: false,
                    flag_lost: true,
                },
            });
            i += 3;
        }
        if let Some((col, _)) = f[i..n].iter().find(|(_, v)| value(v).is_err()) {
            self.rows
                .reject("sample value is neither a number nor `.`", no, *col, line);
            return;
        }
        self.rows.samples += 1;
        self.samples.push(Sample {
            time_us: t,
            trial: self.trial_of_line(),
            left: eyes[0],
            right: eyes[1],
            binocular: None,
            binocular_event: None,
            left_event: None,
            right_event: None,
            stimulus: None,
        });
    }

    fn event(&mut self, no: usize, line: &str, f: &[(usize, &str)]) {
        let key = f[0].1;
        let (kind, needed) = match key {
            "EFIX" => (EventKind::Fixation, 8),
            "ESACC" => (EventKind::Saccade, 11),
            _ => (EventKind::Blink, 5),
        };
        let Some(eye) = f.get(1).and_then(|x| eye_of(x.1)) else {
            let col = f.get(1).map_or(1, |x| x.0);
            self.rows
                .reject(&format!("{key} without an eye (L or R)"), no, col, line);
            return;
        };
        if f.len() < needed {
            let reason = format!("{key} with fewer than its {} values", needed - 2);
            self.rows.reject(&reason, no, 1, line);
            return;
        }
        let (Some(start), Some(end), Some(duration)) =
            (time_us(f[2].1), time_us(f[3].1), duration_us(f[4].1))
        else {
            let bad = (2..5).find(|&k| time_us(f[k].1).is_none()).unwrap_or(2);
            self.rows.reject(
                &format!("{key} time is not a number of milliseconds"),
                no,
                f[bad].0,
                line,
            );
            return;
        };
        if end < start {
            self.rows
                .reject(&format!("{key} ends before it starts"), no, f[3].0, line);
            return;
        }
        let values: Result<Vec<Option<f64>>, ()> =
            f[5..needed].iter().map(|x| value(x.1)).collect();
        let Ok(v) = values else {
            let bad = (5..needed).find(|&k| value(f[k].1).is_err()).unwrap_or(5);
            self.rows.reject(
                &format!("{key} value is neither a number nor `.`"),
                no,
                f[bad].0,
                line,
            );
            return;
        };
        if kind != EventKind::Blink && self.event_kind != "GAZE" {
            let reason = format!(
                "{key} position in {} units, not screen pixels (convert the EDF with `edf2asc` for gaze events)",
                self.event_kind
            );
            self.rows.reject(&reason, no, 1, line);
            return;
        }
        if self.block_start_us.is_some_and(|s| start < s) || !self.in_block {
            self.events_before_start += 1;
        }
        let slot = (eye == Eye::Right) as usize;
        self.event_numbers[slot] += 1;
        let (x, y, end_x, end_y, pupil) = match kind {
            EventKind::Fixation => (v[0], v[1], None, None, v[2]),
            EventKind::Saccade => (v[0], v[1], v[2], v[3], None),
            EventKind::Blink => (None, None, None, None, None),
        };
        self.rows.events += 1;
        self.events.push(Event {
            trial: self.trial_of_line(),
            x,
            y,
            end_x,
            end_y,
            pupil_x: pupil,
            ..Event::span(kind, eye, self.event_numbers[slot], start, end, duration)
        });
    }

    fn finish(mut self) -> Recording {
        self.header.calibration_area_px = self.gaze_coords.or(self.display_coords);
        if self.events_before_start > 0 {
            self.notes.push(format!(
                "{} events began before their block's START (the tracker parsed them from data before recording); kept with the start time the file gives",
                self.events_before_start
            ));
        }
        if self.header.calibration_area_px.is_none() {
            self.notes.push(
                "no GAZE_COORDS or DISPLAY_COORDS message: the screen size is not in the file"
                    .into(),
            );
        }
        Recording {
            file: self.path.to_string(),
            format: GazeFormat::EyelinkAsc,
            header: self.header,
            columns: self.columns,
            samples: self.samples,
            messages: self.messages,
            events: self.events,
            rows: self.rows,
            notes: self.notes,
        }
    }
}

/// Reads an EyeLink ASC file's bytes; `path` names it in messages.
pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    if looks_like_edf(bytes) {
        return Err(GazeError::File {
            path: path.to_string(),
            message: edf_refusal(),
        });
    }
    let text = decode(bytes);
    let all = lines(&text);
    let mut r = Reader::new(path, all.len());
    let mut ended = 0usize;
    for &(no, line) in &all {
        let was_in_block = r.in_block;
        r.line(no, line);
        if was_in_block && !r.in_block {
            ended += 1;
            r.trial = ended as u32 + 1;
        }
    }
    let not_gaze = r
        .rows
        .unusable
        .iter()
        .find(|(k, _)| k.starts_with("HREF sample") || k.starts_with("PUPIL sample"))
        .map(|(k, f)| format!("{k} ({} lines, the first at line {})", f.count, f.line));
    let first_unusable = r
        .rows
        .unusable
        .iter()
        .min_by_key(|(_, f)| f.line)
        .map(|(k, f)| {
            format!(
                "{k} ({} lines, the first at line {}: `{}`)",
                f.count, f.line, f.example
            )
        });
    let rec = r.finish();
    let has_fixations = rec.events.iter().any(|e| e.kind == EventKind::Fixation);
    if rec.samples.is_empty() && !has_fixations {
        if let Some(reason) = not_gaze {
            return Err(GazeError::File {
                path: path.to_string(),
                message: format!("no screen positions in this file: every {reason}"),
            });
        }
        if rec.messages.is_empty() && rec.events.is_empty() {
            return Err(GazeError::File {
                path: path.to_string(),
                message: match first_unusable {
                    Some(why) => format!(
                        "an EyeLink ASC file with no usable sample, event or message: {why}"
                    ),
                    None => "an EyeLink ASC file without samples, events or messages".into(),
                },
            });
        }
    }
    Ok(rec)
}

/// Why an EDF binary is not read, and how to get the ASC text that is.
pub(crate) fn edf_refusal() -> String {
    "an EyeLink EDF binary: meshgaze reads its ASC text. Convert it with SR Research's `edf2asc FILE.edf` (EyeLink Developers Kit) or EDF Converter, then give the .asc (gzip allowed)".into()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn times_are_exact_microseconds() {
        assert_eq!(time_us("2154556"), Some(2_154_556_000));
        assert_eq!(time_us("2154556.5"), Some(2_154_556_500));
        assert_eq!(time_us("1.25"), Some(1_250));
        assert_eq!(time_us("-1"), None);
        assert_eq!(time_us("1.2345"), None);
        assert_eq!(time_us("."), None);
    }

    #[test]
    fn a_message_offset_moves_the_time_to_the_event() {
        let asc = "MSG\t1000 -14 Target_display\nMSG\t2000 0 key\nMSG\t3000 12 apples and pears\nMSG\t4000 TRIALID 3\n";
        let r = read(asc.as_bytes(), "t.asc").unwrap();
        let got: Vec<(i64, &str)> = r
            .messages
            .iter()
            .map(|m| (m.time_us, m.text.as_str()))
            .collect();
        assert_eq!(
            got,
            vec![
                (1_014_000, "Target_display"),
                (2_000_000, "key"),
                (2_988_000, "apples and pears"),
                (4_000_000, "TRIALID 3"),
            ]
        );
    }

    #[test]
    fn samples_follow_their_blocks_layout() {
        let asc = "MSG\t1 GAZE_COORDS 0.00 0.00 1023.00 767.00\nSTART\t10 \tLEFT\tRIGHT\tSAMPLES\tEVENTS\nSAMPLES\tGAZE\tLEFT\tRIGHT\tRATE\t 250.00\tTRACKING\tCR\tFILTER\t2\n10\t  1.0\t  2.0\t 3.0\t   .\t   .\t 0.0\t.....\nEND\t11 \tSAMPLES\tEVENTS\nSTART\t20 \tLEFT\tSAMPLES\tEVENTS\nSAMPLES\tGAZE\tLEFT\tHTARGET\tRATE\t 250.00\n20\t  5.0\t  6.0\t 7.0\t... \t 4717.0\t 2908.0\t  611.2 .............\nEND\t21\n";
        let r = read(asc.as_bytes(), "t.asc").unwrap();
        assert_eq!(r.rows.samples, 2, "{:?}", r.rows.unusable);
        assert_eq!(r.rows.accounted(), r.rows.lines);
        let s0 = &r.samples[0];
        assert_eq!((s0.left.unwrap().x, s0.left.unwrap().y), (1.0, 2.0));
        assert!(!s0.right.unwrap().valid);
        assert_eq!(r.samples[1].trial, 2);
        assert_eq!(r.samples[1].left.unwrap().x, 5.0);
        assert_eq!(r.header.calibration_area_px, Some([1024.0, 768.0]));
        assert_eq!(r.header.sample_rate_hz, Some(250.0));
    }

    #[test]
    fn href_samples_are_never_pixels() {
        let asc = "START\t10 \tLEFT\tSAMPLES\tEVENTS\nSAMPLES\tHREF\tLEFT\tRATE\t 500.00\n10\t  -1200.0\t  340.0\t 3.0\t...\n";
        let e = read(asc.as_bytes(), "h.asc").unwrap_err().to_string();
        assert!(e.contains("HREF") && e.contains("not screen pixels"), "{e}");
    }

    #[test]
    fn an_edf_binary_says_how_to_convert_it() {
        let mut bytes = b"SR_RESEARCH_COMPANY\n".to_vec();
        bytes.extend([0u8, 1, 2, 3]);
        let e = read(&bytes, "x.edf").unwrap_err().to_string();
        assert!(e.contains("edf2asc"), "{e}");
    }
}

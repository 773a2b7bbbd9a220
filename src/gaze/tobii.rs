//! Tobii gaze-data exports into the one record model: the Pro Lab data export (TSV or CSV,
//! `Recording timestamp`, `Gaze point X`, `Eye movement type`) and the Tobii Studio data
//! export (`RecordingTimestamp`, `GazePointX (ADCSpx)`, `GazeEventType`; BOM, CRLF and a
//! trailing TAB on every line as Studio writes them).
//!
//! Both are one row per time stamp: a gaze sample of the eye tracker, a row of another sensor
//! (Pro Lab's `Mouse`, counted and set aside), or an event row (`Event` / `StudioEvent`, read as
//! a message `VideoStimulusStart B3 - Trim`). The tracker's fixation filter (Tobii I-VT) labels
//! each sample with its eye movement and that movement's index: the rows of one fixation index
//! become one fixation event at the filter's fixation point, starting at its first row and
//! lasting `Gaze event duration`. Fixations are binocular (Tobii averages the eyes).
//!
//! The stimulus comes from the rows' own columns (Pro Lab's `Presented Media name`, else
//! `Presented Stimulus name`; Studio's `MediaName`), and its onset from the `…StimulusStart` /
//! `…Start` event naming it, else its first row: an export names the stimulus of every row,
//! so no message has to be matched.
//!
//! Times: Pro Lab's unit is in the column name (`Recording timestamp [μs]`), or else found
//! from `Recording duration` (ms) or the sample interval; Studio's is ms. Positions are
//! display pixels (Pro Lab's DACSpx, Studio's ADCSpx; Studio's fixation point is in media
//! coordinates and is moved by the media's position). The screen is `Recording resolution`.
use std::collections::BTreeMap;
use std::sync::Arc;

use super::recording::{
    Event, EventKind, Eye, EyeSample, GazeError, GazeFormat, Header, Message, Recording,
    RowAccount, Sample, SharedLabels, SharedNames,
};
use super::table_scan::{body_lines, first_line, for_each_row, lines_estimate, Row};
use super::text::{number, plain_decimal, split_into, trimmed, Separator};

/// Which Tobii exporter wrote the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Dialect {
    ProLab,
    Studio,
}

/// Whether the first line is a Tobii Pro Lab or Studio data export's header.
pub(crate) fn looks_like(first_line: &str) -> bool {
    dialect_of(first_line).is_some()
}

fn dialect_of(first_line: &str) -> Option<Dialect> {
    let f = first_line.trim_start_matches('\u{feff}');
    if f.contains("Recording timestamp") && f.contains("Gaze point X") {
        Some(Dialect::ProLab)
    } else if f.contains("RecordingTimestamp") && f.contains("GazePointX") {
        Some(Dialect::Studio)
    } else {
        None
    }
}

/// The columns a reader uses, by index.
struct Columns {
    time: usize,
    sensor: Option<usize>,
    event: Option<usize>,
    event_value: Option<usize>,
    gaze: Option<[usize; 2]>,
    left: Option<[usize; 2]>,
    right: Option<[usize; 2]>,
    validity: [Option<usize>; 2],
    pupil: [Option<usize>; 2],
    movement: Option<usize>,
    movement_index: Option<usize>,
    duration: Option<usize>,
    fixation: Option<[usize; 2]>,
    media_pos: Option<[usize; 2]>,
    stimulus: Vec<usize>,
    participant: Option<usize>,
    screen: Option<[usize; 2]>,
    screen_text: Option<usize>,
    recording_duration: Option<usize>,
}

impl Columns {
    /// Which of `n` columns the reader looks at (Studio's trailing TAB, an empty field past
    /// the last column, is checked as the row's last field).
    fn wanted(&self, n: usize) -> Vec<bool> {
        let pairs = [
            self.gaze,
            self.left,
            self.right,
            self.fixation,
            self.media_pos,
            self.screen,
        ];
        let singles = [
            Some(self.time),
            self.sensor,
            self.event,
            self.event_value,
            self.validity[0],
            self.validity[1],
            self.pupil[0],
            self.pupil[1],
            self.movement,
            self.movement_index,
            self.duration,
            self.participant,
            self.screen_text,
            self.recording_duration,
        ];
        let mut wanted = vec![false; n];
        let used = pairs
            .into_iter()
            .flatten()
            .flatten()
            .chain(singles.into_iter().flatten())
            .chain(self.stimulus.iter().copied());
        for i in used.filter(|&i| i < n) {
            wanted[i] = true;
        }
        wanted
    }
}

/// The column called `name`, or `name [unit]` / `name (unit)`.
fn find(names: &[String], name: &str) -> Option<usize> {
    names.iter().position(|c| {
        c == name
            || c.strip_prefix(name)
                .is_some_and(|rest| rest.starts_with(" [") || rest.starts_with(" ("))
    })
}

fn pair(names: &[String], x: &str, y: &str) -> Option<[usize; 2]> {
    Some([find(names, x)?, find(names, y)?])
}

fn columns_of(names: &[String], dialect: Dialect, path: &str) -> Result<Columns, GazeError> {
    let need = |n: &str| {
        find(names, n).ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: format!(
                "a Tobii export without the `{n}` column: the time of each row is needed"
            ),
        })
    };
    Ok(match dialect {
        Dialect::ProLab => Columns {
            time: need("Recording timestamp")?,
            sensor: find(names, "Sensor"),
            event: find(names, "Event"),
            event_value: find(names, "Event value"),
            gaze: pair(names, "Gaze point X", "Gaze point Y"),
            left: pair(names, "Gaze point left X", "Gaze point left Y"),
            right: pair(names, "Gaze point right X", "Gaze point right Y"),
            validity: [find(names, "Validity left"), find(names, "Validity right")],
            pupil: [
                find(names, "Pupil diameter left"),
                find(names, "Pupil diameter right"),
            ],
            movement: find(names, "Eye movement type"),
            movement_index: find(names, "Eye movement type index"),
            duration: find(names, "Gaze event duration"),
            fixation: pair(names, "Fixation point X", "Fixation point Y"),
            media_pos: None,
            stimulus: ["Presented Media name", "Presented Stimulus name"]
                .iter()
                .filter_map(|n| find(names, n))
                .collect(),
            participant: find(names, "Participant name"),
            screen: pair(
                names,
                "Recording resolution width",
                "Recording resolution height",
            ),
            screen_text: None,
            recording_duration: find(names, "Recording duration"),
        },
        Dialect::Studio => Columns {
            time: need("RecordingTimestamp")?,
            sensor: None,
            event: find(names, "StudioEvent"),
            event_value: find(names, "StudioEventData"),
            gaze: pair(names, "GazePointX (ADCSpx)", "GazePointY (ADCSpx)"),
            left: pair(names, "GazePointLeftX (ADCSpx)", "GazePointLeftY (ADCSpx)"),
            right: pair(
                names,
                "GazePointRightX (ADCSpx)",
                "GazePointRightY (ADCSpx)",
            ),
            validity: [find(names, "ValidityLeft"), find(names, "ValidityRight")],
            pupil: [find(names, "PupilLeft"), find(names, "PupilRight")],
            movement: find(names, "GazeEventType"),
            movement_index: find(names, "FixationIndex"),
            duration: find(names, "GazeEventDuration"),
            fixation: pair(names, "FixationPointX (MCSpx)", "FixationPointY (MCSpx)"),
            media_pos: pair(names, "MediaPosX (ADCSpx)", "MediaPosY (ADCSpx)"),
            stimulus: find(names, "MediaName").into_iter().collect(),
            participant: find(names, "ParticipantName"),
            screen: None,
            screen_text: find(names, "RecordingResolution"),
            recording_duration: find(names, "RecordingDuration"),
        },
    })
}

/// Fields of a line; a CSV field in double quotes may hold the separator.
fn fields(line: &str, sep: Separator) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    fields_into(line, sep, &mut out);
    out
}

/// [`fields`] into a buffer kept across rows.
fn fields_into<'a>(line: &'a str, sep: Separator, out: &mut Vec<(usize, &'a str)>) {
    if sep != Separator::Comma || !line.contains('"') {
        return split_into(line, sep, out);
    }
    out.clear();
    let bytes = line.as_bytes();
    let (mut i, mut start, mut quoted) = (0, 0, false);
    while i <= bytes.len() {
        let at_end = i == bytes.len();
        if !at_end && bytes[i] == b'"' {
            quoted = !quoted;
        } else if at_end || (bytes[i] == b',' && !quoted) {
            let f = &line[start..i];
            let f = f
                .strip_prefix('"')
                .and_then(|f| f.strip_suffix('"'))
                .unwrap_or(f);
            out.push((start + 1, f));
            start = i + 1;
        }
        i += 1;
    }
}

/// A row's time stamp, in the file's unit.
fn raw_time(field: &str) -> Option<f64> {
    // Nearly every time stamp is a bare decimal, read without the general parser.
    if let Some(v) = plain_decimal(field) {
        return (v.is_finite() && v >= 0.0).then_some(v);
    }
    let f = field.trim();
    let v: f64 = match f.parse() {
        Ok(v) => v,
        Err(_) if f.contains(',') => f.replace(',', ".").parse().ok()?,
        Err(_) => return None,
    };
    (v.is_finite() && v >= 0.0).then_some(v)
}

/// A fixation being collected from its rows.
struct OpenFixation {
    index: String,
    start_us: i64,
    last_us: i64,
    duration_us: Option<i64>,
    x: Option<f64>,
    y: Option<f64>,
    sum: (f64, f64, usize),
    stimulus: Option<Arc<str>>,
}

struct Reader<'a> {
    path: &'a str,
    dialect: Dialect,
    sep: Separator,
    names: Vec<String>,
    c: Columns,
    /// µs per unit of the time column.
    scale: f64,
    rows: RowAccount,
    header: Header,
    samples: Vec<Sample>,
    messages: Vec<Message>,
    fixations: Vec<OpenFixation>,
    /// First time each stimulus is named, and the start events naming it.
    first_named: BTreeMap<String, i64>,
    /// The stimulus copy of the last row that named one (already in `first_named`).
    last_named: Option<Arc<str>>,
    start_events: BTreeMap<String, i64>,
    other_sensors: BTreeMap<String, usize>,
    names_seen: SharedNames,
    labels: SharedLabels,
}

impl Reader<'_> {
    fn get<'b>(&self, f: &[(usize, &'b str)], i: Option<usize>) -> Option<&'b str> {
        i.and_then(|i| f.get(i))
            .map(|x| trimmed(x.1))
            .filter(|v| !v.is_empty())
    }

    fn num(&self, f: &[(usize, &str)], i: Option<usize>) -> Result<Option<f64>, usize> {
        match i {
            Some(i) if i < f.len() => number(f[i].1, self.sep).map_err(|_| i),
            _ => Ok(None),
        }
    }

    fn point(
        &self,
        f: &[(usize, &str)],
        p: Option<[usize; 2]>,
    ) -> Result<Option<(f64, f64)>, usize> {
        let Some([x, y]) = p else { return Ok(None) };
        Ok(match (self.num(f, Some(x))?, self.num(f, Some(y))?) {
            (Some(x), Some(y)) => Some((x, y)),
            _ => None,
        })
    }

    fn eye(&self, f: &[(usize, &str)], slot: usize) -> Result<Option<EyeSample>, usize> {
        let p = if slot == 0 { self.c.left } else { self.c.right };
        if p.is_none() {
            return Ok(None);
        }
        let pos = self.point(f, p)?;
        let flag = self.get(f, self.c.validity[slot]);
        let flag_lost = match (self.dialect, flag) {
            (Dialect::ProLab, Some(v)) => v != "Valid",
            // Studio: 0 certain … 4 eye not found; 0 and 1 are what Tobii calls valid.
            (Dialect::Studio, Some(v)) => v.parse::<u8>().map_or(true, |code| code > 1),
            (_, None) => pos.is_none(),
        };
        let pupil = self.num(f, self.c.pupil[slot])?.filter(|p| *p > 0.0);
        Ok(Some(match pos {
            Some((x, y)) => EyeSample {
                x,
                y,
                pupil,
                valid: !flag_lost,
                flag_lost,
            },
            None => EyeSample {
                x: 0.0,
                y: 0.0,
                pupil: None,
                valid: false,
                flag_lost: true,
            },
        }))
    }

    fn row(&mut self, row: Row<'_>) {
        let (no, line) = (row.no, row.line);
        if line.trim().is_empty() {
            self.rows.blank_lines += 1;
            return;
        }
        // A quoted CSV field may hold a comma: such a line is split field by field.
        let mut quoted_fields = Vec::new();
        let (f, count, last) = match row.fields {
            Some(f) => (&f[..row.count.min(f.len())], row.count, row.last),
            None => {
                fields_into(line, self.sep, &mut quoted_fields);
                let last = quoted_fields.last().map_or("", |x| x.1);
                (&quoted_fields[..], quoted_fields.len(), last)
            }
        };
        let n = self.names.len();
        // Studio ends lines with a TAB (an empty last column): one field more or fewer is that.
        let ok_len = count == n
            || (count == n + 1 && last.trim().is_empty())
            || (count + 1 == n && self.names[n - 1].is_empty());
        if !ok_len {
            let reason = format!("row with a field count other than the header's {n}");
            self.rows.reject(&reason, no, 1, line);
            return;
        }
        let Some(t) = f.get(self.c.time).and_then(|x| raw_time(x.1)) else {
            let col = f.get(self.c.time).map_or(1, |x| x.0);
            let reason = format!("`{}` is not a time", self.names[self.c.time]);
            self.rows.reject(&reason, no, col, line);
            return;
        };
        let t_us = (t * self.scale).round() as i64;
        if self.header.subject.is_none() {
            self.header.subject = self.get(f, self.c.participant).map(str::to_string);
        }
        self.screen_of(f);
        let stimulus = self.stimulus_of(f);
        if let Some(s) = &stimulus {
            // Consecutive rows share one copy of their name (SharedNames): a row naming the
            // previous row's copy has nothing new for the map, whose lookup would compare
            // strings on each of a million rows.
            let same_as_before = self
                .last_named
                .as_ref()
                .is_some_and(|last| Arc::ptr_eq(last, s));
            if !same_as_before {
                if !self.first_named.contains_key(&**s) {
                    self.first_named.insert(s.to_string(), t_us);
                }
                self.last_named = Some(s.clone());
            }
        }
        let event = self.get(f, self.c.event).map(str::to_string);
        if let Some(ev) = &event {
            let value = self.get(f, self.c.event_value).unwrap_or("");
            if ev.ends_with("Start") && !value.is_empty() {
                self.start_events.entry(value.to_string()).or_insert(t_us);
            }
            self.messages.push(Message {
                time_us: t_us,
                trial: 1,
                text: format!("{ev} {value}").trim_end().to_string(),
            });
        }
        let sensor = self.get(f, self.c.sensor);
        // Pro Lab says which sensor a row is from; Studio's rows are gaze unless they carry
        // only an event.
        let gaze_row = match (self.c.sensor.is_some(), sensor) {
            (true, Some("Eye Tracker")) => true,
            (true, Some(other)) => {
                match self.other_sensors.get_mut(other) {
                    Some(count) => *count += 1,
                    None => {
                        self.other_sensors.insert(other.to_string(), 1);
                    }
                }
                if event.is_none() {
                    let reason = format!("a `{other}` sensor row (not gaze)");
                    self.rows.reject(&reason, no, 1, line);
                    return;
                }
                false
            }
            (true, None) => false,
            (false, _) => event.is_none() || self.has_gaze(f),
        };
        if !gaze_row {
            if event.is_some() {
                self.rows.messages += 1;
            } else {
                self.rows
                    .reject("row with neither a sensor nor an event", no, 1, line);
            }
            return;
        }
        // A gaze row: a sample (its event, when it has one, is a message as well).
        match self.sample(f, t_us, stimulus) {
            Ok(()) => self.rows.samples += 1,
            Err(i) => {
                let reason = format!("`{}` is not a number", self.names[i]);
                self.rows.reject(&reason, no, f[i].0, line);
            }
        }
    }

    fn has_gaze(&self, f: &[(usize, &str)]) -> bool {
        [self.c.gaze, self.c.left, self.c.right]
            .into_iter()
            .flatten()
            .any(|[x, _]| self.get(f, Some(x)).is_some())
    }

    fn stimulus_of(&mut self, f: &[(usize, &str)]) -> Option<Arc<str>> {
        let text = self.c.stimulus.iter().find_map(|&i| self.get(f, Some(i)))?;
        Some(self.names_seen.of(text))
    }

    fn screen_of(&mut self, f: &[(usize, &str)]) {
        if self.header.calibration_area_px.is_some() {
            return;
        }
        if let Some([w, h]) = self.c.screen {
            if let (Ok(Some(w)), Ok(Some(h))) = (self.num(f, Some(w)), self.num(f, Some(h))) {
                self.header.calibration_area_px = (w > 0.0 && h > 0.0).then_some([w, h]);
            }
        }
        if let Some(text) = self.get(f, self.c.screen_text) {
            let v: Vec<f64> = text
                .split('x')
                .filter_map(|p| p.trim().parse().ok())
                .collect();
            if v.len() == 2 && v[0] > 0.0 && v[1] > 0.0 {
                self.header.calibration_area_px = Some([v[0], v[1]]);
            }
        }
    }

    fn sample(
        &mut self,
        f: &[(usize, &str)],
        t_us: i64,
        stimulus: Option<Arc<str>>,
    ) -> Result<(), usize> {
        let left = self.eye(f, 0)?;
        let right = self.eye(f, 1)?;
        let both = self.point(f, self.c.gaze)?;
        let binocular = both.map(|(x, y)| EyeSample {
            x,
            y,
            pupil: None,
            valid: left.is_some_and(|e| e.valid) || right.is_some_and(|e| e.valid),
            flag_lost: false,
        });
        let fixation_point = self.point(f, self.c.fixation)?;
        let media_pos = self.point(f, self.c.media_pos)?;
        let duration = self.num(f, self.c.duration)?;
        let movement = self.get(f, self.c.movement);
        let index = self.get(f, self.c.movement_index);
        if movement == Some("Fixation") {
            if let Some(index) = index {
                let point = fixation_point.map(|(x, y)| match media_pos {
                    Some((mx, my)) => (x + mx, y + my),
                    None => (x, y),
                });
                self.fixation_row(index, t_us, duration, point, binocular, stimulus.clone());
            }
        }
        self.samples.push(Sample {
            time_us: t_us,
            trial: 1,
            left,
            right,
            binocular,
            binocular_event: movement.map(|m| self.labels.of(m)),
            left_event: None,
            right_event: None,
            stimulus,
        });
        Ok(())
    }

    fn fixation_row(
        &mut self,
        index: &str,
        t_us: i64,
        duration_ms: Option<f64>,
        point: Option<(f64, f64)>,
        gaze: Option<EyeSample>,
        stimulus: Option<Arc<str>>,
    ) {
        let continues = self.fixations.last().is_some_and(|f| f.index == index);
        if !continues {
            self.fixations.push(OpenFixation {
                index: index.to_string(),
                start_us: t_us,
                last_us: t_us,
                duration_us: duration_ms.map(|d| (d * 1000.0).round() as i64),
                x: point.map(|p| p.0),
                y: point.map(|p| p.1),
                sum: (0.0, 0.0, 0),
                stimulus,
            });
        }
        let open = self.fixations.last_mut().expect("just pushed or continued");
        open.last_us = t_us;
        if let Some(g) = gaze.filter(|g| g.valid) {
            open.sum = (open.sum.0 + g.x, open.sum.1 + g.y, open.sum.2 + 1);
        }
    }

    /// The time unit when the column does not name it: against the recording's length in
    /// ms where the file gives it, else from the sample interval (1–40 ms at 25–1,200 Hz).
    fn infer_scale(
        names: &[String],
        c: &Columns,
        body: &[u8],
        sep: Separator,
        dialect: Dialect,
    ) -> (f64, String) {
        let name = &names[c.time];
        if name.contains("[μs]") || name.contains("[µs]") || name.contains("[us]") {
            return (1.0, "µs (from the column name)".into());
        }
        if name.contains("[ms]") {
            return (1000.0, "ms (from the column name)".into());
        }
        if dialect == Dialect::Studio {
            return (1000.0, "ms (Tobii Studio's unit)".into());
        }
        let time_of = |l: &str| fields(l, sep).get(c.time).and_then(|x| raw_time(x.1));
        let times: Vec<f64> = body_lines(body)
            .take(5000)
            .filter_map(|l| time_of(&l))
            .collect();
        // The whole file's span: its first and its last row with a time.
        let first = body_lines(body).find_map(|l| time_of(&l));
        let last = body_lines(body).rev().find_map(|l| time_of(&l));
        let span = match (first, last) {
            (Some(a), Some(b)) => b - a,
            _ => 0.0,
        };
        let duration_ms = c.recording_duration.and_then(|i| {
            body_lines(body).find_map(|l| {
                fields(&l, sep)
                    .get(i)
                    .and_then(|x| number(x.1, sep).ok().flatten())
            })
        });
        if let Some(d) = duration_ms.filter(|d| *d > 0.0 && span > 0.0) {
            // In ms the rows span about the recording's length; in µs a thousand times it.
            let unit = if span > 20.0 * d {
                (1.0, "µs")
            } else {
                (1000.0, "ms")
            };
            return (
                unit.0,
                format!(
                    "{} (the rows span {span:.0} units of a {d:.0} ms recording)",
                    unit.1
                ),
            );
        }
        let mut deltas: Vec<f64> = times
            .windows(2)
            .map(|w| w[1] - w[0])
            .filter(|d| *d > 0.0)
            .collect();
        deltas.sort_by(f64::total_cmp);
        match deltas.get(deltas.len() / 2) {
            Some(&d) if d > 200.0 => (1.0, format!("µs (median interval {d:.0} units)")),
            Some(&d) => (1000.0, format!("ms (median interval {d:.3} units)")),
            None => (
                1000.0,
                "ms (too few rows to tell; Pro Lab's default)".into(),
            ),
        }
    }

    fn finish(self, time_note: String) -> Recording {
        let onset_of = |name: &str, first: i64| -> i64 {
            let stem = name.rsplit_once('.').map_or(name, |(s, _)| s);
            self.start_events
                .get(name)
                .or_else(|| self.start_events.get(stem))
                .copied()
                .unwrap_or(first)
        };
        // A start event names the stimulus without its extension (`VideoStimulusStart B3 -
        // Trim`); its message is the media file the rows name (`B3 - Trim.mp4`), so the
        // stimulus-message rules see the onset, as they do in the other formats.
        let media_by_stem: BTreeMap<&str, &str> = self
            .first_named
            .keys()
            .filter_map(|m| Some((m.rsplit_once('.')?.0, m.as_str())))
            .collect();
        let mut messages = self.messages.clone();
        let mut renamed = 0;
        for m in &mut messages {
            if let Some((ev, value)) = m.text.split_once(' ') {
                if let (true, Some(media)) = (ev.ends_with("Start"), media_by_stem.get(value)) {
                    m.text = media.to_string();
                    renamed += 1;
                }
            }
        }
        let mut events = Vec::new();
        let mut from_samples = 0;
        for (k, f) in self.fixations.iter().enumerate() {
            let (x, y) = match (f.x, f.y, f.sum.2) {
                (Some(x), Some(y), _) => (Some(x), Some(y)),
                (_, _, n) if n > 0 => {
                    from_samples += 1;
                    (Some(f.sum.0 / n as f64), Some(f.sum.1 / n as f64))
                }
                _ => (None, None),
            };
            // A negative duration (a damaged row) falls back to the rows' span, never below 0.
            let duration = f
                .duration_us
                .filter(|d| *d >= 0)
                .unwrap_or((f.last_us - f.start_us).max(0));
            let onset = f
                .stimulus
                .as_deref()
                .map(|s| onset_of(s, self.first_named.get(s).copied().unwrap_or(f.start_us)));
            events.push(Event {
                x,
                y,
                stimulus: f.stimulus.as_deref().map(str::to_string),
                stimulus_onset_us: onset,
                ..Event::span(
                    EventKind::Fixation,
                    Eye::Binocular,
                    k as u64 + 1,
                    f.start_us,
                    f.start_us.saturating_add(duration),
                    duration,
                )
            });
        }
        let mut notes = vec![format!(
            "time column `{}` read as {time_note}",
            self.names[self.c.time]
        )];
        if renamed > 0 {
            notes.push(format!(
                "{renamed} stimulus start events are messages named by their media file"
            ));
        }
        for (sensor, n) in &self.other_sensors {
            notes.push(format!(
                "{n} rows of the `{sensor}` sensor are not gaze and were set aside"
            ));
        }
        if from_samples > 0 {
            notes.push(format!(
                "{from_samples} fixations have no fixation point in the file (outside any media): placed at the mean of their valid gaze samples"
            ));
        }
        if self.header.calibration_area_px.is_none() {
            notes.push("no recording resolution in the file: the screen size is not known".into());
        }
        let rows = self.rows;
        Recording {
            file: self.path.to_string(),
            format: match self.dialect {
                Dialect::ProLab => GazeFormat::TobiiProLab,
                Dialect::Studio => GazeFormat::TobiiStudio,
            },
            header: self.header,
            columns: self.names,
            samples: self.samples,
            messages,
            events,
            rows,
            notes,
        }
    }
}

/// Reads a Tobii Pro Lab or Studio data export; `path` names it in messages.
pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let Some((first, body_start)) = first_line(bytes) else {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "the file is empty".into(),
        });
    };
    let Some(dialect) = dialect_of(&first) else {
        return Err(GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: "not a Tobii Pro Lab or Studio data export: the header names neither `Recording timestamp` and `Gaze point X` (Pro Lab) nor `RecordingTimestamp` and `GazePointX (ADCSpx)` (Studio)".into(),
        });
    };
    let sep = Separator::sniff(&first);
    let names: Vec<String> = fields(&first, sep)
        .iter()
        .map(|(_, c)| c.trim().to_string())
        .collect();
    let c = columns_of(&names, dialect, path)?;
    let body = &bytes[body_start..];
    let (scale, time_note) = Reader::infer_scale(&names, &c, body, sep, dialect);
    let mut r = Reader {
        path,
        dialect,
        sep,
        names,
        c,
        scale,
        rows: RowAccount {
            header_lines: 1,
            ..Default::default()
        },
        header: Header {
            banner: Some(match dialect {
                Dialect::ProLab => "Tobii Pro Lab data export".into(),
                Dialect::Studio => "Tobii Studio data export".into(),
            }),
            ..Default::default()
        },
        samples: Vec::with_capacity(lines_estimate(body)),
        messages: Vec::new(),
        fixations: Vec::new(),
        first_named: BTreeMap::new(),
        last_named: None,
        start_events: BTreeMap::new(),
        other_sensors: BTreeMap::new(),
        names_seen: SharedNames::default(),
        labels: SharedLabels::default(),
    };
    let wanted = r.c.wanted(r.names.len());
    // Quotes stop the fast split only in CSV: a TAB export's `"` is an ordinary byte.
    let csv = sep == Separator::Comma;
    r.rows.lines = for_each_row(bytes, body_start, 2, sep, &wanted, csv, |row| r.row(row));
    r.header.sample_rate_hz = super::recording::median_rate_hz(&r.samples, 1);
    Ok(r.finish(time_note))
}

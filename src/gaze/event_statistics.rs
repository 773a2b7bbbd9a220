//! Format B: BeGaze Metrics Export "Event Statistics" (Single). One header row, one row per
//! event; the separator (TAB, comma, semicolon) and the decimal mark are user options, so both
//! are sniffed; `-` is missing. Times are milliseconds from the start of the trial
//! (`Event Start Trial Time [ms]`), so each event carries its `Stimulus`. Event classification
//! comes as `Category` + `Eye L/R`, or as per-eye `Category Left/Right/Binocular` columns.
//! Written from the documented column names: no real file of this format was available.
use super::recording::{
    Event, EventKind, Eye, GazeError, GazeFormat, Header, Recording, RowAccount,
};
use super::text::{
    decode, header_row, is_missing, lines, number, required_column, table_row, Separator,
};

/// The field under the column called `name`.
fn field<'a>(columns: &[String], f: &[(usize, &'a str)], name: &str) -> Option<(usize, &'a str)> {
    columns
        .iter()
        .position(|c| c == name)
        .and_then(|c| f.get(c))
        .copied()
}

fn kind_of(category: &str) -> Option<EventKind> {
    match category.trim() {
        "Fixation" | "Visual Intake" => Some(EventKind::Fixation),
        "Saccade" => Some(EventKind::Saccade),
        "Blink" => Some(EventKind::Blink),
        _ => None,
    }
}

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let (sep, columns) = header_row(&all, path)?;
    let col = |name: &str| columns.iter().position(|c| c == name);
    let need = |name: &str| required_column(&columns, name, path, "BeGaze Event Statistics export");
    let cols = Columns {
        start: need("Event Start Trial Time [ms]")?,
        end: need("Event End Trial Time [ms]")?,
        duration: col("Event Duration [ms]"),
        trial: col("Trial"),
        stimulus: col("Stimulus"),
        participant: col("Participant"),
        streams: streams_of(&columns, path)?,
        names: &columns,
        sep,
    };
    let mut rows = RowAccount {
        lines: all.len(),
        header_lines: 1,
        ..Default::default()
    };
    let mut header = Header::default();
    let mut events = Vec::new();
    let mut number_per_stream = std::collections::HashMap::new();
    for &(no, line) in &all[1..] {
        let Some(f) = table_row(line, no, sep, columns.len(), &mut rows) else {
            continue;
        };
        let (kind, eye) = match cols.category(&f) {
            Ok(k) => k,
            Err((reason, c)) => {
                rows.reject(&reason, no, c, line);
                continue;
            }
        };
        let Some(mut event) = cols.event(&f, kind, eye, no, line, &mut rows) else {
            continue;
        };
        if header.subject.is_none() {
            header.subject = event.participant.clone();
        }
        let n = number_per_stream
            .entry((event.participant.clone(), event.trial, eye, kind as u8))
            .or_insert(0u64);
        *n += 1;
        event.number = *n;
        events.push(event);
        rows.events += 1;
    }
    events.sort_by(|a, b| {
        (&a.participant, a.trial, a.start_us, a.eye, a.number).cmp(&(
            &b.participant,
            b.trial,
            b.start_us,
            b.eye,
            b.number,
        ))
    });
    let notes = notes_of(&events, sep);
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::EventStatistics,
        header,
        columns,
        samples: Vec::new(),
        messages: Vec::new(),
        events,
        rows,
        notes,
    })
}

/// Where an event's classification is: `Category` + `Eye L/R`, or per-eye category columns
/// (column, eye column, the eye when there is no eye column).
fn streams_of(
    columns: &[String],
    path: &str,
) -> Result<Vec<(usize, Option<usize>, Eye)>, GazeError> {
    let col = |name: &str| columns.iter().position(|c| c == name);
    let mut streams = Vec::new();
    if let Some(c) = col("Category") {
        streams.push((c, col("Eye L/R"), Eye::Left));
    }
    for (name, eye) in [
        ("Category Left", Eye::Left),
        ("Category Right", Eye::Right),
        ("Category Binocular", Eye::Binocular),
    ] {
        if let Some(c) = col(name) {
            streams.push((c, None, eye));
        }
    }
    if streams.is_empty() {
        return Err(GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: "no `Category` (or `Category Left/Right/Binocular`) column".into(),
        });
    }
    Ok(streams)
}

/// Which column holds what, and the separator of the numbers.
struct Columns<'a> {
    start: usize,
    end: usize,
    duration: Option<usize>,
    trial: Option<usize>,
    stimulus: Option<usize>,
    participant: Option<usize>,
    streams: Vec<(usize, Option<usize>, Eye)>,
    names: &'a [String],
    sep: Separator,
}

impl Columns<'_> {
    /// The row's event kind and eye: from the first category column that names an event; or
    /// why the row is not an event, and the column to point at.
    fn category(&self, f: &[(usize, &str)]) -> Result<(EventKind, Eye), (String, usize)> {
        for &(c, eye_c, default_eye) in &self.streams {
            let cat = f[c].1.trim();
            if cat == "Separator" {
                return Err(("`Separator` row (between trials)".into(), f[c].0));
            }
            if let Some(kind) = kind_of(cat) {
                let eye = match eye_c.map(|e| f[e].1.trim()) {
                    Some("Left" | "L") => Eye::Left,
                    Some("Right" | "R") => Eye::Right,
                    Some(_) | None if eye_c.is_none() => default_eye,
                    _ => Eye::Binocular,
                };
                return Ok((kind, eye));
            }
        }
        let c = self.streams[0].0;
        let cat = f[c].1.trim();
        let reason = if is_missing(cat) {
            "no event category (`-`)".to_string()
        } else {
            format!("event category `{cat}` not used by meshgaze")
        };
        Err((reason, f[c].0))
    }

    /// The row's event (numbered later); None when a field is unusable, counted once in
    /// `rows` at the first unusable field so that every line is accounted for exactly once.
    fn event(
        &self,
        f: &[(usize, &str)],
        kind: EventKind,
        eye: Eye,
        no: usize,
        line: &str,
        rows: &mut RowAccount,
    ) -> Option<Event> {
        match self.parse_event(f, kind, eye) {
            Ok(event) => Some(event),
            Err((reason, column)) => {
                rows.reject(&reason, no, column, line);
                None
            }
        }
    }

    /// The row's event, or why not and at which column.
    fn parse_event(
        &self,
        f: &[(usize, &str)],
        kind: EventKind,
        eye: Eye,
    ) -> Result<Event, (String, usize)> {
        let sep = self.sep;
        let ms = |i: usize, name: &str| -> Result<Option<f64>, (String, usize)> {
            number(f[i].1, sep).map_err(|_| (format!("`{name}` is not a number"), f[i].0))
        };
        let required = |i: usize, name: &str| -> Result<f64, (String, usize)> {
            ms(i, name)?.ok_or_else(|| (format!("missing `{name}`"), f[i].0))
        };
        let start_ms = required(self.start, "Event Start Trial Time [ms]")?;
        let end_ms = required(self.end, "Event End Trial Time [ms]")?;
        let duration_ms = match self.duration {
            Some(c) => ms(c, "Event Duration [ms]")?.unwrap_or(end_ms - start_ms),
            None => end_ms - start_ms,
        };
        let real = |name: &str| -> Result<Option<f64>, (String, usize)> {
            match field(self.names, f, name) {
                Some((c, t)) => {
                    number(t, sep).map_err(|_| (format!("`{name}` is not a number"), c))
                }
                None => Ok(None),
            }
        };
        let raw_start = real("Event Start Raw Time [ms]")?;
        let raw_end = real("Event End Raw Time [ms]")?;
        let fx = real("Fixation Position X [px]")?;
        let fy = real("Fixation Position Y [px]")?;
        let sx = real("Saccade Start Position X [px]")?;
        let sy = real("Saccade Start Position Y [px]")?;
        let ex = real("Saccade End Position X [px]")?;
        let ey = real("Saccade End Position Y [px]")?;
        let dx = real("Fixation Dispersion X [px]")?;
        let dy = real("Fixation Dispersion Y [px]")?;
        let pupil = real("Fixation Average Pupil Diameter [mm]")?;
        if end_ms < start_ms {
            return Err(("event ends before it starts".to_string(), 1));
        }
        let trial = self
            .trial
            .map(|c| f[c].1.trim())
            .and_then(|t| {
                t.trim_start_matches(|ch: char| !ch.is_ascii_digit())
                    .parse::<u32>()
                    .ok()
            })
            .unwrap_or(1);
        let participant = self
            .participant
            .map(|c| f[c].1.trim().to_string())
            .filter(|p| !is_missing(p));
        // The tracker clock, when the export has the raw times: the stimulus onset is where
        // the trial time is zero on that clock.
        let (start_us, end_us, stimulus_onset_us) = match (raw_start, raw_end) {
            (Some(rs), Some(re)) => (
                (rs * 1000.0).round() as i64,
                (re * 1000.0).round() as i64,
                Some(((rs - start_ms) * 1000.0).round() as i64),
            ),
            _ => (
                (start_ms * 1000.0).round() as i64,
                (end_ms * 1000.0).round() as i64,
                None,
            ),
        };
        let (x, y) = if kind == EventKind::Saccade {
            (sx, sy)
        } else {
            (fx, fy)
        };
        Ok(Event {
            kind,
            eye,
            trial,
            number: 0,
            start_us,
            end_us,
            duration_us: (duration_ms * 1000.0).round() as i64,
            x,
            y,
            end_x: ex,
            end_y: ey,
            dispersion_x: dx,
            dispersion_y: dy,
            pupil_x: pupil,
            pupil_y: None,
            stimulus: self
                .stimulus
                .map(|c| f[c].1.trim().to_string())
                .filter(|s| !is_missing(s)),
            stimulus_onset_us,
            participant,
        })
    }
}

/// What the reader tells the user about the file: its clock, its participants, its separator.
fn notes_of(events: &[Event], sep: Separator) -> Vec<String> {
    let raw_clock = events.iter().any(|e| e.stimulus_onset_us.is_some());
    let mut notes = vec![if raw_clock {
        "event times from the `Event Start/End Raw Time [ms]` columns (the tracker clock)"
            .to_string()
    } else {
        "event times are milliseconds from each trial's start (not the tracker clock)".to_string()
    }];
    let participants: std::collections::BTreeSet<&str> = events
        .iter()
        .filter_map(|e| e.participant.as_deref())
        .collect();
    if participants.len() > 1 {
        notes.push(format!(
            "{} participants in one file ({}): each is its own subject",
            participants.len(),
            participants.iter().copied().collect::<Vec<_>>().join(", ")
        ));
    }
    if sep != Separator::Tab {
        notes.push(format!("fields separated by {sep:?}"));
    }
    notes
}

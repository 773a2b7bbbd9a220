//! Format B-fix: the older BeGaze "fixation" export. No `##` header: one header row, then one
//! row per fixation, TAB-separated (comma and semicolon sniffed too), usually CRLF:
//!
//! `Trial  Subject  Color  Stimulus  Start Time [ms]  End Time [ms]  Fixation Start [ms]
//! Fixation Duration [ms]  Fixation End [ms]  Position X  Position Y  Average Pupil Size [px] X
//! Average Pupil Size [px] Y  Average Pupil Diameter [mm]  Dispersion X  Dispersion Y  Eye
//! Number`
//!
//! Fixation times are milliseconds from the start of the trial, whose stimulus the row names;
//! one file holds several subjects and trials. `Eye` is `Binocular`, `Left` or `Right`.
use super::recording::{
    Event, EventKind, Eye, GazeError, GazeFormat, Header, Recording, RowAccount,
};
use super::text::{
    decode, header_row, is_missing, lines, number, required_column, table_row, Separator,
};

/// The columns detection looks for on the first line.
pub(crate) const SIGNATURE: [&str; 3] = [
    "Fixation Start [ms]",
    "Fixation Duration [ms]",
    "Position X",
];

/// Which column holds what.
struct Columns {
    start: usize,
    duration: Option<usize>,
    end: Option<usize>,
    x: usize,
    y: usize,
    trial: Option<usize>,
    subject: Option<usize>,
    stimulus: Option<usize>,
    eye: Option<usize>,
    number: Option<usize>,
    pupil_x: Option<usize>,
    pupil_y: Option<usize>,
    dispersion_x: Option<usize>,
    dispersion_y: Option<usize>,
}

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let (sep, columns) = header_row(&all, path)?;
    let col = |name: &str| columns.iter().position(|c| c == name);
    let need = |name: &str| required_column(&columns, name, path, "BeGaze fixation export");
    let cols = Columns {
        start: need("Fixation Start [ms]")?,
        duration: col("Fixation Duration [ms]"),
        end: col("Fixation End [ms]"),
        x: need("Position X")?,
        y: need("Position Y")?,
        trial: col("Trial"),
        subject: col("Subject"),
        stimulus: col("Stimulus"),
        eye: col("Eye"),
        number: col("Number"),
        pupil_x: col("Average Pupil Size [px] X"),
        pupil_y: col("Average Pupil Size [px] Y"),
        dispersion_x: col("Dispersion X"),
        dispersion_y: col("Dispersion Y"),
    };
    if cols.duration.is_none() && cols.end.is_none() {
        return Err(GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: "neither `Fixation Duration [ms]` nor `Fixation End [ms]`: a fixation's length is unknown".into(),
        });
    }
    let mut rows = RowAccount {
        lines: all.len(),
        header_lines: 1,
        ..Default::default()
    };
    let mut events = Vec::new();
    for &(no, line) in all.iter().skip(1) {
        let Some(f) = table_row(line, no, sep, columns.len(), &mut rows) else {
            continue;
        };
        match cols.fixation(&f, sep) {
            Ok(e) => {
                events.push(e);
                rows.events += 1;
            }
            Err((reason, column)) => rows.reject(&reason, no, column, line),
        }
    }
    // Rows come per subject and trial already; a stable sort keeps ties in file order.
    events.sort_by(|a: &Event, b: &Event| {
        (&a.participant, a.trial, a.start_us).cmp(&(&b.participant, b.trial, b.start_us))
    });
    let mut header = Header::default();
    let subjects: std::collections::BTreeSet<&str> = events
        .iter()
        .filter_map(|e| e.participant.as_deref())
        .collect();
    if subjects.len() == 1 {
        header.subject = subjects.first().map(|s| s.to_string());
    }
    let mut notes = vec![
        "fixation times are milliseconds from each trial's start (not the tracker clock)"
            .to_string(),
    ];
    if subjects.len() > 1 {
        notes.push(format!(
            "{} subjects in one file ({}): each is its own subject",
            subjects.len(),
            subjects.iter().copied().collect::<Vec<_>>().join(", ")
        ));
    }
    if sep != Separator::Tab {
        notes.push(format!("fields separated by {sep:?}"));
    }
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::BeGazeFixations,
        header,
        columns,
        samples: Vec::new(),
        messages: Vec::new(),
        events,
        rows,
        notes,
    })
}

impl Columns {
    /// The row's fixation, or why not and at which column.
    fn fixation(&self, f: &[(usize, &str)], sep: Separator) -> Result<Event, (String, usize)> {
        let name_of = |i: usize| -> &'static str {
            match i {
                _ if i == self.start => "Fixation Start [ms]",
                _ if Some(i) == self.duration => "Fixation Duration [ms]",
                _ if Some(i) == self.end => "Fixation End [ms]",
                _ if i == self.x => "Position X",
                _ if i == self.y => "Position Y",
                _ if Some(i) == self.pupil_x => "Average Pupil Size [px] X",
                _ if Some(i) == self.pupil_y => "Average Pupil Size [px] Y",
                _ if Some(i) == self.dispersion_x => "Dispersion X",
                _ if Some(i) == self.dispersion_y => "Dispersion Y",
                _ => "Number",
            }
        };
        let value = |i: usize| -> Result<Option<f64>, (String, usize)> {
            number(f[i].1, sep).map_err(|_| (format!("`{}` is not a number", name_of(i)), f[i].0))
        };
        let optional = |c: Option<usize>| c.map(value).transpose().map(Option::flatten);
        let required =
            |i: usize| value(i)?.ok_or_else(|| (format!("missing `{}`", name_of(i)), f[i].0));
        let start_ms = required(self.start)?;
        let duration_ms = match (optional(self.duration)?, optional(self.end)?) {
            (Some(d), _) => d,
            (None, Some(end)) => end - start_ms,
            (None, None) => {
                let c = self.duration.or(self.end).unwrap_or(self.start);
                return Err(("missing `Fixation Duration [ms]`".into(), f[c].0));
            }
        };
        if duration_ms < 0.0 {
            let c = self.duration.or(self.end).unwrap_or(self.start);
            return Err(("fixation with a negative duration".into(), f[c].0));
        }
        let eye = match self.eye.map(|c| (c, f[c].1.trim())) {
            None => Eye::Binocular,
            Some((_, "Binocular" | "B" | "")) => Eye::Binocular,
            Some((_, "Left" | "L")) => Eye::Left,
            Some((_, "Right" | "R")) => Eye::Right,
            Some((c, other)) => {
                return Err((
                    format!("`Eye` is `{other}`, not Binocular, Left or Right"),
                    f[c].0,
                ))
            }
        };
        let text = |c: Option<usize>| {
            c.map(|c| f[c].1.trim().to_string())
                .filter(|t| !is_missing(t))
        };
        let trial = text(self.trial)
            .and_then(|t| {
                t.trim_start_matches(|ch: char| !ch.is_ascii_digit())
                    .parse::<u32>()
                    .ok()
            })
            .unwrap_or(1);
        let number = optional(self.number)?.map_or(0, |n| n.max(0.0) as u64);
        // Beyond ±2^53 µs (285 years) a time is not a recording's: refuse it rather than
        // let the end overflow.
        const LIMIT_MS: f64 = 9.007e12;
        if start_ms.abs() > LIMIT_MS || duration_ms > LIMIT_MS {
            let c = self.duration.or(self.end).unwrap_or(self.start);
            return Err(("fixation time out of range".into(), f[c].0));
        }
        let start_us = (start_ms * 1000.0).round() as i64;
        let duration_us = (duration_ms * 1000.0).round() as i64;
        Ok(Event {
            kind: EventKind::Fixation,
            eye,
            trial,
            number,
            start_us,
            end_us: start_us + duration_us,
            duration_us,
            x: Some(required(self.x)?),
            y: Some(required(self.y)?),
            end_x: None,
            end_y: None,
            dispersion_x: optional(self.dispersion_x)?,
            dispersion_y: optional(self.dispersion_y)?,
            pupil_x: optional(self.pupil_x)?,
            pupil_y: optional(self.pupil_y)?,
            stimulus: text(self.stimulus),
            stimulus_onset_us: None,
            participant: text(self.subject),
        })
    }
}

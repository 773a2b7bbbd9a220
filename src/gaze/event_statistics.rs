//! Format B: BeGaze Metrics Export "Event Statistics" (Single). One header row, one row per
//! event; the separator (TAB, comma, semicolon) and the decimal mark are user options, so both
//! are sniffed; `-` is missing. Times are milliseconds from the start of the trial
//! (`Event Start Trial Time [ms]`), so each event carries its `Stimulus`. Event classification
//! comes as `Category` + `Eye L/R`, or as per-eye `Category Left/Right/Binocular` columns.
//! Written from the documented column names: no real file of this format was available.
use super::model::{Event, EventKind, Eye, GazeError, Header, Recording, RowAccount, SmiFormat};
use super::text::{decode, header_row, is_missing, lines, number, table_row, Separator};

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
    let need = |name: &str| {
        col(name).ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: format!("no `{name}` column: not a BeGaze Event Statistics export"),
        })
    };
    let start_c = need("Event Start Trial Time [ms]")?;
    let end_c = need("Event End Trial Time [ms]")?;
    let duration_c = col("Event Duration [ms]");
    // Classification: `Category` + `Eye L/R`, or per-eye category columns.
    let mut streams: Vec<(usize, Option<usize>, Eye)> = Vec::new();
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
    let (trial_c, stimulus_c, participant_c) = (col("Trial"), col("Stimulus"), col("Participant"));
    let mut rows = RowAccount {
        lines: all.len(),
        header_lines: 1,
        ..Default::default()
    };
    let mut header = Header::default();
    let mut events = Vec::new();
    let mut number_per_stream = std::collections::HashMap::new();
    'rows: for &(no, line) in &all[1..] {
        let Some(f) = table_row(line, no, sep, columns.len(), &mut rows) else {
            continue;
        };
        // The event's stream: the first category column that names an event.
        let mut found = None;
        for &(c, eye_c, default_eye) in &streams {
            let cat = f[c].1.trim();
            if cat == "Separator" {
                rows.reject("`Separator` row (between trials)", no, f[c].0, line);
                continue 'rows;
            }
            if let Some(kind) = kind_of(cat) {
                let eye = match eye_c.map(|e| f[e].1.trim()) {
                    Some("Left" | "L") => Eye::Left,
                    Some("Right" | "R") => Eye::Right,
                    Some(_) | None if eye_c.is_none() => default_eye,
                    _ => Eye::Binocular,
                };
                found = Some((kind, eye));
                break;
            }
        }
        let Some((kind, eye)) = found else {
            let c = streams[0].0;
            let cat = f[c].1.trim();
            let reason = if is_missing(cat) {
                "no event category (`-`)".to_string()
            } else {
                format!("event category `{cat}` not used by meshgaze")
            };
            rows.reject(&reason, no, f[c].0, line);
            continue;
        };
        let ms = |i: usize, name: &str, rows: &mut RowAccount| -> Result<Option<f64>, ()> {
            number(f[i].1, sep)
                .map_err(|_| rows.reject(&format!("`{name}` is not a number"), no, f[i].0, line))
        };
        let Ok(Some(start_ms)) = ms(start_c, "Event Start Trial Time [ms]", &mut rows) else {
            if number(f[start_c].1, sep).is_ok() {
                rows.reject(
                    "missing `Event Start Trial Time [ms]`",
                    no,
                    f[start_c].0,
                    line,
                );
            }
            continue;
        };
        let Ok(Some(end_ms)) = ms(end_c, "Event End Trial Time [ms]", &mut rows) else {
            if number(f[end_c].1, sep).is_ok() {
                rows.reject("missing `Event End Trial Time [ms]`", no, f[end_c].0, line);
            }
            continue;
        };
        let duration_ms = match duration_c.map(|c| ms(c, "Event Duration [ms]", &mut rows)) {
            Some(Err(())) => continue,
            Some(Ok(Some(d))) => d,
            _ => end_ms - start_ms,
        };
        let mut real = |name: &str| -> Result<Option<f64>, ()> {
            match field(&columns, &f, name) {
                Some((c, t)) => number(t, sep)
                    .map_err(|_| rows.reject(&format!("`{name}` is not a number"), no, c, line)),
                None => Ok(None),
            }
        };
        let (Ok(raw_start), Ok(raw_end)) = (
            real("Event Start Raw Time [ms]"),
            real("Event End Raw Time [ms]"),
        ) else {
            continue;
        };
        let (Ok(fx), Ok(fy), Ok(sx), Ok(sy), Ok(ex), Ok(ey), Ok(dx), Ok(dy), Ok(pupil)) = (
            real("Fixation Position X [px]"),
            real("Fixation Position Y [px]"),
            real("Saccade Start Position X [px]"),
            real("Saccade Start Position Y [px]"),
            real("Saccade End Position X [px]"),
            real("Saccade End Position Y [px]"),
            real("Fixation Dispersion X [px]"),
            real("Fixation Dispersion Y [px]"),
            real("Fixation Average Pupil Diameter [mm]"),
        ) else {
            continue;
        };
        if end_ms < start_ms {
            rows.reject("event ends before it starts", no, 1, line);
            continue;
        }
        let trial = trial_c
            .map(|c| f[c].1.trim())
            .and_then(|t| {
                t.trim_start_matches(|ch: char| !ch.is_ascii_digit())
                    .parse::<u32>()
                    .ok()
            })
            .unwrap_or(1);
        let participant = participant_c
            .map(|c| f[c].1.trim().to_string())
            .filter(|p| !is_missing(p));
        if header.subject.is_none() {
            header.subject = participant.clone();
        }
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
        let n = number_per_stream
            .entry((participant.clone(), trial, eye, kind as u8))
            .or_insert(0u64);
        *n += 1;
        let (x, y) = if kind == EventKind::Saccade {
            (sx, sy)
        } else {
            (fx, fy)
        };
        events.push(Event {
            kind,
            eye,
            trial,
            number: *n,
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
            stimulus: stimulus_c
                .map(|c| f[c].1.trim().to_string())
                .filter(|s| !is_missing(s)),
            stimulus_onset_us,
            participant,
        });
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
    Ok(Recording {
        file: path.to_string(),
        format: SmiFormat::EventStatistics,
        header,
        columns,
        samples: Vec::new(),
        messages: Vec::new(),
        events,
        rows,
        notes,
    })
}

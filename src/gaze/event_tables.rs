//! Format C1: IDF Event Detector / BeGaze event text. A `Key: value` header, then one
//! `Table Header for …:` block per event type with its column names, then event rows whose
//! first field (`Fixation L`, `Saccade R`, `Blink L`, `UserEvent`, …) says which table they
//! follow. Fields are separated by TAB (native), comma (BeGaze option) or, in damaged copies
//! whose TABs became spaces, runs of two or more spaces.
use std::collections::HashMap;

use super::idf_samples::parse_header_line;
use super::recording::{
    Event, EventKind, Eye, GazeError, GazeFormat, Header, Message, Recording, RowAccount,
};
use super::text::{integer, lines, message_text, number, split, Separator};

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = super::text::decode(bytes);
    let all = lines(&text);
    let first_table = all
        .iter()
        .position(|(_, l)| l.trim_start().starts_with("Table Header for"))
        .ok_or_else(|| GazeError::File {
            path: path.to_string(),
            message: "no `Table Header for …` line was found: not an SMI event export".into(),
        })?;
    let mut header = Header::default();
    let mut rows = RowAccount {
        lines: all.len(),
        ..Default::default()
    };
    for (_, l) in &all[..first_table] {
        if l.trim().is_empty() {
            rows.blank_lines += 1;
        } else {
            // Damaged copies separate key and value with spaces instead of a TAB.
            parse_header_line(&l.replace("        ", "\t"), &mut header);
            rows.header_lines += 1;
        }
    }
    // Tables: title → column names.
    let mut tables: HashMap<String, Vec<String>> = HashMap::new();
    let mut sep: Option<Separator> = None;
    let mut columns_all = Vec::new();
    let mut i = first_table;
    let mut events = Vec::new();
    let mut messages = Vec::new();
    let mut notes = Vec::new();
    let mut pending_title: Option<String> = None;
    while i < all.len() {
        let (no, line) = (all[i].0, all[i].1);
        i += 1;
        let trimmed = line.trim();
        if trimmed.is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        if let Some(rest) = trimmed.strip_prefix("Table Header for") {
            pending_title = Some(rest.trim().trim_end_matches(':').trim().to_string());
            rows.header_lines += 1;
            continue;
        }
        if let Some(title) = pending_title.take() {
            let s = *sep.get_or_insert_with(|| Separator::sniff(line));
            if s == Separator::Spaces && !notes.iter().any(|n: &String| n.contains("spaces")) {
                notes.push("fields are separated by runs of spaces (TABs replaced): a damaged copy, read by splitting on 2+ spaces".into());
            }
            let cols: Vec<String> = split(line, s)
                .iter()
                .map(|(_, c)| c.trim().to_string())
                .collect();
            columns_all.extend(cols.iter().cloned());
            tables.insert(title, cols);
            rows.header_lines += 1;
            continue;
        }
        let s = sep.unwrap_or(Separator::Tab);
        let f = split(line, s);
        let kind_text = f[0].1.trim();
        let (table, kind, eye) = match row_kind(kind_text) {
            Ok(k) => k,
            Err(reason) => {
                rows.reject(&reason, no, 1, line);
                continue;
            }
        };
        let Some(cols) = tables.get(table) else {
            rows.reject(
                &format!("`{kind_text}` row without a `Table Header for {table}` block"),
                no,
                1,
                line,
            );
            continue;
        };
        let row = Row {
            cols,
            fields: &f,
            sep: s,
            no,
            line,
        };
        match row.parse(kind, eye, &mut rows) {
            Some(Parsed::Event(e)) => {
                events.push(e);
                rows.events += 1;
            }
            Some(Parsed::Message(m)) => {
                messages.push(m);
                rows.messages += 1;
            }
            None => {}
        }
    }
    // IDF Event Detector writes each trial's left-eye events, then its right-eye events.
    events.sort_by_key(|e| (e.trial, e.start_us, e.eye, e.number));
    messages.sort_by_key(|m| (m.trial, m.time_us));
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::EventTables,
        header,
        columns: columns_all,
        samples: Vec::new(),
        messages,
        events,
        rows,
        notes,
    })
}

/// The table a row belongs to, its event kind (None for a user event / message) and its eye
/// letter; or why the row is not read.
fn row_kind(kind_text: &str) -> Result<(&'static str, Option<EventKind>, &str), String> {
    if let Some(e) = kind_text.strip_prefix("Fixation ") {
        Ok(("Fixations", Some(EventKind::Fixation), e))
    } else if let Some(e) = kind_text.strip_prefix("Saccade ") {
        Ok(("Saccades", Some(EventKind::Saccade), e))
    } else if let Some(e) = kind_text.strip_prefix("Blink ") {
        Ok(("Blinks", Some(EventKind::Blink), e))
    } else if kind_text == "UserEvent" {
        Ok(("User Events", None, ""))
    } else if kind_text.starts_with("Trigger") || kind_text.starts_with("TriggerLine") {
        Err("trigger-line event (not used by meshgaze)".into())
    } else {
        Err(format!("unknown event type `{kind_text}`"))
    }
}

enum Parsed {
    Event(Event),
    Message(Message),
}

/// One data row with the columns of its table.
struct Row<'a> {
    cols: &'a [String],
    fields: &'a [(usize, &'a str)],
    sep: Separator,
    /// 1-based line number and the line, for messages.
    no: usize,
    line: &'a str,
}

impl Row<'_> {
    fn field(&self, name: &str) -> Option<(usize, &str)> {
        let c = self.cols.iter().position(|c| c == name)?;
        self.fields.get(c).copied()
    }

    /// An integer field; a missing or malformed one rejects the row (counted in `rows`).
    fn int(&self, name: &str, rows: &mut RowAccount) -> Option<i64> {
        match self.field(name).map(|(c, t)| (c, integer(t))) {
            Some((_, Ok(Some(v)))) => Some(v),
            Some((c, _)) => {
                rows.reject(
                    &format!("`{name}` is not an integer"),
                    self.no,
                    c,
                    self.line,
                );
                None
            }
            None => {
                rows.reject(
                    &format!("row has no `{name}` field"),
                    self.no,
                    self.line.len() + 1,
                    self.line,
                );
                None
            }
        }
    }

    /// The row as an event or a message; None when rejected (and counted in `rows`).
    fn parse(&self, kind: Option<EventKind>, eye: &str, rows: &mut RowAccount) -> Option<Parsed> {
        let (no, line) = (self.no, self.line);
        let trial = self.int("Trial", rows)?;
        let start = self.int("Start", rows)?;
        let Some(kind) = kind else {
            let text = self
                .field("Description")
                .map(|(_, t)| message_text(t))
                .unwrap_or_default();
            return Some(Parsed::Message(Message {
                time_us: start,
                trial: trial.clamp(0, u32::MAX as i64) as u32,
                text,
            }));
        };
        let eye = match eye.trim() {
            "L" => Eye::Left,
            "R" => Eye::Right,
            // BeGaze 3.6 writes binocular events (`Fixation B`).
            "B" => Eye::Binocular,
            other => {
                rows.reject(
                    &format!("unknown eye `{other}` (expected L, R or B)"),
                    no,
                    1,
                    line,
                );
                return None;
            }
        };
        let number_ = self.int("Number", rows)?;
        let end = self.int("End", rows)?;
        let duration = self.int("Duration", rows)?;
        let mut bad = None;
        let mut real = |names: &[&str]| -> Option<f64> {
            let (c, t) = names.iter().find_map(|n| self.field(n))?;
            match number(t, self.sep) {
                Ok(v) => v,
                Err(()) => {
                    bad.get_or_insert((c, names[0].to_string()));
                    None
                }
            }
        };
        let (x, y, end_x, end_y) = match kind {
            EventKind::Fixation => (real(&["Location X"]), real(&["Location Y"]), None, None),
            EventKind::Saccade => (
                real(&["Start Loc.X"]),
                real(&["Start Loc.Y"]),
                real(&["End Loc.X"]),
                real(&["End Loc.Y"]),
            ),
            EventKind::Blink => (None, None, None, None),
        };
        let (dispersion_x, dispersion_y, pupil_x, pupil_y) = if kind == EventKind::Fixation {
            (
                real(&["Dispersion X"]),
                real(&["Dispersion Y"]),
                real(&["Avg. Pupil Size X", "Avg Pupil Size X"]),
                real(&["Avg. Pupil Size Y", "Avg Pupil Size Y"]),
            )
        } else {
            (None, None, None, None)
        };
        if let Some((c, name)) = bad {
            rows.reject(&format!("`{name}` is not a number"), no, c, line);
            return None;
        }
        if end < start || duration < 0 {
            rows.reject("event ends before it starts", no, 1, line);
            return None;
        }
        Some(Parsed::Event(Event {
            kind,
            eye,
            trial: trial.clamp(0, u32::MAX as i64) as u32,
            number: number_.max(0) as u64,
            start_us: start,
            end_us: end,
            duration_us: duration,
            x,
            y,
            end_x,
            end_y,
            dispersion_x,
            dispersion_y,
            pupil_x,
            pupil_y,
            stimulus: None,
            stimulus_onset_us: None,
            participant: None,
        }))
    }
}

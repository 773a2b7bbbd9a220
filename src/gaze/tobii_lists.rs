//! Tobii Studio 1.x / 2.x (and ClearView) list exports: a block of `key: value` lines
//! (`Recording date:`, `Screen resolution: 1280 x 1024`, `Subject:`), then one TAB table.
//! * The fixation list (`…-Fixation-Data.tsv`): `FixationIndex`, `Timestamp` (ms from the
//!   recording's start), `FixationDuration` (ms), `MappedFixationPointX/Y` (screen px; a
//!   point the filter could not map is written -1, which stays off screen).
//! * The event list (`…-Event-Data.tsv`): `Timestamp`, `Event`, `EventKey`, `Data1`, `Data2`,
//!   `Descriptor`, read as messages (`LogData Load 1st Problem`).
//!
//! Studio wrote the two beside each other with one recording name: reading a fixation list
//! also reads the messages of its event list (`X-Fixation-Data.tsv` → `X-Event-Data.tsv`),
//! which is how its stimulus onsets reach it. An event list alone has no gaze and is refused,
//! naming the fixation list to give instead.
use super::recording::{
    Event, EventKind, Eye, GazeError, GazeFormat, Header, Message, Recording, RowAccount,
};
use super::text::{decode, lines, number, split, Separator};

/// Which list a table header line starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum List {
    Fixations,
    Events,
}

fn list_of(line: &str) -> Option<List> {
    let l = line.trim_start_matches('\u{feff}');
    if l.starts_with("FixationIndex\tTimestamp\tFixationDuration") {
        Some(List::Fixations)
    } else if l.starts_with("Timestamp\tEvent\tEventKey") {
        Some(List::Events)
    } else {
        None
    }
}

/// Whether the file's first lines are a Studio 1.x/2.x list export.
pub(crate) fn looks_like(head: &str) -> bool {
    let mut it = head.lines().take(80);
    let starts_with_block = head
        .trim_start_matches('\u{feff}')
        .lines()
        .next()
        .is_some_and(|l| l.ends_with("Properties:") || l.contains("properties:"));
    starts_with_block && it.any(|l| list_of(l.trim_end_matches('\r')).is_some())
}

/// The rows of an event list's table from line index `start`, as messages; rows that are not
/// one are counted in `rows`.
fn event_rows(all: &[(usize, &str)], start: usize, rows: &mut RowAccount) -> Vec<Message> {
    let mut out = Vec::new();
    for &(no, line) in &all[start..] {
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        let f = split(line, Separator::Tab);
        let Ok(Some(t)) = number(f[0].1, Separator::Tab) else {
            rows.reject("`Timestamp` is not a number", no, 1, line);
            continue;
        };
        let words: Vec<&str> = f[1..]
            .iter()
            .map(|x| x.1.trim())
            .filter(|w| !w.is_empty())
            .collect();
        rows.messages += 1;
        out.push(Message {
            time_us: (t * 1000.0).round() as i64,
            trial: 1,
            text: words.join(" "),
        });
    }
    out
}

/// The `key: value` block before the table: screen, subject, and every entry kept.
fn read_header_block(block: &[(usize, &str)], header: &mut Header, rows: &mut RowAccount) {
    for &(_, line) in block {
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        rows.header_lines += 1;
        if let Some((k, v)) = line.split_once(':') {
            let (k, v) = (k.trim(), v.trim());
            match k {
                "Screen resolution" | "Recording resolution" => {
                    let wh: Vec<f64> = v.split('x').filter_map(|p| p.trim().parse().ok()).collect();
                    if wh.len() == 2 && wh[0] > 0.0 && wh[1] > 0.0 {
                        header.calibration_area_px = Some([wh[0], wh[1]]);
                    }
                }
                "Subject" | "Participant" if !v.is_empty() => header.subject = Some(v.to_string()),
                _ => {}
            }
            header.entries.push((k.to_string(), v.to_string()));
        }
    }
}

/// Reads a Studio list export; `path` names it in messages.
pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let mut header = Header {
        banner: Some("Tobii Studio list export".into()),
        ..Header::default()
    };
    let mut rows = RowAccount {
        lines: all.len(),
        ..Default::default()
    };
    let Some((table_at, list)) = all
        .iter()
        .enumerate()
        .find_map(|(k, (_, l))| list_of(l).map(|t| (k, t)))
    else {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "a Tobii Studio list export without its `FixationIndex\tTimestamp…` or `Timestamp\tEvent…` table".into(),
        });
    };
    read_header_block(&all[..table_at], &mut header, &mut rows);
    rows.header_lines += 1; // the table's header line
    let columns: Vec<String> = split(all[table_at].1, Separator::Tab)
        .iter()
        .map(|(_, c)| c.trim().to_string())
        .filter(|c| !c.is_empty())
        .collect();
    if list == List::Events {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "a Tobii Studio event list: it holds events (mouse clicks, logged messages) but no gaze. Give the recording's fixation list (`…-Fixation-Data.tsv`, exported beside it), whose messages meshgaze reads from this file".into(),
        });
    }
    let mut events = Vec::new();
    for &(no, line) in &all[table_at + 1..] {
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        let f = split(line, Separator::Tab);
        if f.len() < 5 {
            rows.reject("fixation row with fewer than its 5 values", no, 1, line);
            continue;
        }
        let vals: Result<Vec<Option<f64>>, usize> = (0..5)
            .map(|i| number(f[i].1, Separator::Tab).map_err(|_| i))
            .collect();
        let v = match vals {
            Ok(v) => v,
            Err(i) => {
                let reason = format!("`{}` is not a number", columns.get(i).map_or("?", |c| c));
                rows.reject(&reason, no, f[i].0, line);
                continue;
            }
        };
        let (Some(index), Some(t), Some(d)) = (v[0], v[1], v[2]) else {
            rows.reject(
                "fixation row without its index, time or duration",
                no,
                1,
                line,
            );
            continue;
        };
        if t < 0.0 || d < 0.0 || index < 0.0 {
            rows.reject("negative fixation time or duration", no, f[1].0, line);
            continue;
        }
        // Beyond ±2^53 µs a time is no longer exact, and its end would overflow.
        if t > 9.0e12 || d > 9.0e12 {
            rows.reject("fixation time or duration beyond 2^53 µs", no, f[1].0, line);
            continue;
        }
        let (start, duration) = ((t * 1000.0).round() as i64, (d * 1000.0).round() as i64);
        rows.events += 1;
        events.push(Event {
            x: v[3],
            y: v[4],
            ..Event::span(
                EventKind::Fixation,
                Eye::Binocular,
                index as u64,
                start,
                start + duration,
                duration,
            )
        });
    }
    let mut notes =
        vec!["Tobii Studio fixation list: times in ms from the recording's start".to_string()];
    if header.calibration_area_px.is_none() {
        notes.push("no `Screen resolution:` line: the screen size is not in the file".into());
    }
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::TobiiStudioList,
        header,
        columns,
        samples: Vec::new(),
        messages: Vec::new(),
        events,
        rows,
        notes,
    })
}

/// The messages of the event list beside a fixation list (`X-Fixation-Data.tsv` →
/// `X-Event-Data.tsv`), with the file read and its rows that were not messages; None when
/// there is no such file.
pub fn sibling_event_messages(file: &std::path::Path) -> Option<(Vec<Message>, String, usize)> {
    let name = file.file_name()?.to_string_lossy().to_string();
    let sibling = file.with_file_name(name.replace("-Fixation-Data", "-Event-Data"));
    if sibling == file {
        return None;
    }
    let bytes = std::fs::read(&sibling).ok()?;
    let text = decode(&bytes);
    let all = lines(&text);
    let start = all
        .iter()
        .position(|(_, l)| list_of(l) == Some(List::Events))?
        + 1;
    let mut rows = RowAccount::default();
    let messages = event_rows(&all, start, &mut rows);
    Some((
        messages,
        sibling.display().to_string(),
        rows.unusable_total(),
    ))
}

//! Pupil Labs exports with gaze on a screen surface, into the one record model.
//!
//! A head-worn tracker sees the world through its scene camera; a screen position exists only
//! where the export maps gaze onto a surface tracked on the screen:
//! * Pupil Core (Pupil Player's Surface Tracker): `surfaces/gaze_positions_on_surface_<name>.csv`
//!   (`gaze_timestamp` s, `x_norm`/`y_norm` on the surface with the origin bottom-left,
//!   `on_surf`, `confidence`) and `fixations_on_surface_<name>.csv` (one row per world frame
//!   of each `fixation_id`, `start_timestamp` s, `duration` ms, `norm_pos_x/y`, `on_surf`).
//!   Messages are read from `surface_events.csv` beside the file (`Surface 1 enter`) and from
//!   Pupil Player's `annotations.csv` in the export folder above it (`label`).
//! * Neon / Invisible (Pupil Cloud's Marker Mapper enrichment): `gaze.csv` (`timestamp [ns]`,
//!   `gaze detected on surface`, `gaze position on surface x/y [normalized]`, origin top-left)
//!   and `fixations.csv` (`start`/`end timestamp [ns]`, `fixation x/y [normalized]`);
//!   messages from `events.csv` beside the file.
//!
//! Positions are fractions of the surface; ingest scales them to the screen with `--screen` or
//! the protocol's display. A sample counts as tracked where it is on the surface and, for
//! Core, its confidence is at least 0.6 (Pupil Player's default minimum data confidence).
//!
//! A world-camera export (`gaze_positions.csv`, `fixations.csv` with `norm_pos_x` but no
//! surface; Neon's `gaze x [px]` scene-camera pixels) has no screen position and is refused,
//! saying how to get one.
use std::collections::BTreeMap;

use super::recording::{
    Event, EventKind, Eye, EyeSample, GazeError, GazeFormat, Header, Message, Recording,
    RowAccount, Sample,
};
use super::table_scan::{first_line, for_each_row, lines_estimate};
use super::text::{decode, lines, split, Separator};

/// Pupil Player's default minimum data confidence.
pub const MIN_CONFIDENCE: f64 = 0.6;

/// What a Pupil Labs table is, from its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Table {
    CoreSurfaceGaze,
    CoreSurfaceFixations,
    CloudSurfaceGaze,
    CloudSurfaceFixations,
    /// World-camera gaze or fixations: no screen position.
    WorldCamera,
}

fn table_of(first_line: &str) -> Option<Table> {
    let f = first_line.trim_start_matches('\u{feff}');
    let has = |c: &str| f.split(',').any(|x| x.trim() == c);
    if has("gaze_timestamp") && has("x_norm") && has("on_surf") {
        Some(Table::CoreSurfaceGaze)
    } else if has("fixation_id") && has("norm_pos_x") && has("on_surf") {
        Some(Table::CoreSurfaceFixations)
    } else if has("gaze position on surface x [normalized]") {
        Some(Table::CloudSurfaceGaze)
    } else if has("fixation x [normalized]") {
        Some(Table::CloudSurfaceFixations)
    } else if (has("gaze_timestamp") && has("norm_pos_x"))
        || (has("start_timestamp") && has("norm_pos_x") && has("start_frame_index"))
        || (has("timestamp [ns]") && (has("gaze x [px]") || has("fixation x [px]")))
    {
        Some(Table::WorldCamera)
    } else {
        None
    }
}

/// Whether the first line is a Pupil Labs gaze or fixation export (surface or world camera).
pub(crate) fn looks_like(first_line: &str) -> bool {
    table_of(first_line).is_some()
}

/// Whether the first line is one of Pupil Cloud's exports (as opposed to Pupil Player's).
pub(crate) fn is_cloud(first_line: &str) -> bool {
    matches!(
        table_of(first_line),
        Some(Table::CloudSurfaceGaze | Table::CloudSurfaceFixations)
    ) || first_line.contains("timestamp [ns]")
}

/// Why a world-camera export is refused, and what gives a screen position instead.
fn world_camera_refusal() -> String {
    "a Pupil Labs world-camera export: its positions are in the scene camera's image, not on the screen, so no fixation can be placed on a stimulus. For Pupil Core, define a surface on the screen (AprilTag markers at its corners) in Pupil Player's Surface Tracker and export `surfaces/gaze_positions_on_surface_<name>.csv` and `fixations_on_surface_<name>.csv`; for Neon or Invisible, run a Marker Mapper enrichment in Pupil Cloud and give its `gaze.csv` / `fixations.csv`".into()
}

fn truthy(v: &str) -> Option<bool> {
    match v.trim() {
        "True" | "true" | "TRUE" | "1" => Some(true),
        "False" | "false" | "FALSE" | "0" => Some(false),
        _ => None,
    }
}

/// A fixation collected over its rows (Core writes one per world frame).
struct Open {
    start_us: i64,
    end_us: i64,
    sum: (f64, f64, usize),
}

/// The columns a table's rows are read from.
struct Columns {
    time: usize,
    x: usize,
    y: usize,
    /// `on_surf` / `… detected on surface`.
    on: Option<usize>,
    confidence: Option<usize>,
    fixation_id: Option<usize>,
    /// Duration in ms (Core) or the end time (Cloud) of a fixation.
    duration: Option<usize>,
    end: Option<usize>,
}

/// The columns of `table`, by name; an error names a missing required one.
fn columns_of(table: Table, names: &[String], path: &str) -> Result<Columns, GazeError> {
    let col = |n: &str| names.iter().position(|c| c == n);
    let need = |n: &str| {
        col(n).ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: format!("a Pupil Labs export without the `{n}` column"),
        })
    };
    let (time, x, y, on, confidence, fixation_id, duration, end) = match table {
        Table::CoreSurfaceGaze => (
            need("gaze_timestamp")?,
            need("x_norm")?,
            need("y_norm")?,
            col("on_surf"),
            col("confidence"),
            None,
            None,
            None,
        ),
        Table::CoreSurfaceFixations => (
            need("start_timestamp")?,
            need("norm_pos_x")?,
            need("norm_pos_y")?,
            col("on_surf"),
            None,
            Some(need("fixation_id")?),
            Some(need("duration")?),
            None,
        ),
        Table::CloudSurfaceGaze => (
            need("timestamp [ns]")?,
            need("gaze position on surface x [normalized]")?,
            need("gaze position on surface y [normalized]")?,
            col("gaze detected on surface"),
            None,
            None,
            None,
            None,
        ),
        _ => (
            need("start timestamp [ns]")?,
            need("fixation x [normalized]")?,
            need("fixation y [normalized]")?,
            col("fixation detected on surface"),
            None,
            Some(need("fixation id")?),
            col("duration [ms]"),
            col("end timestamp [ns]"),
        ),
    };
    Ok(Columns {
        time,
        x,
        y,
        on,
        confidence,
        fixation_id,
        duration,
        end,
    })
}

/// The table a file's header line starts and its column names; world-camera tables are
/// refused here.
fn table_and_names(first: Option<&str>, path: &str) -> Result<(Table, Vec<String>), GazeError> {
    let Some(first) = first else {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "the file is empty".into(),
        });
    };
    let table = table_of(first).ok_or_else(|| GazeError::At {
        path: path.to_string(),
        line: 1,
        column: 1,
        message: "not a Pupil Labs gaze or fixation export".into(),
    })?;
    if table == Table::WorldCamera {
        return Err(GazeError::File {
            path: path.to_string(),
            message: world_camera_refusal(),
        });
    }
    let names = split(first, Separator::Comma)
        .iter()
        .map(|(_, c)| c.trim().to_string())
        .collect();
    Ok((table, names))
}

/// A surface gaze sample: the position where it is tracked on the surface, else lost.
fn surface_sample(time_us: i64, tracked: Option<(f64, f64)>) -> Sample {
    let (x, y) = tracked.unwrap_or((0.0, 0.0));
    Sample {
        time_us,
        trial: 1,
        left: None,
        right: None,
        binocular: Some(EyeSample {
            x,
            y,
            pupil: None,
            valid: tracked.is_some(),
            flag_lost: tracked.is_none(),
        }),
        binocular_event: None,
        left_event: None,
        right_event: None,
        stimulus: None,
    }
}

/// Adds one world frame's row of fixation `id` (its point where it is on the surface).
fn add_fixation_row(
    fixations: &mut BTreeMap<String, Open>,
    order: &mut Vec<String>,
    id: &str,
    start_us: i64,
    end_us: i64,
    point: Option<(f64, f64)>,
) {
    if !fixations.contains_key(id) {
        order.push(id.to_string());
    }
    let o = fixations.entry(id.to_string()).or_insert(Open {
        start_us,
        end_us,
        sum: (0.0, 0.0, 0),
    });
    if let Some((a, b)) = point {
        o.sum = (o.sum.0 + a, o.sum.1 + b, o.sum.2 + 1);
    }
}

/// What the notes say of a surface export.
fn notes_of(cloud: bool, low_confidence: usize, off_surface: usize) -> Vec<String> {
    let mut notes = vec![format!(
        "Pupil Labs {} surface export: positions are fractions of the surface (origin {})",
        if cloud {
            "Cloud (Marker Mapper)"
        } else {
            "Core (Surface Tracker)"
        },
        if cloud {
            "top-left"
        } else {
            "bottom-left, flipped to top-left"
        }
    )];
    if low_confidence > 0 {
        notes.push(format!(
            "{low_confidence} samples below confidence {MIN_CONFIDENCE} count as lost"
        ));
    }
    if off_surface > 0 {
        notes.push(format!(
            "{off_surface} fixations never on the surface have no position"
        ));
    }
    notes
}

/// Pupil time (s) or Cloud time (ns) as µs.
fn time_us(v: f64, cloud: bool) -> i64 {
    if cloud {
        (v / 1000.0).round() as i64
    } else {
        (v * 1e6).round() as i64
    }
}

/// Whether a row is on the surface: its own column where it has one (Err: the column's index
/// when the value is neither True nor False), else a position inside the unit square.
fn on_surface_of(
    on: Option<usize>,
    f: &[(usize, &str)],
    px: Option<f64>,
    py: Option<f64>,
) -> Result<bool, usize> {
    match on {
        Some(i) => truthy(f[i].1).ok_or(i),
        None => Ok(px.is_some_and(|v| (0.0..=1.0).contains(&v))
            && py.is_some_and(|v| (0.0..=1.0).contains(&v))),
    }
}

/// Reads a Pupil Labs surface export; `path` names it in messages.
pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let head = first_line(bytes);
    let (table, names) = table_and_names(head.as_ref().map(|(l, _)| &**l), path)?;
    let body_start = head.map_or(bytes.len(), |(_, next)| next);
    let cloud = matches!(
        table,
        Table::CloudSurfaceGaze | Table::CloudSurfaceFixations
    );
    let Columns {
        time,
        x,
        y,
        on,
        confidence,
        fixation_id,
        duration,
        end,
    } = columns_of(table, &names, path)?;
    let to_us = |v: f64| time_us(v, cloud);
    let mut rows = RowAccount {
        header_lines: 1,
        ..Default::default()
    };
    let mut samples = Vec::with_capacity(lines_estimate(&bytes[body_start..]));
    let mut fixations: BTreeMap<String, Open> = BTreeMap::new();
    let mut order: Vec<String> = Vec::new();
    let mut low_confidence = 0usize;
    let n = names.len();
    let mut wanted = vec![false; n];
    let used = [
        Some(time),
        Some(x),
        Some(y),
        on,
        confidence,
        fixation_id,
        duration,
        end,
    ];
    for i in used.into_iter().flatten().filter(|&i| i < n) {
        wanted[i] = true;
    }
    // Pupil's exports hold no quoted field; a `"` is an ordinary byte, as before.
    rows.lines = for_each_row(
        bytes,
        body_start,
        2,
        Separator::Comma,
        &wanted,
        false,
        |row| {
            let (no, line, count) = (row.no, row.line, row.count);
            if line.trim().is_empty() {
                rows.blank_lines += 1;
                return;
            }
            // Only the wanted columns' fields are filled; a row of the header's width has them.
            let f = row.fields.unwrap_or(&[]);
            if count != n || f.len() != n {
                let reason = format!("row with a field count other than the header's {n}");
                rows.reject(&reason, no, 1, line);
                return;
            }
            let num = |i: usize| f[i].1.trim().parse::<f64>().ok().filter(|v| v.is_finite());
            let Some(t) = num(time) else {
                rows.reject(
                    &format!("`{}` is not a number", names[time]),
                    no,
                    f[time].0,
                    line,
                );
                return;
            };
            let (px, py) = (num(x), num(y));
            let on_surface = match on_surface_of(on, f, px, py) {
                Ok(b) => b,
                Err(i) => {
                    let reason = format!("`{}` is neither True nor False", names[i]);
                    rows.reject(&reason, no, f[i].0, line);
                    return;
                }
            };
            let conf = confidence.and_then(num);
            let t_us = to_us(t);
            // Core's surface origin is bottom-left, Cloud's top-left; the record model's is top-left.
            let pos = match (px, py) {
                (Some(a), Some(b)) => Some((a, if cloud { b } else { 1.0 - b })),
                _ => None,
            };
            if let Some(id_col) = fixation_id {
                let end_us = match (end.and_then(num), duration.and_then(num)) {
                    (Some(e), _) => to_us(e),
                    (None, Some(d_ms)) => t_us.saturating_add((d_ms * 1000.0).round() as i64),
                    (None, None) => t_us,
                };
                let point = pos.filter(|_| on_surface);
                add_fixation_row(
                    &mut fixations,
                    &mut order,
                    f[id_col].1.trim(),
                    t_us,
                    end_us,
                    point,
                );
                rows.events += 1;
                return;
            }
            let confident = conf.is_none_or(|c| c >= MIN_CONFIDENCE);
            low_confidence += (!confident) as usize;
            let valid = on_surface && confident && pos.is_some();
            rows.samples += 1;
            samples.push(surface_sample(t_us, pos.filter(|_| valid)));
        },
    );
    // Pupil Player writes gaze rows per world frame, not in gaze-time order.
    samples.sort_by_key(|s| s.time_us);
    let (mut events, off_surface) = fixation_events(&order, &fixations);
    events.sort_by_key(|e| e.start_us);
    let notes = notes_of(cloud, low_confidence, off_surface);
    Ok(Recording {
        file: path.to_string(),
        format: if cloud {
            GazeFormat::PupilCloud
        } else {
            GazeFormat::PupilCore
        },
        header: Header {
            banner: Some("Pupil Labs surface export".into()),
            normalized: true,
            ..Header::default()
        },
        columns: names,
        samples,
        messages: Vec::new(),
        events,
        rows,
        notes,
    })
}

/// One fixation event per id, in file order, at the mean of its on-surface rows; and how
/// many were never on the surface.
fn fixation_events(order: &[String], fixations: &BTreeMap<String, Open>) -> (Vec<Event>, usize) {
    let mut off_surface = 0;
    let mut events = Vec::new();
    for (k, id) in order.iter().enumerate() {
        let o = &fixations[id];
        if o.sum.2 == 0 {
            off_surface += 1;
        }
        let (fx, fy) = if o.sum.2 > 0 {
            (
                Some(o.sum.0 / o.sum.2 as f64),
                Some(o.sum.1 / o.sum.2 as f64),
            )
        } else {
            (None, None)
        };
        events.push(Event {
            x: fx,
            y: fy,
            ..Event::span(
                EventKind::Fixation,
                Eye::Binocular,
                k as u64 + 1,
                o.start_us,
                o.end_us.max(o.start_us),
                o.end_us.max(o.start_us) - o.start_us,
            )
        });
    }
    (events, off_surface)
}

/// Messages of the files Pupil Labs writes beside a surface export: `surface_events.csv`
/// (`world_timestamp`, `surface_name`, `event_type`) and Player's `annotations.csv`
/// (`timestamp`, `label`) for Core; Cloud's `events.csv` (`timestamp [ns]`, `name`). Returns
/// the messages and, per file read, its path, its messages and its lines that were not one
/// (counted, so none is lost unsaid).
pub fn sibling_messages(
    file: &std::path::Path,
    cloud: bool,
) -> (Vec<Message>, Vec<(String, usize, usize)>) {
    let dir = file.parent().unwrap_or(std::path::Path::new("."));
    let candidates: Vec<(std::path::PathBuf, &[&str], bool)> = if cloud {
        vec![(dir.join("events.csv"), &["timestamp [ns]", "name"], true)]
    } else {
        vec![
            (
                dir.join("surface_events.csv"),
                &["world_timestamp", "surface_name", "event_type"],
                false,
            ),
            (
                dir.parent().unwrap_or(dir).join("annotations.csv"),
                &["timestamp", "label"],
                false,
            ),
            (dir.join("annotations.csv"), &["timestamp", "label"], false),
        ]
    };
    let mut out = Vec::new();
    let mut used = Vec::new();
    for (p, cols, ns) in candidates {
        if used.iter().any(|(u, _, _)| *u == p.display().to_string()) {
            continue;
        }
        let Ok(bytes) = std::fs::read(&p) else {
            continue;
        };
        let text = decode(&bytes);
        let all = lines(&text);
        let Some(&(_, head)) = all.first() else {
            continue;
        };
        let names: Vec<&str> = head.split(',').map(str::trim).collect();
        let idx: Option<Vec<usize>> = cols
            .iter()
            .map(|c| names.iter().position(|n| n == c))
            .collect();
        let Some(idx) = idx else { continue };
        let (before, mut skipped) = (out.len(), 0);
        for &(_, line) in &all[1..] {
            let f: Vec<&str> = line.split(',').collect();
            if f.len() != names.len() {
                skipped += 1;
                continue;
            }
            let Some(t) = f[idx[0]]
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
            else {
                skipped += 1;
                continue;
            };
            let text = idx[1..]
                .iter()
                .map(|&i| f[i].trim())
                .collect::<Vec<_>>()
                .join(" ");
            out.push(Message {
                time_us: if ns {
                    (t / 1000.0).round() as i64
                } else {
                    (t * 1e6).round() as i64
                },
                trial: 1,
                text,
            });
        }
        used.push((p.display().to_string(), out.len() - before, skipped));
    }
    out.sort_by_key(|m| m.time_us);
    (out, used)
}

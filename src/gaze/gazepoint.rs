//! Gazepoint (GP3, GP3 HD) exports of Gazepoint Analysis: `*_all_gaze.csv` (one row per
//! sample) and `*_fixations.csv` (one row per fixation), into the one record model.
//!
//! Columns (Gazepoint's API names): `TIME(2022/09/19 13:34:49.156)` seconds since the
//! recording started (its start in the name), `TIMETICK(f=10000000)` the tracker's ticks,
//! `MEDIA_NAME` the stimulus shown, `FPOGX/FPOGY` the fixation point of gaze and `FPOGS`,
//! `FPOGD`, `FPOGID`, `FPOGV` its start (s), duration so far (s), id and validity, `BPOGX/BPOGY`
//! / `BPOGV` the best point of gaze (both eyes), `LPOGX/LPOGY`, `RPOGX/RPOGY` per eye when
//! exported, `LPMM`/`RPMM` pupil diameters (mm), `USER` what the experiment logged. Positions
//! are fractions of the screen (origin top-left); the file does not give the screen's size,
//! so ingest scales them with `--screen` or the protocol's display and says so.
//!
//! Fixations are Gazepoint's own: the rows of one valid `FPOGID`, whose last row holds the
//! fixation's final position and duration (the tracker updates both while it lasts).
use std::collections::BTreeMap;

use super::recording::{
    Event, EventKind, Eye, EyeSample, GazeError, GazeFormat, Header, Message, Recording,
    RowAccount, Sample, SharedNames,
};
use super::table_scan::{first_line, for_each_row, lines_estimate};
use super::text::{number, split, Separator};

/// Whether the first line is a Gazepoint Analysis export's header.
pub(crate) fn looks_like(first_line: &str) -> bool {
    let f = first_line.trim_start_matches('\u{feff}');
    f.contains("FPOGX") && f.contains("FPOGY") && (f.contains("TIME(") || f.contains("TIME,"))
}

struct Columns {
    time: usize,
    media: Option<usize>,
    user: Option<usize>,
    count: Option<usize>,
    fpog: [usize; 2],
    fpog_start: Option<usize>,
    fpog_duration: Option<usize>,
    fpog_id: Option<usize>,
    fpog_valid: Option<usize>,
    best: Option<[usize; 3]>,
    left: Option<[usize; 3]>,
    right: Option<[usize; 3]>,
    pupil: [Option<usize>; 2],
}

impl Columns {
    /// Which of `n` columns the reader looks at (~20 of Gazepoint's ~50).
    fn wanted(&self, n: usize) -> Vec<bool> {
        let mut wanted = vec![false; n];
        let used = [
            Some(self.time),
            self.media,
            self.user,
            self.count,
            Some(self.fpog[0]),
            Some(self.fpog[1]),
            self.fpog_start,
            self.fpog_duration,
            self.fpog_id,
            self.fpog_valid,
            self.pupil[0],
            self.pupil[1],
        ]
        .into_iter()
        .flatten()
        .chain(
            [self.best, self.left, self.right]
                .into_iter()
                .flatten()
                .flatten(),
        );
        for i in used.filter(|&i| i < n) {
            wanted[i] = true;
        }
        wanted
    }
}

fn columns_of(names: &[String], path: &str) -> Result<Columns, GazeError> {
    let col = |n: &str| names.iter().position(|c| c == n);
    let need = |n: &str| {
        col(n).ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: format!("a Gazepoint export without the `{n}` column"),
        })
    };
    let time = names
        .iter()
        .position(|c| c == "TIME" || c.starts_with("TIME("))
        .ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message:
                "a Gazepoint export without a `TIME(…)` column: the time of each row is needed"
                    .into(),
        })?;
    let triple = |x: &str, y: &str, v: &str| Some([col(x)?, col(y)?, col(v)?]);
    Ok(Columns {
        time,
        media: col("MEDIA_NAME"),
        user: col("USER"),
        count: col("CNT"),
        fpog: [need("FPOGX")?, need("FPOGY")?],
        fpog_start: col("FPOGS"),
        fpog_duration: col("FPOGD"),
        fpog_id: col("FPOGID"),
        fpog_valid: col("FPOGV"),
        best: triple("BPOGX", "BPOGY", "BPOGV"),
        left: triple("LPOGX", "LPOGY", "LPOGV"),
        right: triple("RPOGX", "RPOGY", "RPOGV"),
        pupil: [col("LPMM"), col("RPMM")],
    })
}

/// `TIME(2022/09/19 13:34:49.156)`: the recording's start.
fn start_of(name: &str) -> Option<chrono::NaiveDateTime> {
    let inner = name.strip_prefix("TIME(")?.strip_suffix(')')?;
    chrono::NaiveDateTime::parse_from_str(inner, "%Y/%m/%d %H:%M:%S%.f").ok()
}

/// A fixation id's rows so far.
struct Open {
    start_us: i64,
    last_us: i64,
    duration_us: i64,
    x: f64,
    y: f64,
    stimulus: Option<String>,
}

/// The numbers of one row: time, eyes, the fixation point and its start, duration, id and
/// validity, the sample counter.
struct Row {
    t: f64,
    left: Option<EyeSample>,
    right: Option<EyeSample>,
    best: Option<EyeSample>,
    fpog: (Option<f64>, Option<f64>),
    fix: (Option<f64>, Option<f64>, Option<f64>, Option<f64>),
    count: Option<f64>,
}

/// Parses a row's fields; Err: the index of a field that is not a number.
fn parse_row(c: &Columns, f: &[(usize, &str)], sep: Separator) -> Result<Row, usize> {
    let get = |i: Option<usize>| -> Result<Option<f64>, usize> {
        match i {
            Some(i) if i < f.len() => number(f[i].1, sep).map_err(|_| i),
            _ => Ok(None),
        }
    };
    let eye =
        |cols: Option<[usize; 3]>, pupil: Option<usize>| -> Result<Option<EyeSample>, usize> {
            let Some([x, y, v]) = cols else {
                return Ok(None);
            };
            let (x, y, v) = (get(Some(x))?, get(Some(y))?, get(Some(v))?);
            let valid = v == Some(1.0) && x.is_some() && y.is_some();
            Ok(Some(EyeSample {
                x: if valid { x.unwrap_or(0.0) } else { 0.0 },
                y: if valid { y.unwrap_or(0.0) } else { 0.0 },
                pupil: get(pupil)?.filter(|p| *p > 0.0),
                valid,
                flag_lost: !valid,
            }))
        };
    Ok(Row {
        t: get(Some(c.time))?.ok_or(c.time)?,
        left: eye(c.left, c.pupil[0])?,
        right: eye(c.right, c.pupil[1])?,
        best: eye(c.best, None)?,
        fpog: (get(Some(c.fpog[0]))?, get(Some(c.fpog[1]))?),
        fix: (
            get(c.fpog_start)?,
            get(c.fpog_duration)?,
            get(c.fpog_id)?,
            get(c.fpog_valid)?,
        ),
        count: get(c.count).ok().flatten(),
    })
}

/// Folds a row of fixation `id` into it: the tracker updates the position and duration
/// while the fixation lasts, so the last row's are the fixation's.
/// `row` is made only for a fixation's first row: its stimulus name is copied once, not on
/// each of the fixation's ~60 rows.
fn add_fixation_row(
    fixations: &mut BTreeMap<u64, Open>,
    id: u64,
    (t_us, x, y, duration_us): (i64, f64, f64, i64),
    row: impl FnOnce() -> Open,
) {
    let e = fixations.entry(id).or_insert_with(row);
    e.last_us = t_us;
    e.x = x;
    e.y = y;
    e.duration_us = e.duration_us.max(duration_us);
}

/// The fixation export has the all-gaze columns but one row per fixation: its sample
/// counter `CNT` jumps. Its rows are fixations, not samples to detect fixations in.
fn is_fixation_table(counts: &[f64]) -> bool {
    let mut steps: Vec<f64> = counts.windows(2).map(|w| w[1] - w[0]).collect();
    steps.sort_by(f64::total_cmp);
    steps.get(steps.len() / 2).is_some_and(|&d| d > 1.0)
}

/// One fixation event per valid FPOGID, with its stimulus's onset (its first row).
fn fixation_events(
    fixations: BTreeMap<u64, Open>,
    first_named: &BTreeMap<String, i64>,
) -> Vec<Event> {
    fixations
        .into_iter()
        .map(|(id, o)| {
            let duration = if o.duration_us > 0 {
                o.duration_us
            } else {
                (o.last_us - o.start_us).max(0)
            };
            let onset = o
                .stimulus
                .as_ref()
                .and_then(|s| first_named.get(s).copied());
            Event {
                x: Some(o.x),
                y: Some(o.y),
                stimulus: o.stimulus,
                stimulus_onset_us: onset,
                ..Event::span(
                    EventKind::Fixation,
                    Eye::Binocular,
                    id,
                    o.start_us,
                    o.start_us.saturating_add(duration),
                    duration,
                )
            }
        })
        .collect()
}

/// The header line's separator, column names and the columns read.
fn header_row(
    first: Option<&str>,
    path: &str,
) -> Result<(Separator, Vec<String>, Columns), GazeError> {
    let Some(first) = first else {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "the file is empty".into(),
        });
    };
    let sep = Separator::sniff(first);
    let names: Vec<String> = split(first, sep)
        .iter()
        .map(|(_, c)| c.trim().to_string())
        .collect();
    let c = columns_of(&names, path)?;
    Ok((sep, names, c))
}

/// A sample of the per-eye points of gaze (the best point and stimulus are the caller's).
fn gaze_sample(time_us: i64, left: Option<EyeSample>, right: Option<EyeSample>) -> Sample {
    Sample {
        time_us,
        trial: 1,
        left,
        right,
        binocular: None,
        binocular_event: None,
        left_event: None,
        right_event: None,
        stimulus: None,
    }
}

/// Reads a Gazepoint Analysis export; `path` names it in messages.
pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let head = first_line(bytes);
    let (sep, names, c) = header_row(head.as_ref().map(|(l, _)| &**l), path)?;
    let body_start = head.map_or(bytes.len(), |(_, next)| next);
    let header = Header {
        banner: Some("Gazepoint Analysis export".into()),
        date: start_of(&names[c.time]),
        normalized: true,
        ..Header::default()
    };
    let mut rows = RowAccount {
        header_lines: 1,
        ..Default::default()
    };
    let mut samples = Vec::with_capacity(lines_estimate(&bytes[body_start..]));
    let mut messages = Vec::new();
    let mut fixations: BTreeMap<u64, Open> = BTreeMap::new();
    let mut first_named: BTreeMap<String, i64> = BTreeMap::new();
    let mut counts: Vec<f64> = Vec::new();
    let n = names.len();
    let wanted = c.wanted(n);
    let mut stimulus_names = SharedNames::default();
    // A `"` is an ordinary byte in Gazepoint's tables (it writes no quoted fields).
    rows.lines = for_each_row(bytes, body_start, 2, sep, &wanted, false, |line| {
        let (no, count, line, fields) = (line.no, line.count, line.line, line.fields);
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            return;
        }
        let f = fields.map_or(&[][..], |f| &f[..count.min(f.len())]);
        // Gazepoint ends every line with a comma: the header's last name is empty.
        let fits = count == n || (count + 1 == n && names[n - 1].is_empty());
        if !fits {
            let reason = format!("row with a field count other than the header's {n}");
            rows.reject(&reason, no, 1, line);
            return;
        }
        let text_of = |i: Option<usize>| {
            i.and_then(|i| f.get(i))
                .map(|x| x.1.trim())
                .filter(|v| !v.is_empty())
        };
        let Row {
            t,
            left,
            right,
            best,
            fpog,
            fix: (fs, fd, id, fv),
            count,
        } = match parse_row(&c, f, sep) {
            Ok(v) => v,
            Err(i) => {
                let reason = format!("`{}` is not a number", names[i]);
                rows.reject(&reason, no, f[i].0, line);
                return;
            }
        };
        if t < 0.0 {
            rows.reject("negative TIME", no, f[c.time].0, line);
            return;
        }
        let t_us = (t * 1e6).round() as i64;
        if let Some(k) = count {
            counts.push(k);
        }
        let stimulus = text_of(c.media).map(|t| stimulus_names.of(t));
        if let Some(s) = stimulus
            .as_deref()
            .filter(|s| !first_named.contains_key(*s))
        {
            first_named.insert(s.to_string(), t_us);
        }
        if let Some(u) = text_of(c.user) {
            messages.push(Message {
                time_us: t_us,
                trial: 1,
                text: u.to_string(),
            });
        }
        if let (Some(id), Some(1.0), (Some(x), Some(y))) = (id, fv, fpog) {
            let start_us = fs.map_or(t_us, |s| (s * 1e6).round() as i64);
            let duration_us = fd.map_or(0, |d| (d * 1e6).round() as i64);
            let open = || Open {
                start_us,
                last_us: t_us,
                duration_us,
                x,
                y,
                stimulus: stimulus.as_deref().map(str::to_string),
            };
            add_fixation_row(&mut fixations, id as u64, (t_us, x, y, duration_us), open);
        }
        rows.samples += 1;
        samples.push(Sample {
            binocular: best,
            stimulus,
            ..gaze_sample(t_us, left, right)
        });
    });
    let events = fixation_events(fixations, &first_named);
    let mut rec = Recording {
        file: path.to_string(),
        format: GazeFormat::Gazepoint,
        header,
        columns: names,
        samples,
        messages,
        events,
        rows,
        notes: Vec::new(),
    };
    tell_table_kind(&mut rec, &counts);
    Ok(rec)
}

/// A fixation export repeats the all-gaze columns with one row per fixation (its sample
/// counter jumps): its rows are events, not samples. Says which kind the file is, and gives
/// an all-gaze export its sampling rate.
fn tell_table_kind(rec: &mut Recording, counts: &[f64]) {
    let note = if is_fixation_table(counts) {
        rec.rows.events = rec.rows.samples;
        rec.rows.samples = 0;
        rec.samples.clear();
        "Gazepoint fixation export (one row per fixation: its sample counter CNT jumps); positions are fractions of the screen"
    } else {
        // A fixation table's rows are far apart and irregular: no rate from fewer than 10.
        rec.header.sample_rate_hz = super::recording::median_rate_hz(&rec.samples, 10);
        "Gazepoint all-gaze export; positions are fractions of the screen"
    };
    rec.notes.push(note.to_string());
}

//! Format C2: BeGaze "Raw Data" export. One header row of column names with units in
//! brackets (`RecordingTime [ms]`, `Point of Regard Binocular X [px]`, …), one row per sample,
//! `-` for missing values; TAB natively, other separators when re-exported (the shared ETG
//! file is a pandas comma re-export). Times are milliseconds since the recording started and
//! become integer microseconds.
use super::recording::{
    EyeSample, GazeError, GazeFormat, Header, Recording, RowAccount, Sample, SharedLabels,
    SharedNames,
};
use super::text::{decode, header_row, lines, number, table_row, Separator};

/// Where an eye's X, Y and (optional) pupil columns are.
type EyeColumns = Option<(usize, usize, Option<usize>)>;

/// The columns this reader uses, by name.
struct RawColumns {
    time: usize,
    left: EyeColumns,
    right: EyeColumns,
    binocular: EyeColumns,
    trial: Option<usize>,
    stimulus: Option<usize>,
    participant: Option<usize>,
    category: [Option<usize>; 3],
}

impl RawColumns {
    fn find(columns: &[String], path: &str) -> Result<RawColumns, GazeError> {
        let col = |name: &str| columns.iter().position(|c| c == name);
        let time = col("RecordingTime [ms]").ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line: 1,
            column: 1,
            message: "no `RecordingTime [ms]` column: not a BeGaze Raw Data export".into(),
        })?;
        let eye_cols = |e: &str| {
            Some((
                col(&format!("Point of Regard {e} X [px]"))?,
                col(&format!("Point of Regard {e} Y [px]"))?,
                col(&format!("Pupil Diameter {e} [mm]")),
            ))
        };
        Ok(RawColumns {
            time,
            left: eye_cols("Left"),
            right: eye_cols("Right"),
            binocular: eye_cols("Binocular"),
            trial: col("Trial"),
            stimulus: col("Stimulus"),
            participant: col("Participant"),
            category: [
                col("Category Left"),
                col("Category Right"),
                col("Category Binocular"),
            ],
        })
    }
}

/// One data row's fields, where it is, and how its rejects are counted.
struct Row<'a, 'r> {
    fields: &'a [(usize, &'a str)],
    no: usize,
    line: &'a str,
    sep: Separator,
    columns: &'a [String],
    rows: &'r mut RowAccount,
    names: &'r mut SharedNames,
    labels: &'r mut SharedLabels,
}

impl Row<'_, '_> {
    /// One eye's sample; `Err` when a field is not a number (the row is counted as unusable).
    fn eye(&mut self, c: EyeColumns) -> Result<Option<EyeSample>, ()> {
        let Some((xc, yc, pc)) = c else {
            return Ok(None);
        };
        let x = self.number(xc)?;
        let y = self.number(yc)?;
        let pupil = match pc {
            Some(i) => self.number(i)?,
            None => None,
        };
        Ok(Some(match (x, y) {
            (Some(x), Some(y)) => EyeSample {
                x,
                y,
                pupil,
                valid: !(x == 0.0 && y == 0.0),
                flag_lost: false,
            },
            _ => EyeSample {
                x: 0.0,
                y: 0.0,
                pupil,
                valid: false,
                flag_lost: false,
            },
        }))
    }

    fn number(&mut self, i: usize) -> Result<Option<f64>, ()> {
        number(self.fields[i].1, self.sep).map_err(|_| {
            self.rows.reject(
                &format!("`{}` is not a number", self.columns[i]),
                self.no,
                self.fields[i].0,
                self.line,
            )
        })
    }

    fn label(&mut self, c: Option<usize>) -> Option<std::sync::Arc<str>> {
        c.map(|i| self.labels.of(self.fields[i].1.trim()))
    }

    /// The row's sample, or None when it is unusable (counted).
    fn sample(&mut self, cols: &RawColumns) -> Option<Sample> {
        let (tc, tt) = self.fields[cols.time];
        let time_us = match number(tt, self.sep) {
            Ok(Some(ms)) => (ms * 1000.0).round() as i64,
            _ => {
                self.rows.reject(
                    "`RecordingTime [ms]` is not a number",
                    self.no,
                    tc,
                    self.line,
                );
                return None;
            }
        };
        // `Trial001` → 1.
        let trial = cols
            .trial
            .map(|c| self.fields[c].1.trim())
            .and_then(|t| {
                t.trim_start_matches(|ch: char| !ch.is_ascii_digit())
                    .parse::<u32>()
                    .ok()
            })
            .unwrap_or(1);
        let left = self.eye(cols.left).ok()?;
        let right = self.eye(cols.right).ok()?;
        let binocular = self.eye(cols.binocular).ok()?;
        let [cat_l, cat_r, cat_b] = cols.category;
        Some(Sample {
            time_us,
            trial,
            left,
            right,
            binocular,
            binocular_event: self.label(cat_b),
            left_event: self.label(cat_l),
            right_event: self.label(cat_r),
            stimulus: cols
                .stimulus
                .map(|i| self.names.of(self.fields[i].1.trim())),
        })
    }
}

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let (sep, columns) = header_row(&all, path)?;
    let cols = RawColumns::find(&columns, path)?;
    let mut rows = RowAccount {
        lines: all.len(),
        header_lines: 1,
        ..Default::default()
    };
    let mut header = Header::default();
    let mut samples = Vec::new();
    let mut names = SharedNames::default();
    let mut labels = SharedLabels::default();
    for &(no, line) in &all[1..] {
        let Some(f) = table_row(line, no, sep, columns.len(), &mut rows) else {
            continue;
        };
        let mut row = Row {
            fields: &f,
            no,
            line,
            sep,
            columns: &columns,
            rows: &mut rows,
            names: &mut names,
            labels: &mut labels,
        };
        let Some(sample) = row.sample(&cols) else {
            continue;
        };
        if header.subject.is_none() {
            header.subject = cols
                .participant
                .map(|i| row.fields[i].1.trim().to_string())
                .filter(|p| !super::text::is_missing(p));
        }
        samples.push(sample);
        rows.samples += 1;
    }
    let mut notes = Vec::new();
    if sep != Separator::Tab {
        notes.push(format!(
            "fields separated by {sep:?}, not BeGaze's TAB: a re-exported file"
        ));
    }
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::BeGazeRaw,
        header,
        columns,
        samples,
        messages: Vec::new(),
        events: Vec::new(),
        rows,
        notes,
    })
}

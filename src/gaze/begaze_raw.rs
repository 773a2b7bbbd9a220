//! Format C2: BeGaze "Raw Data" export. One header row of column names with units in
//! brackets (`RecordingTime [ms]`, `Point of Regard Binocular X [px]`, …), one row per sample,
//! `-` for missing values; TAB natively, other separators when re-exported (the shared ETG
//! file is a pandas comma re-export). Times are milliseconds since the recording started and
//! become integer microseconds.
use super::recording::{EyeSample, GazeError, Header, Recording, RowAccount, Sample, SmiFormat};
use super::text::{decode, header_row, lines, number, table_row, Separator};

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let (sep, columns) = header_row(&all, path)?;
    let col = |name: &str| columns.iter().position(|c| c == name);
    let time_c = col("RecordingTime [ms]").ok_or_else(|| GazeError::At {
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
    let (left_c, right_c, bin_c) = (eye_cols("Left"), eye_cols("Right"), eye_cols("Binocular"));
    let (trial_c, stimulus_c, participant_c) = (col("Trial"), col("Stimulus"), col("Participant"));
    let (cat_l, cat_r, cat_b) = (
        col("Category Left"),
        col("Category Right"),
        col("Category Binocular"),
    );
    let mut rows = RowAccount {
        lines: all.len(),
        header_lines: 1,
        ..Default::default()
    };
    let mut header = Header::default();
    let mut samples = Vec::new();
    'rows: for &(no, line) in &all[1..] {
        let Some(f) = table_row(line, no, sep, columns.len(), &mut rows) else {
            continue;
        };
        let (tc, tt) = f[time_c];
        let time_us = match number(tt, sep) {
            Ok(Some(ms)) => (ms * 1000.0).round() as i64,
            _ => {
                rows.reject("`RecordingTime [ms]` is not a number", no, tc, line);
                continue;
            }
        };
        // `Trial001` → 1.
        let trial = trial_c
            .map(|c| f[c].1.trim())
            .and_then(|t| {
                t.trim_start_matches(|ch: char| !ch.is_ascii_digit())
                    .parse::<u32>()
                    .ok()
            })
            .unwrap_or(1);
        let mut eye = |c: Option<(usize, usize, Option<usize>)>| -> Result<Option<EyeSample>, ()> {
            let Some((xc, yc, pc)) = c else {
                return Ok(None);
            };
            let mut get = |i: usize| {
                number(f[i].1, sep).map_err(|_| {
                    rows.reject(
                        &format!("`{}` is not a number", columns[i]),
                        no,
                        f[i].0,
                        line,
                    )
                })
            };
            let x = get(xc)?;
            let y = get(yc)?;
            let pupil = match pc {
                Some(i) => get(i)?,
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
        };
        let Ok(left) = eye(left_c) else {
            continue 'rows;
        };
        let Ok(right) = eye(right_c) else {
            continue 'rows;
        };
        let Ok(binocular) = eye(bin_c) else {
            continue 'rows;
        };
        let text_of = |c: Option<usize>| c.map(|i| f[i].1.trim().to_string());
        if header.subject.is_none() {
            header.subject = participant_c
                .map(|i| f[i].1.trim().to_string())
                .filter(|p| !super::text::is_missing(p));
        }
        samples.push(Sample {
            time_us,
            trial,
            left,
            right,
            binocular,
            binocular_event: text_of(cat_b),
            left_event: text_of(cat_l),
            right_event: text_of(cat_r),
            stimulus: text_of(stimulus_c),
        });
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
        format: SmiFormat::BeGazeRaw,
        header,
        columns,
        samples,
        messages: Vec::new(),
        events: Vec::new(),
        rows,
        notes,
    })
}

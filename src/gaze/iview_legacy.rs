//! Format A2: iView X 2.x sample files (`#FileVersion: 2`). A header of `#` lines
//! (`#Fileformat:`, `#Subject:`, `## Date: September 19, 2008`, `## of Pts Recorded:`,
//! `#Offset Of Calibration Area:`, `#Size Of Calibration Area: 800 600`, `#Sample Rate: 60`),
//! a `#Time Set Pupil H Pupil V C.R. H C.R. V ScreenH ScreenV Diam H Diam V` column line,
//! then TAB-separated numeric rows. `Time` is milliseconds; `ScreenH`/`ScreenV` are the gaze
//! in pixels of the calibration area. One eye, and the file does not say which.
use super::idf_samples::parse_header_line;
use super::recording::{EyeSample, GazeError, GazeFormat, Header, Recording, RowAccount, Sample};
use super::text::{decode, lines, number, split, Separator};

/// Whether `head` (the file's first lines) looks like an iView X 2.x sample file.
pub(crate) fn looks_like(head: &str) -> bool {
    let mut it = head.lines().map(|l| l.trim_end_matches('\r'));
    let first = it.next().unwrap_or("");
    first.starts_with("#FileVersion:")
        || head
            .lines()
            .any(|l| l.starts_with("#Time\t") && l.contains("ScreenH") && l.contains("ScreenV"))
}

struct Columns {
    time: usize,
    x: usize,
    y: usize,
    pupil: Option<usize>,
    count: usize,
}

fn columns_of(names: &[String], line: usize, path: &str) -> Result<Columns, GazeError> {
    let col = |n: &str| names.iter().position(|c| c == n);
    let need = |n: &str| {
        col(n).ok_or_else(|| GazeError::At {
            path: path.to_string(),
            line,
            column: 1,
            message: format!(
                "iView X 2.x column line without `{n}`: the gaze position (ScreenH, ScreenV) and `Time` are needed"
            ),
        })
    };
    Ok(Columns {
        time: need("Time")?,
        x: need("ScreenH")?,
        y: need("ScreenV")?,
        pupil: col("Diam H"),
        count: names.len(),
    })
}

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let mut header = Header::default();
    let mut rows = RowAccount {
        lines: all.len(),
        ..Default::default()
    };
    let mut names: Vec<String> = Vec::new();
    let mut cols: Option<Columns> = None;
    let mut samples = Vec::new();
    for &(no, line) in &all {
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        if let Some(body) = line.strip_prefix('#') {
            rows.header_lines += 1;
            if cols.is_none() && body.starts_with("Time\t") {
                names = split(body, Separator::Tab)
                    .iter()
                    .map(|(_, c)| c.trim().to_string())
                    .collect();
                cols = Some(columns_of(&names, no, path)?);
            } else {
                parse_header_line(line, &mut header);
            }
            continue;
        }
        let Some(c) = &cols else {
            rows.reject("data row before the `#Time` column line", no, 1, line);
            continue;
        };
        let f = split(line, Separator::Tab);
        // Some exporters end rows with a TAB: one empty trailing field is not a misfit.
        let n = if f.len() == c.count + 1 && f.last().is_some_and(|x| x.1.trim().is_empty()) {
            c.count
        } else {
            f.len()
        };
        if n != c.count {
            let reason = format!(
                "row with a field count other than the column line's {}",
                c.count
            );
            rows.reject(&reason, no, 1, line);
            continue;
        }
        let get = |i: usize| number(f[i].1, Separator::Tab).map_err(|_| (i, f[i].0));
        let parsed = (|| {
            let t = get(c.time)?.ok_or((c.time, f[c.time].0))?;
            let x = get(c.x)?;
            let y = get(c.y)?;
            let pupil = match c.pupil {
                Some(i) => get(i)?,
                None => None,
            };
            Ok::<_, (usize, usize)>((t, x, y, pupil))
        })();
        let (t, x, y, pupil) = match parsed {
            Ok(v) => v,
            Err((i, column)) => {
                let reason = format!("`{}` is not a number", names[i]);
                rows.reject(&reason, no, column, line);
                continue;
            }
        };
        let (x, y) = (x.unwrap_or(0.0), y.unwrap_or(0.0));
        samples.push(Sample {
            // Integer milliseconds on disk: exact as integer µs.
            time_us: (t * 1000.0).round() as i64,
            trial: 1,
            left: Some(EyeSample {
                x,
                y,
                pupil,
                valid: !(x == 0.0 && y == 0.0),
                flag_lost: false,
            }),
            right: None,
            binocular: None,
            binocular_event: None,
            left_event: None,
            right_event: None,
            stimulus: None,
        });
        rows.samples += 1;
    }
    if cols.is_none() {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "an iView X 2.x header without the `#Time	…	ScreenH	ScreenV` column line: no sample can be read".into(),
        });
    }
    let notes = vec![
        "iView X 2.x sample file: one eye, which the file does not name; its gaze is read as the left eye".to_string(),
        "times are integer milliseconds (kept exact in µs); a sample is lost where ScreenH/ScreenV is (0, 0)".to_string(),
    ];
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::IviewLegacy,
        header,
        columns: names,
        samples,
        messages: Vec::new(),
        events: Vec::new(),
        rows,
        notes,
    })
}

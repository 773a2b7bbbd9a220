//! Format A (IDF Converter) and A' (BeGaze) sample text: a `##` header, a TAB column-header
//! line found by content (`Time` and `Type`), then `SMP` rows (one value per column) and `MSG`
//! rows (`Time MSG Trial # Message: text`). Columns are picked by name, never by position.
use super::recording::{
    EyeSample, GazeError, GazeFormat, Header, Message, Recording, RowAccount, Sample, SharedLabels,
    SharedNames,
};
use super::text::{integer, lines, number, split, Separator};

/// Reads the `key: value` header lines (with or without their `##`).
pub(crate) fn parse_header_line(line: &str, header: &mut Header) {
    let body = line.trim_start_matches('#').trim();
    if body.is_empty() {
        return;
    }
    if body.starts_with('[') && body.ends_with(']') {
        if header.banner.is_none() {
            header.banner = Some(body.to_string());
        }
        return;
    }
    let Some((key, value)) = body.split_once(':') else {
        header.entries.push((body.to_string(), String::new()));
        return;
    };
    let key = key.trim().to_string();
    let parts: Vec<&str> = value
        .split('\t')
        .map(str::trim)
        .filter(|p| !p.is_empty())
        .collect();
    let value = parts.join("\t");
    let nums = |n: usize| -> Option<Vec<f64>> {
        let v: Vec<f64> = parts.iter().filter_map(|p| p.parse::<f64>().ok()).collect();
        (v.len() >= n).then_some(v)
    };
    let anonymised = matches!(value.as_str(), "" | "NA" | "###");
    match key.as_str() {
        "Sample Rate" => header.sample_rate_hz = nums(1).map(|v| v[0]),
        // iView X 2.x says "Size Of Calibration Area".
        "Calibration Area" | "Size Of Calibration Area" => {
            header.calibration_area_px = nums(2).map(|v| [v[0], v[1]])
        }
        "Stimulus Dimension [mm]" => header.stimulus_dimension_mm = nums(2).map(|v| [v[0], v[1]]),
        "Head Distance [mm]" => header.head_distance_mm = nums(1).map(|v| v[0]),
        "Subject" if !anonymised => header.subject = Some(value.clone()),
        "Version" => header.version = Some(value.clone()),
        "Date" if !anonymised => {
            header.date = chrono::NaiveDateTime::parse_from_str(&value, "%d.%m.%Y %H:%M:%S").ok()
        }
        "Format" => {
            header.format_items = value
                .split(',')
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect()
        }
        _ => {}
    }
    header.entries.push((key, value));
}

struct EyeColumns {
    x: usize,
    y: usize,
    validity: Option<usize>,
    pupil: Option<usize>,
    event: Option<usize>,
}

fn eye_columns(columns: &[String], e: &str) -> Option<EyeColumns> {
    let find = |name: &str| columns.iter().position(|c| c == name);
    Some(EyeColumns {
        x: find(&format!("{e} POR X [px]"))?,
        y: find(&format!("{e} POR Y [px]"))?,
        validity: find(&format!("{e} Validity")),
        pupil: find(&format!("{e} Mapped Diameter [mm]"))
            .or_else(|| find(&format!("{e} Pupil Diameter [mm]")))
            .or_else(|| find(&format!("{e} Dia X [px]"))),
        event: find(&format!("{e} Event Info")),
    })
}

pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = super::text::decode(bytes);
    let all = lines(&text);
    let header_at = all
        .iter()
        .position(|(_, l)| {
            let f: Vec<&str> = l.split('\t').map(str::trim).collect();
            f.contains(&"Time") && f.contains(&"Type")
        })
        .ok_or_else(|| GazeError::File {
            path: path.to_string(),
            message: "no column header line (a TAB-separated line with `Time` and `Type`) was found: not an SMI sample export".into(),
        })?;
    let mut header = Header::default();
    let mut rows = RowAccount {
        lines: all.len(),
        ..Default::default()
    };
    for (_, l) in &all[..header_at] {
        parse_header_line(l, &mut header);
        rows.header_lines += 1;
    }
    rows.header_lines += 1; // the column line
    let columns: Vec<String> = all[header_at]
        .1
        .split('\t')
        .map(|c| c.trim().to_string())
        .collect();
    let col = |name: &str| columns.iter().position(|c| c == name);
    let (time_c, type_c) = (col("Time").expect("found"), col("Type").expect("found"));
    let trial_c = col("Trial");
    let left = eye_columns(&columns, "L");
    let right = eye_columns(&columns, "R");
    let stimulus_c = col("Stimulus");
    let format = if header.banner.as_deref() == Some("[BeGaze]")
        || left.as_ref().is_some_and(|e| e.event.is_some())
        || right.as_ref().is_some_and(|e| e.event.is_some())
    {
        GazeFormat::BeGazeSamples
    } else {
        GazeFormat::IdfSamples
    };
    let mut notes = Vec::new();
    if left.is_none() && right.is_none() {
        notes.push("no `L/R POR X [px]` columns: samples carry no gaze position".to_string());
    }
    let layout = Layout {
        columns: &columns,
        time_c,
        type_c,
        trial_c,
        left: &left,
        right: &right,
        stimulus_c,
    };
    // Data rows in parallel chunks, merged in file order: the result does not depend on the
    // number of threads.
    use rayon::prelude::*;
    let parts: Vec<(Vec<Sample>, Vec<Message>, RowAccount)> = all[header_at + 1..]
        .par_chunks(16_384)
        .map(|chunk| parse_rows(chunk, &layout))
        .collect();
    let mut samples = Vec::with_capacity(parts.iter().map(|p| p.0.len()).sum());
    let mut messages = Vec::new();
    for (s, m, acc) in parts {
        samples.extend(s);
        messages.extend(m);
        rows.blank_lines += acc.blank_lines;
        rows.samples += acc.samples;
        rows.messages += acc.messages;
        for (reason, first) in acc.unusable {
            let e = rows
                .unusable
                .entry(reason)
                .or_insert(super::recording::FirstSeen {
                    count: 0,
                    ..first.clone()
                });
            e.count += first.count;
        }
    }
    if samples.len() > 1 && samples.windows(2).any(|w| w[1].time_us < w[0].time_us) {
        notes.push("sample times go backwards somewhere: kept in file order".into());
    }
    Ok(Recording {
        file: path.to_string(),
        format,
        header,
        columns,
        samples,
        messages,
        events: Vec::new(),
        rows,
        notes,
    })
}

struct Layout<'a> {
    columns: &'a [String],
    time_c: usize,
    type_c: usize,
    trial_c: Option<usize>,
    left: &'a Option<EyeColumns>,
    right: &'a Option<EyeColumns>,
    stimulus_c: Option<usize>,
}

fn parse_rows(chunk: &[(usize, &str)], layout: &Layout) -> (Vec<Sample>, Vec<Message>, RowAccount) {
    let Layout {
        columns,
        time_c,
        type_c,
        trial_c,
        left,
        right,
        stimulus_c,
    } = *layout;
    let sep = Separator::Tab;
    let mut rows = RowAccount::default();
    let mut samples = Vec::new();
    let mut messages = Vec::new();
    let mut names = SharedNames::default();
    let mut labels = SharedLabels::default();
    'rows: for &(no, line) in chunk {
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        let f = split(line, sep);
        let Some(&(tc, kind)) = f.get(type_c) else {
            rows.reject("row too short to have a `Type`", no, line.len() + 1, line);
            continue;
        };
        let time = f.get(time_c).map(|(_, t)| integer(t));
        let time = match time {
            Some(Ok(Some(t))) => t,
            _ => {
                rows.reject(
                    "`Time` is not an integer (µs)",
                    no,
                    f.get(time_c).map_or(1, |x| x.0),
                    line,
                );
                continue;
            }
        };
        let trial = match trial_c.and_then(|c| f.get(c)).map(|(_, t)| integer(t)) {
            None => 1,
            Some(Ok(Some(t))) if (0..=u32::MAX as i64).contains(&t) => t as u32,
            _ => {
                let c = trial_c.and_then(|c| f.get(c)).map_or(1, |x| x.0);
                rows.reject("`Trial` is not an integer", no, c, line);
                continue;
            }
        };
        match kind.trim() {
            "MSG" => {
                let text = f[(type_c + 2).min(f.len())..]
                    .iter()
                    .map(|(_, t)| *t)
                    .collect::<Vec<_>>()
                    .join("\t");
                messages.push(Message {
                    time_us: time,
                    trial,
                    text: super::text::message_text(&text),
                });
                rows.messages += 1;
            }
            "SMP" => {
                if f.len() != columns.len() {
                    rows.reject(
                        &format!(
                            "SMP row with a field count other than the header's {}",
                            columns.len()
                        ),
                        no,
                        1,
                        line,
                    );
                    continue;
                }
                let mut eyes = [None, None];
                let mut events = [None, None];
                for (k, cols) in [&left, &right].into_iter().enumerate() {
                    let Some(c) = cols else { continue };
                    let Ok((eye, event)) = smp_eye(&f, c, columns, no, line, &mut rows) else {
                        continue 'rows;
                    };
                    eyes[k] = Some(eye);
                    events[k] = event.map(|e| labels.of(e));
                }
                let [left_eye, right_eye] = eyes;
                let [left_event, right_event] = events;
                samples.push(Sample {
                    time_us: time,
                    trial,
                    left: left_eye,
                    right: right_eye,
                    binocular: None,
                    binocular_event: None,
                    left_event,
                    right_event,
                    stimulus: stimulus_c.map(|i| names.of(f[i].1.trim())),
                });
                rows.samples += 1;
            }
            other => rows.reject(
                &format!("unknown row type `{other}` (expected SMP or MSG)"),
                no,
                tc,
                line,
            ),
        }
    }
    (samples, messages, rows)
}

/// One eye of an SMP row and its event column; `Err` when a field is not a number (the row
/// is counted as unusable). Lost where the validity is 0 or the POR is (0, 0).
fn smp_eye<'a>(
    f: &[(usize, &'a str)],
    c: &EyeColumns,
    columns: &[String],
    no: usize,
    line: &str,
    rows: &mut RowAccount,
) -> Result<(EyeSample, Option<&'a str>), ()> {
    let mut get = |i: usize| -> Result<Option<f64>, ()> {
        number(f[i].1, Separator::Tab).map_err(|_| {
            rows.reject(
                &format!("`{}` is not a number", columns[i]),
                no,
                f[i].0,
                line,
            );
        })
    };
    let x = get(c.x)?;
    let y = get(c.y)?;
    let pupil = c.pupil.map(&mut get).transpose()?.flatten();
    let validity = c.validity.map(&mut get).transpose()?.flatten();
    let (x, y) = (x.unwrap_or(0.0), y.unwrap_or(0.0));
    let flag_lost = validity == Some(0.0);
    let valid = !(flag_lost || (x == 0.0 && y == 0.0));
    let eye = EyeSample {
        x,
        y,
        pupil,
        valid,
        flag_lost,
    };
    Ok((eye, c.event.map(|i| f[i].1.trim())))
}

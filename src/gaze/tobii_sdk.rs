//! Tobii Pro SDK gaze dumps: the `gaze_data` callback's fields written one row per sample by
//! an experiment program (CSV or TSV), into the one record model.
//!
//! Columns, as the SDK names them: `system_time_stamp` (µs, the computer's clock; else
//! `device_time_stamp`, the tracker's), per eye `left_gaze_point_on_display_area_x` / `_y`
//! (fractions of the display area, origin top-left) or one column holding the SDK's tuple
//! (`left_gaze_point_on_display_area` = `(0.51, 0.43)`), `left_gaze_point_validity` (1 valid,
//! 0 not; `True`/`False` as Python writes it), `left_pupil_diameter` (mm) with its validity;
//! the same for `right_`. A dump has no fixation events and no messages: fixations are
//! detected in its samples, and the whole recording is one stimulus unless messages are
//! given another way. Positions are fractions of the screen, scaled by ingest.
use super::recording::{EyeSample, GazeError, GazeFormat, Header, Recording, RowAccount, Sample};
use super::text::{decode, lines, Separator};

/// Whether the first line is a Tobii Pro SDK gaze dump's header.
pub(crate) fn looks_like(first_line: &str) -> bool {
    let f = first_line.trim_start_matches('\u{feff}');
    (f.contains("system_time_stamp") || f.contains("device_time_stamp"))
        && f.contains("gaze_point_on_display_area")
}

/// Where one eye's values are.
struct EyeColumns {
    /// (x, y) columns, or one tuple column.
    point: Result<[usize; 2], usize>,
    validity: Option<usize>,
    pupil: Option<usize>,
    pupil_validity: Option<usize>,
}

fn eye_columns(names: &[String], eye: &str) -> Option<EyeColumns> {
    let col = |n: String| names.iter().position(|c| *c == n);
    let base = format!("{eye}_gaze_point_on_display_area");
    let point = match (col(format!("{base}_x")), col(format!("{base}_y"))) {
        (Some(x), Some(y)) => Ok([x, y]),
        _ => Err(col(base)?),
    };
    Some(EyeColumns {
        point,
        validity: col(format!("{eye}_gaze_point_validity")),
        pupil: col(format!("{eye}_pupil_diameter")),
        pupil_validity: col(format!("{eye}_pupil_validity")),
    })
}

/// Fields split on `sep`, except inside the SDK's `( … )` tuples, which hold a comma.
fn fields(line: &str, sep: u8) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let (mut start, mut depth) = (0, 0i32);
    for (i, &b) in line.as_bytes().iter().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' => depth -= 1,
            _ if b == sep && depth <= 0 => {
                out.push((start + 1, line[start..i].trim_matches('"')));
                start = i + 1;
            }
            _ => {}
        }
    }
    out.push((start + 1, line[start..].trim_matches('"')));
    out
}

fn number(v: &str) -> Result<Option<f64>, ()> {
    let v = v.trim();
    if v.is_empty() || v.eq_ignore_ascii_case("nan") {
        return Ok(None);
    }
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(Some(x)),
        _ => Err(()),
    }
}

fn flag(v: &str) -> Option<bool> {
    match v.trim() {
        "1" | "True" | "true" | "TRUE" => Some(true),
        "0" | "False" | "false" | "FALSE" => Some(false),
        _ => None,
    }
}

/// One eye of a row; Err: the column that is not a number (or validity flag).
fn eye_of(c: &EyeColumns, f: &[(usize, &str)]) -> Result<EyeSample, usize> {
    let get = |i: usize| number(f[i].1).map_err(|_| i);
    let (x, y) = match c.point {
        Ok([x, y]) => (get(x)?, get(y)?),
        Err(i) => {
            let inner = f[i].1.trim().trim_start_matches('(').trim_end_matches(')');
            let mut parts = inner.split(',');
            let x = number(parts.next().unwrap_or("")).map_err(|_| i)?;
            let y = number(parts.next().unwrap_or("")).map_err(|_| i)?;
            (x, y)
        }
    };
    let flagged = match c.validity {
        Some(i) => flag(f[i].1).ok_or(i)?,
        None => true,
    };
    let pupil_ok = c.pupil_validity.and_then(|i| flag(f[i].1)).unwrap_or(true);
    let pupil = match c.pupil {
        Some(i) if pupil_ok => get(i)?.filter(|p| *p > 0.0),
        _ => None,
    };
    let valid = flagged && x.is_some() && y.is_some();
    Ok(EyeSample {
        x: if valid { x.unwrap_or(0.0) } else { 0.0 },
        y: if valid { y.unwrap_or(0.0) } else { 0.0 },
        pupil,
        valid,
        flag_lost: !flagged,
    })
}

/// Reads a Tobii Pro SDK gaze dump; `path` names it in messages.
pub fn read(bytes: &[u8], path: &str) -> Result<Recording, GazeError> {
    let text = decode(bytes);
    let all = lines(&text);
    let Some(&(_, first)) = all.first() else {
        return Err(GazeError::File {
            path: path.to_string(),
            message: "the file is empty".into(),
        });
    };
    let sep = if Separator::sniff(first) == Separator::Tab {
        b'\t'
    } else {
        b','
    };
    let names: Vec<String> = fields(first, sep)
        .iter()
        .map(|(_, c)| c.trim().to_string())
        .collect();
    let at_header = |message: String| GazeError::At {
        path: path.to_string(),
        line: 1,
        column: 1,
        message,
    };
    let (time, clock) = ["system_time_stamp", "device_time_stamp"]
        .iter()
        .find_map(|n| names.iter().position(|c| c == n).map(|i| (i, *n)))
        .ok_or_else(|| {
            at_header(
                "a Tobii Pro SDK dump without `system_time_stamp` or `device_time_stamp`".into(),
            )
        })?;
    let eyes = [eye_columns(&names, "left"), eye_columns(&names, "right")];
    if eyes.iter().all(Option::is_none) {
        return Err(at_header(
            "a Tobii Pro SDK dump without `left_`/`right_gaze_point_on_display_area` columns"
                .into(),
        ));
    }
    let mut rows = RowAccount {
        lines: all.len(),
        header_lines: 1,
        ..Default::default()
    };
    let mut samples = Vec::with_capacity(all.len());
    for &(no, line) in &all[1..] {
        if line.trim().is_empty() {
            rows.blank_lines += 1;
            continue;
        }
        let f = fields(line, sep);
        if f.len() != names.len() {
            let reason = format!(
                "row with a field count other than the header's {}",
                names.len()
            );
            rows.reject(&reason, no, 1, line);
            continue;
        }
        let parsed = (|| {
            let t = number(f[time].1).map_err(|_| time)?.ok_or(time)?;
            let left = eyes[0].as_ref().map(|c| eye_of(c, &f)).transpose()?;
            let right = eyes[1].as_ref().map(|c| eye_of(c, &f)).transpose()?;
            Ok::<_, usize>((t, left, right))
        })();
        let (t, left, right) = match parsed {
            Ok(v) => v,
            Err(i) => {
                let reason = format!("`{}` is not a number or validity flag", names[i]);
                rows.reject(&reason, no, f[i].0, line);
                continue;
            }
        };
        if !(0.0..9.0e15).contains(&t) {
            rows.reject(
                &format!("`{clock}` outside 0 to 2^53 µs"),
                no,
                f[time].0,
                line,
            );
            continue;
        }
        rows.samples += 1;
        samples.push(Sample {
            time_us: t.round() as i64,
            trial: 1,
            left,
            right,
            binocular: None,
            binocular_event: None,
            left_event: None,
            right_event: None,
            stimulus: None,
        });
    }
    samples.sort_by_key(|s| s.time_us);
    let rate = super::recording::median_rate_hz(&samples, 1);
    Ok(Recording {
        file: path.to_string(),
        format: GazeFormat::TobiiSdk,
        header: Header {
            banner: Some("Tobii Pro SDK gaze dump".into()),
            sample_rate_hz: rate,
            normalized: true,
            ..Header::default()
        },
        columns: names,
        samples,
        messages: Vec::new(),
        events: Vec::new(),
        rows,
        notes: vec![format!(
            "Tobii Pro SDK gaze dump: times from `{clock}` (µs); positions are fractions of the display area; no fixation events or messages in the file"
        )],
    })
}

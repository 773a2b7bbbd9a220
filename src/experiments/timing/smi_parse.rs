use std::path::Path;

use super::TimingError;

/// What a reader's parse measurement found.
#[derive(Debug)]
pub struct ParseSpeed {
    /// Size of the synthetic export, bytes.
    pub bytes: usize,
    /// Samples parsed.
    pub samples: usize,
    /// Wall seconds of the fastest parse of [`PARSE_RUNS`].
    pub seconds: f64,
    /// Wall seconds of the first parse, the one that takes its memory fresh from the system
    /// (on a virtual machine whose memory the host backs on first touch, it can take twice as
    /// long: that is the machine's cost, not the reader's, and it falls on whichever reader
    /// first grows the process).
    pub first_seconds: f64,
}

/// Each reader parses its bytes this many times; the fastest counts.
pub const PARSE_RUNS: usize = 3;

/// Parses `bytes` [`PARSE_RUNS`] times; the samples are counted by `count`. Each recording is
/// dropped after its run's clock stops.
fn timed_parses(
    bytes: &[u8],
    what: &str,
    count: impl Fn(&crate::gaze::recording::Recording) -> usize,
) -> Result<ParseSpeed, TimingError> {
    let (mut fastest, mut first, mut samples) = (f64::INFINITY, 0.0, 0);
    for run in 0..PARSE_RUNS {
        let start = std::time::Instant::now();
        let rec =
            crate::gaze::parse_recording(bytes, "bench", None).map_err(|e| TimingError::Step {
                step: format!("the {what} parse"),
                message: e.to_string(),
            })?;
        let seconds = start.elapsed().as_secs_f64();
        if run == 0 {
            first = seconds;
        }
        fastest = fastest.min(seconds);
        samples = count(&rec);
    }
    Ok(ParseSpeed {
        bytes: bytes.len(),
        samples,
        seconds: fastest,
        first_seconds: first,
    })
}

/// Parse speed of SMI format A: HBN's 7,343-sample export repeated 150 times to about 1.1
/// million samples (times shifted so they keep increasing), read from memory.
pub fn smi_parse_speed(data: &Path) -> Result<ParseSpeed, TimingError> {
    let path = data.join("smi/hbn-sccn__NDARAA075AMK_Video1_Samples.txt");
    let bad = |message: &str| TimingError::Input {
        path: path.clone(),
        message: message.to_string(),
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(&e.to_string()))?;
    let split_at = text
        .find("\nTime\t")
        .map(|i| i + 1)
        .ok_or_else(|| bad("no `Time` column header"))?;
    let body_start = split_at
        + text[split_at..]
            .find('\n')
            .ok_or_else(|| bad("no data after the column header"))?
        + 1;
    let (head, body) = text.split_at(body_start);
    let rows: Vec<&str> = body.lines().filter(|l| l.contains("\tSMP\t")).collect();
    let mut big = String::with_capacity(text.len() * 160);
    big.push_str(head);
    let mut t: i64 = 1_000_000;
    for _ in 0..150 {
        for r in &rows {
            let rest = r.split_once('\t').map_or("", |(_, rest)| rest);
            t += 16_667;
            big.push_str(&t.to_string());
            big.push('\t');
            big.push_str(rest);
            big.push('\n');
        }
    }
    timed_parses(big.as_bytes(), "SMI", |rec| rec.samples.len())
}

/// Parse speed of EyeLink ASC: syelink's 70,291-sample left-eye recording (500 Hz) repeated 16
/// times to about 1.1 million samples (times shifted so they keep increasing), read from
/// memory: the same scale as the SMI row, so samples per second compare.
pub fn eyelink_parse_speed(data: &Path) -> Result<ParseSpeed, TimingError> {
    let path = data.join("trackers/eyelink/syelink__left_eye.asc");
    let bad = |message: &str| TimingError::Input {
        path: path.clone(),
        message: message.to_string(),
    };
    let text = std::fs::read_to_string(&path).map_err(|e| bad(&e.to_string()))?;
    let is_sample = |l: &str| l.as_bytes().first().is_some_and(u8::is_ascii_digit);
    let rows: Vec<(i64, &str)> = text
        .lines()
        .filter(|l| is_sample(l))
        .filter_map(|l| {
            let (t, rest) = l.split_once('\t')?;
            Some((t.parse::<i64>().ok()?, rest))
        })
        .collect();
    let (Some(first), Some(last)) = (rows.first(), rows.last()) else {
        return Err(bad("no sample rows"));
    };
    let span = last.0 - first.0 + 2;
    let mut big = String::with_capacity(text.len() * 17);
    big.push_str("MSG\t1 GAZE_COORDS 0.00 0.00 1279.00 1023.00\nSTART\t1 \tLEFT\tSAMPLES\tEVENTS\nSAMPLES\tGAZE\tLEFT\tRATE\t 500.00\tTRACKING\tCR\tFILTER\t2\n");
    for k in 0..16 {
        for (t, rest) in &rows {
            big.push_str(&(t + k * span).to_string());
            big.push('\t');
            big.push_str(rest);
            big.push('\n');
        }
    }
    big.push_str("END\t1 \tSAMPLES\tEVENTS\n");
    timed_parses(big.as_bytes(), "EyeLink", |rec| rec.samples.len())
}

/// A table export whose rows are repeated with shifted times for a parse measurement.
struct TableCase {
    file: &'static str,
    separator: char,
    /// The time column, and how many of its units one row-span shift adds per repeat.
    time_column: usize,
    /// Time units per second (µs: 1e6, s: 1).
    units_per_s: f64,
    what: &'static str,
}

const TABLE_CASES: [TableCase; 3] = [
    TableCase {
        file: "trackers/tobii/tobii-pro__all_gaze.csv",
        separator: ',',
        time_column: 0,
        units_per_s: 1e6,
        what: "Tobii Pro Lab",
    },
    TableCase {
        file: "trackers/gazepoint/d2lab__User_1_all_gaze.csv",
        separator: ',',
        time_column: 3,
        units_per_s: 1.0,
        what: "Gazepoint",
    },
    TableCase {
        file: "trackers/pupil/chblab__gaze_positions_on_surface_Surface_1.csv",
        separator: ',',
        time_column: 2,
        units_per_s: 1.0,
        what: "Pupil Core surface",
    },
];

/// Parse speed of the Tobii Pro Lab, Gazepoint and Pupil Core readers: each real export's
/// rows repeated (times shifted by the file's span each time) to about 1.1 million rows,
/// read from memory. Returns (reader, speed) per format.
pub fn table_parse_speeds(data: &Path) -> Result<Vec<(&'static str, ParseSpeed)>, TimingError> {
    let mut out = Vec::new();
    for case in &TABLE_CASES {
        let path = data.join(case.file);
        let bad = |message: &str| TimingError::Input {
            path: path.clone(),
            message: message.to_string(),
        };
        let text = std::fs::read_to_string(&path).map_err(|e| bad(&e.to_string()))?;
        let mut lines = text.lines();
        let head = lines.next().ok_or_else(|| bad("empty"))?;
        let rows: Vec<(f64, Vec<&str>)> = lines
            .filter_map(|l| {
                let f: Vec<&str> = l.split(case.separator).collect();
                let t = f.get(case.time_column)?.trim().parse::<f64>().ok()?;
                Some((t, f))
            })
            .collect();
        let (Some(first), Some(last)) = (
            rows.iter().map(|r| r.0).reduce(f64::min),
            rows.iter().map(|r| r.0).reduce(f64::max),
        ) else {
            return Err(bad("no rows with a time"));
        };
        let span = last - first + case.units_per_s / 100.0;
        let repeats = (1_100_000 / rows.len().max(1)).max(1);
        let mut big = String::with_capacity(text.len() * (repeats + 1));
        big.push_str(head);
        big.push('\n');
        let sep = case.separator.to_string();
        for k in 0..repeats {
            for (t, f) in &rows {
                let mut f = f.clone();
                let shifted = if case.units_per_s >= 1e6 {
                    format!("{}", (t + k as f64 * span).round() as i64)
                } else {
                    format!("{:.6}", t + k as f64 * span)
                };
                f[case.time_column] = &shifted;
                big.push_str(&f.join(&sep));
                big.push('\n');
            }
        }
        let speed = timed_parses(big.as_bytes(), case.what, |rec| {
            rec.rows.samples + rec.rows.events
        })?;
        out.push((case.what, speed));
    }
    Ok(out)
}

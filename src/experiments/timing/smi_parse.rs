use std::path::Path;

use super::TimingError;

/// What a reader's parse measurement found.
#[derive(Debug)]
pub struct ParseSpeed {
    /// Size of the synthetic export, bytes.
    pub bytes: usize,
    /// Samples parsed.
    pub samples: usize,
    /// Wall seconds of the parse.
    pub seconds: f64,
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
    let start = std::time::Instant::now();
    let rec = crate::gaze::parse_recording(big.as_bytes(), "bench", None).map_err(|e| {
        TimingError::Step {
            step: "the SMI parse".to_string(),
            message: e.to_string(),
        }
    })?;
    Ok(ParseSpeed {
        bytes: big.len(),
        samples: rec.samples.len(),
        seconds: start.elapsed().as_secs_f64(),
    })
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
    let start = std::time::Instant::now();
    let rec = crate::gaze::parse_recording(big.as_bytes(), "bench", None).map_err(|e| {
        TimingError::Step {
            step: "the EyeLink parse".to_string(),
            message: e.to_string(),
        }
    })?;
    Ok(ParseSpeed {
        bytes: big.len(),
        samples: rec.samples.len(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

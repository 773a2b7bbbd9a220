use std::path::Path;

use super::TimingError;

/// What the SMI parse measurement found.
#[derive(Debug)]
pub struct SmiParseSpeed {
    /// Size of the synthetic export, bytes.
    pub bytes: usize,
    /// Samples parsed.
    pub samples: usize,
    /// Wall seconds of the parse.
    pub seconds: f64,
}

/// Parse speed of SMI format A: HBN's 7,343-sample export repeated 150 times to about 1.1
/// million samples (times shifted so they keep increasing), read from memory.
pub fn smi_parse_speed(data: &Path) -> Result<SmiParseSpeed, TimingError> {
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
    Ok(SmiParseSpeed {
        bytes: big.len(),
        samples: rec.samples.len(),
        seconds: start.elapsed().as_secs_f64(),
    })
}

//! Writers for format A (IDF Converter sample text) and C1 (IDF Event Detector event text),
//! so simulated observers produce the same files a lab's tracker does. Reading what they
//! write gives back the same samples, messages, events and header facts (numbers are printed
//! in Rust's shortest exact form). An eye at exactly (0, 0) reads back invalid: that is SMI's
//! tracking-loss value.
use std::fmt::Write;

use super::recording::{Event, EventKind, Eye, Header, Message, Sample};

fn opt(v: Option<f64>) -> String {
    v.map_or("-".to_string(), |x| format!("{x}"))
}

fn header_lines(h: &Header, prefix: &str, version: &str) -> String {
    let mut s = String::new();
    let mut line = |k: &str, v: String| {
        let _ = writeln!(s, "{prefix}{k}:\t{v}");
    };
    line("Converted from", "meshgaze".into());
    if let Some(d) = h.date {
        line("Date", d.format("%d.%m.%Y %H:%M:%S").to_string());
    }
    line("Version", version.to_string());
    if let Some(r) = h.sample_rate_hz {
        line("Sample Rate", format!("{r}"));
    }
    if let Some(sub) = &h.subject {
        line("Subject", sub.clone());
    }
    if let Some([w, hh]) = h.calibration_area_px {
        line("Calibration Area", format!("{w}\t{hh}"));
    }
    if let Some([w, hh]) = h.stimulus_dimension_mm {
        line("Stimulus Dimension [mm]", format!("{w}\t{hh}"));
    }
    if let Some(d) = h.head_distance_mm {
        line("Head Distance [mm]", format!("{d}"));
    }
    s
}

/// Format A: `## [iView]` header, TAB columns, SMP and MSG rows merged in time order
/// (a message before a sample at the same time).
pub fn write_samples_a(header: &Header, samples: &[Sample], messages: &[Message]) -> String {
    let mut s = String::from("## [iView]\n");
    s.push_str(&header_lines(
        header,
        "## ",
        concat!("meshgaze ", env!("CARGO_PKG_VERSION")),
    ));
    s.push_str("## Format:\tLEFT, RIGHT, DIAMETER, POR, QUALITY, MSG\n## \n");
    s.push_str("Time\tType\tTrial\tL POR X [px]\tL POR Y [px]\tR POR X [px]\tR POR Y [px]\tL Mapped Diameter [mm]\tR Mapped Diameter [mm]\tL Validity\tR Validity\n");
    let (mut i, mut j) = (0, 0);
    while i < samples.len() || j < messages.len() {
        let take_message =
            j < messages.len() && (i >= samples.len() || messages[j].time_us <= samples[i].time_us);
        if take_message {
            let m = &messages[j];
            let _ = writeln!(
                s,
                "{}\tMSG\t{}\t# Message: {}",
                m.time_us,
                m.trial,
                m.text.replace(['\n', '\r'], " ")
            );
            j += 1;
        } else {
            let p = &samples[i];
            let eye = |e: Option<super::recording::EyeSample>| match e {
                Some(e) => (
                    format!("{}", e.x),
                    format!("{}", e.y),
                    e.pupil.map_or(String::new(), |v| format!("{v}")),
                    if e.valid { "1" } else { "0" },
                ),
                None => ("0".into(), "0".into(), String::new(), "0"),
            };
            let (lx, ly, lp, lv) = eye(p.left);
            let (rx, ry, rp, rv) = eye(p.right);
            let _ = writeln!(
                s,
                "{}\tSMP\t{}\t{lx}\t{ly}\t{rx}\t{ry}\t{lp}\t{rp}\t{lv}\t{rv}",
                p.time_us, p.trial
            );
            i += 1;
        }
    }
    s
}

/// Format C1 (TAB): `[iView]` header, the four `Table Header for …` blocks, then user events
/// and every event in (trial, start) order.
pub fn write_events_c1(header: &Header, events: &[Event], messages: &[Message]) -> String {
    let mut s = String::from("[iView]\n");
    s.push_str(&header_lines(
        header,
        "",
        concat!("meshgaze ", env!("CARGO_PKG_VERSION")),
    ));
    s.push('\n');
    s.push_str("Table Header for Fixations:\nEvent Type\tTrial\tNumber\tStart\tEnd\tDuration\tLocation X\tLocation Y\tDispersion X\tDispersion Y\tPlane\tAvg. Pupil Size X\tAvg. Pupil Size Y\n\n");
    s.push_str("Table Header for Saccades:\nEvent Type\tTrial\tNumber\tStart\tEnd\tDuration\tStart Loc.X\tStart Loc.Y\tEnd Loc.X\tEnd Loc.Y\n\n");
    s.push_str("Table Header for Blinks:\nEvent Type\tTrial\tNumber\tStart\tEnd\tDuration\n\n");
    s.push_str("Table Header for User Events:\nEvent Type\tTrial\tNumber\tStart\tDescription\n\n");
    for (k, m) in messages.iter().enumerate() {
        let _ = writeln!(
            s,
            "UserEvent\t{}\t{}\t{}\t# Message: {}",
            m.trial,
            k + 1,
            m.time_us,
            m.text.replace(['\n', '\r'], " ")
        );
    }
    let mut sorted: Vec<&Event> = events.iter().collect();
    sorted.sort_by_key(|e| (e.trial, e.start_us, e.eye, e.number));
    for e in sorted {
        let eye = match e.eye {
            Eye::Left => "L",
            // C1 has no binocular stream: write it as the left eye.
            Eye::Right => "R",
            Eye::Binocular => "L",
        };
        let head = |kind: &str| {
            format!(
                "{kind} {eye}\t{}\t{}\t{}\t{}\t{}",
                e.trial, e.number, e.start_us, e.end_us, e.duration_us
            )
        };
        let _ = match e.kind {
            EventKind::Fixation => writeln!(
                s,
                "{}\t{}\t{}\t{}\t{}\t-1\t{}\t{}",
                head("Fixation"),
                opt(e.x),
                opt(e.y),
                opt(e.dispersion_x),
                opt(e.dispersion_y),
                opt(e.pupil_x),
                opt(e.pupil_y)
            ),
            EventKind::Saccade => writeln!(
                s,
                "{}\t{}\t{}\t{}\t{}",
                head("Saccade"),
                opt(e.x),
                opt(e.y),
                opt(e.end_x),
                opt(e.end_y)
            ),
            EventKind::Blink => writeln!(s, "{}", head("Blink")),
        };
    }
    s
}

//! Writers for SMI format A (IDF Converter sample text) and C1 (IDF Event Detector event text)
//! and for EyeLink ASC text,
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

/// A time in µs as EyeLink writes it: milliseconds, with the fraction only when there is one
/// (`2154556`, `2154556.5`), exact for whole µs.
fn eyelink_ms(t_us: i64) -> String {
    let (ms, us) = (t_us.div_euclid(1000), t_us.rem_euclid(1000));
    if us == 0 {
        format!("{ms}")
    } else {
        format!("{ms}.{us:03}").trim_end_matches('0').to_string()
    }
}

/// An ASC body line keyed for ordering: (time, order within a time, index, text).
type AscLine = (i64, u8, usize, String);

/// Each event's `S…` line at its start and `E…` line at its end (per eye, as EyeLink's
/// parser writes them; a binocular stream has no ASC form and is left out).
fn eyelink_event_lines(events: &[Event]) -> Vec<AscLine> {
    let mut body = Vec::new();
    let mut sorted: Vec<&Event> = events.iter().filter(|e| e.eye != Eye::Binocular).collect();
    sorted.sort_by_key(|e| (e.start_us, e.eye, e.number));
    for (k, e) in sorted.iter().enumerate() {
        let eye = if e.eye == Eye::Left { "L" } else { "R" };
        let key = match e.kind {
            EventKind::Fixation => "FIX",
            EventKind::Saccade => "SACC",
            EventKind::Blink => "BLINK",
        };
        let v = |x: Option<f64>| x.map_or("   .".to_string(), |x| format!("{x}"));
        let head = format!(
            "E{key} {eye} {}\t{}\t{}",
            eyelink_ms(e.start_us),
            eyelink_ms(e.end_us),
            eyelink_ms(e.duration_us)
        );
        let end_line = match e.kind {
            EventKind::Fixation => format!(
                "{head}\t{}\t{}\t{}",
                v(e.x),
                v(e.y),
                e.pupil_x.map_or("0".to_string(), |p| format!("{p}"))
            ),
            EventKind::Saccade => format!(
                "{head}\t{}\t{}\t{}\t{}\t0.00\t0",
                v(e.x),
                v(e.y),
                v(e.end_x),
                v(e.end_y)
            ),
            EventKind::Blink => head,
        };
        body.push((
            e.start_us,
            1,
            k,
            format!("S{key} {eye} {}", eyelink_ms(e.start_us)),
        ));
        body.push((e.end_us, 3, k, end_line));
    }
    body
}

/// EyeLink ASC text, as edf2asc writes a binocular GAZE recording in one block: the `**`
/// preamble, `GAZE_COORDS` (last pixel, SR Research's form) from the calibration area,
/// `START`, the `SAMPLES`/`EVENTS` layout, then messages, sample rows and events merged in
/// time order (an event's `S…` line at its start, its `E…` line after its last sample), and
/// `END`. Lost eyes are `.`; messages keep their text. The subject is the file's name: ASC
/// has no subject field.
pub fn write_eyelink_asc(
    header: &Header,
    samples: &[Sample],
    events: &[Event],
    messages: &[Message],
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "** CONVERTED FROM virtual-observer.edf using meshgaze {}",
        env!("CARGO_PKG_VERSION")
    );
    if let Some(d) = header.date {
        let _ = writeln!(s, "** DATE: {}", d.format("%a %b %e %H:%M:%S %Y"));
    }
    s.push_str("** TYPE: EDF_FILE BINARY EVENT SAMPLE TAGGED\n** VERSION: EYELINK II 1\n** SOURCE: meshgaze virtual observer\n**\n\n");
    let first = samples
        .first()
        .map(|x| x.time_us)
        .into_iter()
        .chain(messages.iter().map(|m| m.time_us))
        .chain(events.iter().map(|e| e.start_us))
        .min()
        .unwrap_or(0);
    let last = samples
        .last()
        .map(|x| x.time_us)
        .into_iter()
        .chain(messages.iter().map(|m| m.time_us))
        .chain(events.iter().map(|e| e.end_us))
        .max()
        .unwrap_or(0);
    let t0 = eyelink_ms(first);
    if let Some([w, h]) = header.calibration_area_px {
        let _ = writeln!(
            s,
            "MSG\t{t0} GAZE_COORDS 0.00 0.00 {:.2} {:.2}",
            w - 1.0,
            h - 1.0
        );
    }
    let rate = header.sample_rate_hz.unwrap_or(250.0);
    let _ = writeln!(s, "START\t{t0} \tLEFT\tRIGHT\tSAMPLES\tEVENTS");
    s.push_str("PRESCALER\t1\nVPRESCALER\t1\nPUPIL\tDIAMETER\n");
    let _ = writeln!(
        s,
        "EVENTS\tGAZE\tLEFT\tRIGHT\tRATE\t{rate:7.2}\tTRACKING\tCR\tFILTER\t2"
    );
    let _ = writeln!(
        s,
        "SAMPLES\tGAZE\tLEFT\tRIGHT\tRATE\t{rate:7.2}\tTRACKING\tCR\tFILTER\t2"
    );
    // (time, order within a time, text): messages, then event starts, samples, event ends.
    let mut body: Vec<AscLine> = Vec::new();
    for (k, m) in messages.iter().enumerate() {
        let text = m.text.replace(['\n', '\r'], " ");
        // A text starting with an integer word would read back as a time offset: say 0.
        let first = text.split([' ', '\t']).next().unwrap_or("");
        let first = first.strip_prefix('-').unwrap_or(first);
        let offset = if !first.is_empty() && first.bytes().all(|b| b.is_ascii_digit()) {
            "0 "
        } else {
            ""
        };
        body.push((
            m.time_us,
            0,
            k,
            format!("MSG\t{} {offset}{text}", eyelink_ms(m.time_us)),
        ));
    }
    body.extend(eyelink_event_lines(events));
    for (k, p) in samples.iter().enumerate() {
        let eye = |e: Option<super::recording::EyeSample>| match e {
            Some(e) if e.valid => format!(
                "{}\t{}\t{}",
                e.x,
                e.y,
                e.pupil.map_or("0.0".to_string(), |v| format!("{v}"))
            ),
            _ => "   .\t   .\t    0.0".to_string(),
        };
        body.push((
            p.time_us,
            2,
            k,
            format!(
                "{}\t{}\t{}\t.....",
                eyelink_ms(p.time_us),
                eye(p.left),
                eye(p.right)
            ),
        ));
    }
    body.sort_by_key(|(t, order, k, _)| (*t, *order, *k));
    for (_, _, _, line) in body {
        s.push_str(&line);
        s.push('\n');
    }
    let _ = writeln!(s, "END\t{} \tSAMPLES\tEVENTS", eyelink_ms(last));
    s
}

/// A message naming a stimulus file as Pro Lab names it: (stem, file name, `Video`/`Image`).
fn tobii_media_of(text: &str) -> Option<(String, String, &'static str)> {
    let name = text.trim().rsplit(['/', '\\']).next()?.to_string();
    let (stem, ext) = name.rsplit_once('.')?;
    let kind = match ext.to_ascii_lowercase().as_str() {
        "mp4" | "avi" | "mov" | "mkv" | "wmv" | "webm" | "m4v" | "mpg" | "mpeg" => "Video",
        "png" | "jpg" | "jpeg" | "bmp" | "gif" | "tif" | "tiff" | "webp" => "Image",
        _ => return None,
    };
    Some((stem.to_string(), name.clone(), kind))
}

/// A fixation as Tobii's filter reports it: (start, end, duration, x, y), both eyes averaged.
type FilterFixation = (i64, i64, i64, f64, f64);

/// The fixation filter's view of `events`: the first eye's fixations (points of both eyes
/// averaged) and its saccades' spans.
fn tobii_filter_spans(events: &[Event]) -> (Vec<FilterFixation>, Vec<(i64, i64)>) {
    // The fixation filter's view: the first eye's fixations, both eyes' points averaged.
    let first_eye = events.iter().map(|e| e.eye).min();
    let mut fixations: Vec<FilterFixation> = Vec::new();
    for e in events
        .iter()
        .filter(|e| e.kind == EventKind::Fixation && Some(e.eye) == first_eye)
    {
        let same: Vec<&Event> = events
            .iter()
            .filter(|o| o.kind == EventKind::Fixation && o.start_us == e.start_us && o.x.is_some())
            .collect();
        let n = same.len().max(1) as f64;
        let x = same.iter().filter_map(|o| o.x).sum::<f64>() / n;
        let y = same.iter().filter_map(|o| o.y).sum::<f64>() / n;
        fixations.push((e.start_us, e.end_us, e.duration_us, x, y));
    }
    fixations.sort_by_key(|f| f.0);
    let saccades: Vec<(i64, i64)> = events
        .iter()
        .filter(|e| e.kind == EventKind::Saccade && Some(e.eye) == first_eye)
        .map(|e| (e.start_us, e.end_us))
        .collect();
    (fixations, saccades)
}

/// Tobii Pro Lab data export text (TSV, `Recording timestamp [μs]`), as Pro Lab writes a
/// screen recording: one `Eye Tracker` row per sample with both eyes, their average, validity
/// and pupil; an event row (`ImageStimulusStart` / `VideoStimulusStart` and the stimulus name
/// without its extension) at each message naming a stimulus file, else the message text as
/// an `Event` of its own; the presented stimulus on every row after its start; and the
/// fixation filter's labels: `Fixation` with its index, duration and point on the rows of each
/// fixation event (both eyes averaged, as Tobii's filter reports), `Saccade`, `EyesNotFound`
/// or `Unclassified` elsewhere.
pub fn write_tobii_pro_lab_tsv(
    header: &Header,
    samples: &[Sample],
    events: &[Event],
    messages: &[Message],
) -> String {
    let mut s = String::from("Recording timestamp [μs]\tSensor\tParticipant name\tRecording resolution width\tRecording resolution height\tEvent\tEvent value\tGaze point X\tGaze point Y\tGaze point left X\tGaze point left Y\tGaze point right X\tGaze point right Y\tPupil diameter left\tPupil diameter right\tValidity left\tValidity right\tPresented Stimulus name\tPresented Media name\tEye movement type\tGaze event duration\tEye movement type index\tFixation point X\tFixation point Y\n");
    let participant = header.subject.clone().unwrap_or_default();
    let [w, h] = header.calibration_area_px.unwrap_or([0.0, 0.0]);
    let (w, h) = if w > 0.0 {
        (format!("{w}"), format!("{h}"))
    } else {
        (String::new(), String::new())
    };
    let (fixations, saccades) = tobii_filter_spans(events);
    let mut msgs: Vec<&Message> = messages.iter().collect();
    msgs.sort_by_key(|m| m.time_us);
    let (mut j, mut fk) = (0usize, 0usize);
    let mut presented: Option<(String, String)> = None;
    let v = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x}"));
    let event_row = |s: &mut String, m: &Message, presented: &mut Option<(String, String)>| {
        let text = m.text.replace(['\n', '\r', '\t'], " ");
        let (event, value) = match tobii_media_of(&text) {
            Some((stem, name, kind)) => {
                *presented = Some((stem.clone(), name));
                (format!("{kind}StimulusStart"), stem)
            }
            None => (text, String::new()),
        };
        let _ = writeln!(
            s,
            "{}\t\t{participant}\t{w}\t{h}\t{event}\t{value}{}",
            m.time_us,
            "\t".repeat(17)
        );
    };
    for p in samples {
        while j < msgs.len() && msgs[j].time_us <= p.time_us {
            event_row(&mut s, msgs[j], &mut presented);
            j += 1;
        }
        while fk < fixations.len() && fixations[fk].1 < p.time_us {
            fk += 1;
        }
        let eye = |e: Option<super::recording::EyeSample>| match e {
            Some(e) if e.valid => (Some(e.x), Some(e.y), e.pupil, "Valid"),
            _ => (None, None, None, "Invalid"),
        };
        let (lx, ly, lp, lv) = eye(p.left);
        let (rx, ry, rp, rv) = eye(p.right);
        let mean = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(a), Some(b)) => Some((a + b) / 2.0),
            (a, b) => a.or(b),
        };
        let (gx, gy) = (mean(lx, rx), mean(ly, ry));
        let in_fixation = fixations
            .get(fk)
            .filter(|f| f.0 <= p.time_us && p.time_us <= f.1);
        let (movement, duration, index, fx, fy) = match in_fixation {
            Some(f) => (
                "Fixation",
                format!("{}", f.2 as f64 / 1000.0),
                format!("{}", fk + 1),
                format!("{}", f.3),
                format!("{}", f.4),
            ),
            None => {
                let kind = if gx.is_none() {
                    "EyesNotFound"
                } else if saccades
                    .iter()
                    .any(|&(a, b)| a <= p.time_us && p.time_us <= b)
                {
                    "Saccade"
                } else {
                    "Unclassified"
                };
                (
                    kind,
                    String::new(),
                    String::new(),
                    String::new(),
                    String::new(),
                )
            }
        };
        let (stim, media) = presented.clone().unwrap_or_default();
        let _ = writeln!(
            s,
            "{}\tEye Tracker\t{participant}\t{w}\t{h}\t\t\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{lv}\t{rv}\t{stim}\t{media}\t{movement}\t{duration}\t{index}\t{fx}\t{fy}",
            p.time_us,
            v(gx),
            v(gy),
            v(lx),
            v(ly),
            v(rx),
            v(ry),
            v(lp),
            v(rp)
        );
    }
    for m in &msgs[j..] {
        event_row(&mut s, m, &mut presented);
    }
    s
}

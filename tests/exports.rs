//! Exports from other labs (issues 12 and 17): BeGaze variants built from their documented
//! layouts, recordings whose messages are not clean stimulus names, the protocol filter with a
//! known answer, and the binary run from outside the repository.
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use meshgaze::gaze::fixations::{
    apply_protocol_filter, fixations, Detector, DetectorParams, EyePolicy, Fate, Fixation,
};
use meshgaze::gaze::ingest::{
    check_one_source_per_subject, ingest_file, FilterRules, IngestParams,
};
use meshgaze::gaze::recording::{EyeSample, GazeFormat, Header, Message, Recording};
use meshgaze::gaze::stimulus_messages::{classify_messages, MessageKind, Segmentation};
use meshgaze::gaze::writers::write_samples_a;
use meshgaze::gaze::{detect_format, parse_recording};
use proptest::prelude::*;

const VIDEO_US: i64 = 48_000_000;

fn params() -> IngestParams {
    IngestParams {
        format: None,
        detector: None,
        eye: EyePolicy::Best,
        validity: meshgaze::gaze::validity::ValidityRule::Auto,
        subject: None,
        detector_params: DetectorParams::default(),
        filter: FilterRules {
            drop_first: 2,
            drop_last: 2,
            keep_longest: 15,
        },
        segmentation: Segmentation {
            pattern: None,
            max_duration_us: Some(VIDEO_US),
        },
        screen_px: Some([1680.0, 1050.0]),
    }
}

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("meshgaze-exports-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// BeGaze "Event Statistics", monocular layout: `Category` + `Eye L/R` + `Index`, raw times,
/// two participants, `Trial004`-style trials, saccade and separator rows, an AOI column.
fn monocular_event_statistics(line_end: &str) -> (String, usize) {
    let header = "Trial\tTrial Start Raw Time [ms]\tStimulus\tExport Start Trial Time [ms]\tExport End Trial Time [ms]\tParticipant\tColor\tTracking Ratio [%]\tCategory Group\tCategory\tEye L/R\tIndex\tEvent Start Trial Time [ms]\tEvent End Trial Time [ms]\tEvent Start Raw Time [ms]\tEvent End Raw Time [ms]\tEvent Duration [ms]\tFixation Position X [px]\tFixation Position Y [px]\tFixation Average Pupil Size X [px]\tFixation Average Pupil Size Y [px]\tFixation Average Pupil Diameter [mm]\tFixation Dispersion X [px]\tFixation Dispersion Y [px]\tSaccade Start Position X [px]\tSaccade Start Position Y [px]\tSaccade End Position X [px]\tSaccade End Position Y [px]\tAOI Name";
    let mut lines = vec![header.to_string()];
    let mut fixation_rows = 0;
    for p in ["P01", "P02"] {
        for (trial, stim, base) in [
            ("Trial004", "10.png", 1_739_439_978_157.6f64),
            ("Trial005", "bunny.avi", 1_739_440_100_000.2),
        ] {
            let mut t = 0.0f64;
            for i in 1..=24 {
                let d = 180.0 + ((i * 37) % 200) as f64;
                lines.push(format!(
                    "{trial}\t{base:.1}\t{stim}\t0.0\t48000.0\t{p}\t-\t98.5\tEye\tFixation\tLeft\t{i}\t{t:.1}\t{:.1}\t{:.1}\t{:.1}\t{d:.1}\t{:.1}\t{:.1}\t12.1\t12.3\t3.45\t5.0\t4.0\t-\t-\t-\t-\t-",
                    t + d,
                    base + t,
                    base + t + d,
                    400.0 + i as f64 * 10.0,
                    300.0 + i as f64 * 5.0
                ));
                fixation_rows += 1;
                t += d;
                lines.push(format!(
                    "{trial}\t{base:.1}\t{stim}\t0.0\t48000.0\t{p}\t-\t98.5\tEye\tSaccade\tLeft\t{i}\t{t:.1}\t{:.1}\t{:.1}\t{:.1}\t30.0\t-\t-\t-\t-\t-\t-\t-\t400.0\t300.0\t500.0\t320.0\t-",
                    t + 30.0,
                    base + t,
                    base + t + 30.0
                ));
                t += 30.0;
            }
            lines.push(format!("{trial}\t{base:.1}\t{stim}\t0.0\t48000.0\t{p}\t-\t98.5\tEye\tSeparator\tLeft\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-"));
        }
    }
    (lines.join(line_end) + line_end, fixation_rows)
}

#[test]
fn begaze_event_statistics_monocular_layout_gives_fixations_per_participant() {
    for line_end in ["\n", "\r\n"] {
        let (text, rows) = monocular_event_statistics(line_end);
        assert_eq!(
            detect_format(text.as_bytes()),
            Ok(GazeFormat::EventStatistics)
        );
        let dir = temp_dir("b-mono");
        let path = dir.join("mono.txt");
        std::fs::write(&path, &text).unwrap();
        let f = ingest_file(&path, &params()).unwrap();
        assert_eq!(
            f.detector,
            Detector::Events,
            "events are the default for format B"
        );
        assert_eq!(f.fixations.len(), rows);
        assert_eq!(
            f.recording.rows.unusable_total(),
            4,
            "the 4 separator rows, counted"
        );
        assert_eq!(f.recording.rows.events, 2 * rows, "fixations and saccades");
        // Each participant is a subject, each stimulus keeps 15.
        for p in ["P01", "P02"] {
            for s in ["10.png", "bunny.avi"] {
                let kept = f
                    .fixations
                    .iter()
                    .filter(|x| x.subject == p && x.stimulus == s && x.fate == Fate::Kept)
                    .count();
                assert_eq!(kept, 15, "{p} {s}");
            }
        }
        // Raw times are the tracker clock; the offset from onset is the trial time.
        let first = &f.fixations[0];
        assert_eq!(first.eye, "left");
        assert_eq!(first.start_us, 1_739_439_978_157_600);
        assert_eq!(first.onset_offset_us, Some(0));
        let second = &f.fixations[1];
        assert_eq!(second.onset_offset_us, Some(247_000));
    }
}

fn begaze36_events() -> String {
    let mut l: Vec<String> = [
        "[BeGaze]",
        "Converted from:\tC:\\data\\s01.idf",
        "Date:\t12.03.2015 10:20:30",
        "Version:\tBeGaze 3.6.40",
        "Sample Rate:\t30",
        "Subject:\ts01",
        "Description:\t",
        "",
        "Table Header for Fixations:",
        "Event Type\tTrial\tNumber\tStart\tEnd\tDuration\tLocation X\tLocation Y\tDispersion X\tDispersion Y\tPlane\tAvg. Pupil Size X\tAvg. Pupil Size Y",
        "",
        "Table Header for Saccades:",
        "Event Type\tTrial\tNumber\tStart\tEnd\tDuration\tStart Loc.X\tStart Loc.Y\tEnd Loc.X\tEnd Loc.Y\tAmplitude\tPeak Speed\tPeak Speed At\tAverage Speed\tPeak Accel.\tPeak Decel.\tAverage Accel.",
        "",
        "Table Header for Blinks:",
        "Event Type\tTrial\tNumber\tStart\tEnd\tDuration",
        "",
        "Table Header for User Events:",
        "Event Type\tTrial\tNumber\tStart\tDescription",
        "",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    let mut t: i64 = 1_286_764_499;
    l.push(format!(
        "UserEvent\t1\t1\t{}\t# Message: bunny.avi",
        t - 1000
    ));
    for i in 1..=24 {
        let d = 67_015 + i * 1000;
        l.push(format!(
            "Fixation B\t1\t{i}\t{t}\t{}\t{d}\t{:.2}\t{:.2}\t1\t1\t-1\t94.00\t89.25",
            t + d,
            766.5 + i as f64,
            662.74
        ));
        t += d;
        l.push(format!("Saccade B\t1\t{i}\t{t}\t{}\t33000\t700.00\t600.00\t710.00\t620.00\t1.20\t100.0\t0.5\t50.0\t1000\t-1000\t500", t + 33_000));
        t += 33_000;
    }
    l.push(format!("Blink B\t1\t1\t{t}\t{}\t100000", t + 100_000));
    l.join("\r\n") + "\r\n"
}

#[test]
fn begaze_3_6_binocular_event_text_gives_fixations() {
    let text = begaze36_events();
    assert_eq!(detect_format(text.as_bytes()), Ok(GazeFormat::EventTables));
    let dir = temp_dir("c1-b");
    let path = dir.join("s01_events.txt");
    std::fs::write(&path, &text).unwrap();
    let f = ingest_file(&path, &params()).unwrap();
    assert_eq!(f.recording.rows.unusable_total(), 0);
    assert_eq!(f.recording.header.sample_rate_hz, Some(30.0));
    assert_eq!(f.subject, "s01");
    assert_eq!(f.fixations.len(), 24);
    assert!(f
        .fixations
        .iter()
        .all(|x| x.eye == "binocular" && x.stimulus == "bunny.avi"));
    assert_eq!(
        f.fixations.iter().filter(|x| x.fate == Fate::Kept).count(),
        15
    );
}

#[test]
fn samples_without_gaze_position_say_why_and_what_to_do() {
    let mut l = vec![
        "## [iView]".to_string(),
        "## Sample Rate:\t250".into(),
        "## Subject:\tp3".into(),
        "## Calibration Area:\t1680\t1050".into(),
        "## ".into(),
        "Time\tType\tTrial\tL Raw X [px]\tL Raw Y [px]\tL Dia X [px]\tL Dia Y [px]\tL CR1 X [px]\tL CR1 Y [px]\tL POR X [px]\tL POR Y [px]\tR POR X [px]\tR POR Y [px]\tTiming\tL Validity\tR Validity".into(),
    ];
    for i in 0..500 {
        l.push(format!(
            "{}\tSMP\t1\t300.1\t200.2\t20.0\t19.0\t310.0\t210.0\t0.00\t0.00\t0.00\t0.00\t0\t1\t1",
            1_000_000 + i * 4000
        ));
    }
    let dir = temp_dir("por0");
    let path = dir.join("por0.txt");
    std::fs::write(&path, l.join("\n") + "\n").unwrap();
    let e = ingest_file(&path, &params())
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("0.00 in all 500 samples"), "{e}");
    assert!(
        e.contains("no gaze position") && e.contains("Re-export"),
        "{e}"
    );
    assert!(e.starts_with(&path.display().to_string()), "{e}");
}

#[test]
fn a_minimal_iview_column_subset_still_reads() {
    let mut l = vec![
        "## [iView]".to_string(),
        "## Sample Rate:\t250".into(),
        "## ".into(),
        "Time\tType\tTrial\tL POR X [px]\tL POR Y [px]\tR POR X [px]\tR POR Y [px]\tL Validity\tR Validity\tPupil Confidence".into(),
        "1000000\tMSG\t1\t# Message: bunny.mp4".into(),
    ];
    // Ten 300 ms fixations 130 px apart (more than I-DT's 100 px dispersion), 250 Hz.
    for k in 0..10 {
        for i in 0..75 {
            let t = 1_000_000 + (k * 75 + i) * 4000;
            let x = 200.0 + 130.0 * k as f64;
            l.push(format!("{t}\tSMP\t1\t{x}\t400\t{x}\t400\t1\t1\t1"));
        }
    }
    let rec = parse_recording((l.join("\n") + "\n").as_bytes(), "minimal.txt", None).unwrap();
    assert_eq!(rec.rows.unusable_total(), 0);
    assert_eq!(rec.samples.len(), 750);
    let fx = fixations(
        &rec,
        "s",
        Detector::IDt,
        EyePolicy::Best,
        &DetectorParams::default(),
        &params().segmentation,
    )
    .unwrap();
    assert_eq!(fx.len(), 10);
    assert!(fx.iter().all(|f| f.stimulus == "bunny.mp4"));
}

/// A 250 Hz recording whose messages are everything a real one carries; fixations every
/// 400 ms (300 ms fixating, 100 ms away) from 0 to 150 s.
fn recording_with_messages(messages: &[(i64, &str)]) -> Recording {
    let mut samples = Vec::new();
    let mut t = 0i64;
    let mut k = 0;
    while t < 150_000_000 {
        let phase = t % 400_000;
        let (x, y, valid) = if phase < 300_000 {
            (
                200.0 + 60.0 * (k % 20) as f64,
                300.0 + 40.0 * (k % 7) as f64,
                true,
            )
        } else {
            (0.0, 0.0, false) // a blink between fixations ends each one
        };
        let e = EyeSample {
            x,
            y,
            pupil: Some(3.5),
            valid,
            flag_lost: false,
        };
        samples.push(common::both_eyes_sample(t, e));
        t += 4000;
        if t % 400_000 == 0 {
            k += 1;
        }
    }
    Recording {
        file: "messages.txt".into(),
        format: GazeFormat::IdfSamples,
        header: Header {
            sample_rate_hz: Some(250.0),
            calibration_area_px: Some([1680.0, 1050.0]),
            subject: Some("s01".into()),
            ..Header::default()
        },
        columns: Vec::new(),
        samples,
        messages: messages
            .iter()
            .map(|&(t, text)| Message {
                time_us: t,
                trial: 1,
                text: text.to_string(),
            })
            .collect(),
        events: Vec::new(),
        rows: Default::default(),
        notes: Vec::new(),
    }
}

const REAL_MESSAGES: [(i64, &str); 11] = [
    (1_000_000, "Starting wait for fixation period"),
    (2_000_000, "# UTC: 1489598928 791"),
    (
        5_000_000,
        r"start_trial 36 C:\Users\someone\Desktop\Manip SMI\Images_finales\mtemo33.png",
    ),
    (10_000_000, "["),
    (20_000_000, "UE-mouseclick left x=407 y=378"),
    (30_000_000, "Starting wait for fixation period"),
    (40_000_000, "car_banana.jpg"),
    (50_000_000, "\"Spoon"),
    (60_000_000, "UE-keypress"),
    (70_000_000, "Elmos World The Sky Active.avi"),
    (140_000_000, "ball-calibration.avi"),
];

fn detect(rec: &Recording) -> Vec<Fixation> {
    fixations(
        rec,
        "s01",
        Detector::IDt,
        EyePolicy::Best,
        &DetectorParams::default(),
        &params().segmentation,
    )
    .unwrap()
}

#[test]
fn only_messages_naming_a_stimulus_file_start_a_stimulus() {
    let rec = recording_with_messages(&REAL_MESSAGES);
    let fx = detect(&rec);
    let mut names: Vec<&str> = fx.iter().map(|f| f.stimulus.as_str()).collect();
    names.dedup();
    // Segmentation by hand: before 5 s no stimulus; mtemo33.png 5–40 s (status, clock,
    // cut-off and user-event messages in between do not end it); car_banana.jpg 40–70 s;
    // the Elmo video 70–118 s (ended by the 48 s video length), then nothing until
    // ball-calibration.avi at 140 s. Fixations after a stimulus ended keep its name.
    assert_eq!(
        names,
        [
            "",
            "mtemo33.png",
            "car_banana.jpg",
            "Elmos World The Sky Active.avi",
            "ball-calibration.avi"
        ]
    );
    let in_range = |f: &Fixation, a: i64, b: i64| f.start_us >= a && f.start_us < b;
    for f in &fx {
        let expected = match f.start_us {
            t if t < 5_000_000 => "",
            t if t < 40_000_000 => "mtemo33.png",
            t if t < 70_000_000 => "car_banana.jpg",
            t if t < 140_000_000 => "Elmos World The Sky Active.avi",
            _ => "ball-calibration.avi",
        };
        assert_eq!(f.stimulus, expected, "fixation at {} µs", f.start_us);
        let outside = in_range(f, 0, 5_000_000) || in_range(f, 118_000_000, 140_000_000);
        assert_eq!(f.fate == Fate::Invalid, outside, "at {} µs", f.start_us);
        if outside {
            assert!(f.invalid_reason.is_some());
        }
    }
    let late = fx
        .iter()
        .find(|f| in_range(f, 118_000_000, 140_000_000))
        .unwrap();
    assert_eq!(
        late.invalid_reason,
        Some("after the stimulus ended (the protocol's stimulus length)")
    );
    // Every other message is listed with its kind.
    let kinds: Vec<MessageKind> = classify_messages(&rec, &params().segmentation)
        .iter()
        .map(|m| m.kind)
        .collect();
    use MessageKind::*;
    assert_eq!(
        kinds,
        [
            Status, Clock, Stimulus, Truncated, UserEvent, Status, Stimulus, Truncated, UserEvent,
            Stimulus, Stimulus
        ]
    );
}

#[test]
fn a_fixation_after_the_video_ended_is_invalid_at_ingest_not_a_kept_slot() {
    // One stimulus at 0: the video ends at 48 s; the recording runs to 150 s.
    let rec = recording_with_messages(&[(0, "bunny.mp4")]);
    let mut fx = detect(&rec);
    apply_protocol_filter(&mut fx, 2, 2, 15);
    assert!(fx
        .iter()
        .filter(|f| f.start_us >= VIDEO_US)
        .all(|f| f.fate == Fate::Invalid));
    // The last two valid fixations dropped are the last two before 48 s.
    let mut valid: Vec<&Fixation> = fx.iter().filter(|f| f.start_us < VIDEO_US).collect();
    valid.sort_by_key(|f| f.start_us);
    let n = valid.len();
    assert_eq!(valid[n - 1].fate, Fate::DroppedLast);
    assert_eq!(valid[n - 2].fate, Fate::DroppedLast);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn mutated_variant_files_never_panic_and_account_for_every_line(
        which in 0usize..2,
        seed in any::<u64>(),
        edits in 1usize..20,
    ) {
        let mut bytes = if which == 0 {
            monocular_event_statistics("\r\n").0.into_bytes()
        } else {
            begaze36_events().into_bytes()
        };
        let mut s = seed;
        for _ in 0..edits {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let at = (s >> 33) as usize % bytes.len();
            let alphabet = b"\t\n,.-B0x\"#";
            let what = alphabet[(s >> 20) as usize % alphabet.len()];
            match s % 3 {
                0 => bytes[at] = what,
                1 => bytes.insert(at, what),
                _ => {
                    bytes.remove(at);
                }
            }
        }
        if let Ok(r) = parse_recording(&bytes, "mutated", None) {
            prop_assert_eq!(r.rows.accounted(), r.rows.lines);
            let _ = fixations(&r, "s", meshgaze::gaze::ingest::default_detector(&r), EyePolicy::Best, &DetectorParams::default(), &params().segmentation);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]
    #[test]
    fn messages_change_stimulus_and_fate_never_the_fixations(
        picks in proptest::collection::vec((0i64..150_000, 0usize..REAL_MESSAGES.len()), 0..12)
    ) {
        let bare = detect(&recording_with_messages(&[]));
        let msgs: Vec<(i64, &str)> = picks.iter().map(|&(t, k)| (t * 1000, REAL_MESSAGES[k].1)).collect();
        let with = detect(&recording_with_messages(&msgs));
        prop_assert_eq!(bare.len(), with.len());
        for (a, b) in bare.iter().zip(&with) {
            prop_assert_eq!((a.start_us, a.end_us, a.x_px, a.y_px), (b.start_us, b.end_us, b.x_px, b.y_px));
        }
    }
}

/// Fixations with distinct durations in a shuffled order, some invalid.
fn filter_case() -> Vec<Fixation> {
    let durations = [
        310.0, 120.0, 450.0, 95.0, 505.0, 230.0, 180.0, 640.0, 275.0, 390.0, 150.0, 820.0, 205.0,
        330.0, 415.0, 260.0, 555.0, 140.0, 700.0, 365.0, 480.0, 110.0, 290.0, 600.0, 170.0,
    ];
    durations
        .iter()
        .enumerate()
        .map(|(i, &d)| Fixation {
            subject: "s".into(),
            stimulus: "bunny.mp4".into(),
            eye: "left",
            trial: 1,
            start_us: 1_000_000 * i as i64,
            end_us: 1_000_000 * i as i64 + (d * 1000.0) as i64,
            duration_ms: d,
            x_px: 100.0,
            y_px: 100.0,
            dispersion_px: None,
            pupil: None,
            // Fixations 0 and 23 are invalid: they neither count among the first and last two
            // nor take a kept slot.
            fate: if i == 0 || i == 23 {
                Fate::Invalid
            } else {
                Fate::Kept
            },
            onset_offset_us: Some(1_000_000 * i as i64),
            invalid_reason: (i == 0 || i == 23).then_some("no gaze position"),
        })
        .collect()
}

#[test]
fn the_filter_keeps_the_15_longest_of_the_middle_known_answer() {
    let mut fx = filter_case();
    apply_protocol_filter(&mut fx, 2, 2, 15);
    // By hand: valid indices in time order are 1..=22 and 24. First two: 1, 2. Last two: 22,
    // 24. Middle: 3..=21 (19 fixations); its 4 shortest are 3 (95), 21 (110), 17 (140),
    // 10 (150); the other 15 are kept.
    let fate = |i: usize| fx[i].fate;
    assert_eq!((fate(0), fate(23)), (Fate::Invalid, Fate::Invalid));
    assert_eq!((fate(1), fate(2)), (Fate::DroppedFirst, Fate::DroppedFirst));
    assert_eq!((fate(22), fate(24)), (Fate::DroppedLast, Fate::DroppedLast));
    let not_longest: Vec<usize> = (0..fx.len())
        .filter(|&i| fate(i) == Fate::NotLongest)
        .collect();
    assert_eq!(not_longest, [3, 10, 17, 21]);
    let kept: Vec<usize> = (0..fx.len()).filter(|&i| fate(i) == Fate::Kept).collect();
    assert_eq!(kept, [4, 5, 6, 7, 8, 9, 11, 12, 13, 14, 15, 16, 18, 19, 20]);
}

#[test]
fn the_filter_breaks_duration_ties_towards_the_earlier_fixation() {
    let mut fx = filter_case();
    for f in fx.iter_mut() {
        f.duration_ms = 200.0;
        f.fate = Fate::Kept;
        f.invalid_reason = None;
    }
    apply_protocol_filter(&mut fx, 2, 2, 15);
    // All equal: after dropping 0, 1 and 23, 24, the 15 earliest of 2..=22 are kept.
    let kept: Vec<usize> = (0..fx.len())
        .filter(|&i| fx[i].fate == Fate::Kept)
        .collect();
    assert_eq!(kept, (2..17).collect::<Vec<_>>());
}

#[test]
fn a_sample_and_an_event_export_of_one_subject_are_refused() {
    let dir = temp_dir("dup");
    let rec = recording_with_messages(&[(0, "bunny.mp4")]);
    let a = dir.join("s01_samples.txt");
    let text = write_samples_a(&rec.header, &rec.samples, &rec.messages);
    std::fs::write(&a, &text).unwrap();
    let b = dir.join("s01_again.txt");
    std::fs::write(&b, &text).unwrap();
    let files = vec![
        ingest_file(&a, &params()).unwrap(),
        ingest_file(&b, &params()).unwrap(),
    ];
    let e = check_one_source_per_subject(&files)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s01_samples.txt") && e.contains("s01_again.txt") && e.contains("s01"),
        "{e}"
    );
}

fn meshgaze(dir: &Path, args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr),
    )
}

#[test]
fn the_binary_works_from_any_directory() {
    let dir = temp_dir("anywhere");
    // No protocols/ folder here: the built-in protocol serves every default.
    let (ok, text) = meshgaze(&dir, &["protocol", "show"]);
    assert!(ok && text.contains("[fixations]"), "{text}");
    std::fs::write(dir.join("mono.txt"), monocular_event_statistics("\n").0).unwrap();
    let (ok, text) = meshgaze(&dir, &["ingest", "mono.txt", "-o", "ingest"]);
    assert!(ok, "{text}");
    assert!(dir.join("ingest/fixations.csv").exists());
    let (ok, text) = meshgaze(&dir, &["ingest", "--list-messages", "mono.txt"]);
    assert!(ok, "{text}");
    // A missing file: named once, the OS error once.
    let (ok, text) = meshgaze(&dir, &["protocol", "check", "nope.toml"]);
    assert!(!ok);
    assert_eq!(text.matches("os error 2").count(), 1, "{text}");
    assert!(text.contains("nope.toml"), "{text}");
}

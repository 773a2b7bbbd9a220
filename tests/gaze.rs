//! SMI readers on every real export in ../shared/data/smi, plus arbitrary and mutated bytes.
mod common;

use std::path::PathBuf;

use meshgaze::gaze::{parse_recording, read_recording, EventKind, Eye, GazeFormat, Recording};
use proptest::prelude::*;

fn smi(name: &str) -> PathBuf {
    common::shared_data().join("smi").join(name)
}

fn read(name: &str) -> Recording {
    let r = read_recording(&smi(name), None).unwrap_or_else(|e| panic!("{e}"));
    // Nothing unaccounted for: every line is header, blank, sample, message, event or counted.
    assert_eq!(r.rows.accounted(), r.rows.lines, "{name}: {:?}", r.rows);
    r
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn hbn_samples_binocular_60hz_with_anonymised_header() {
    let r = read("hbn-sccn__NDARAA075AMK_Video1_Samples.txt");
    assert_eq!(r.format, GazeFormat::IdfSamples);
    assert_eq!(
        (r.rows.samples, r.rows.messages, r.rows.unusable_total()),
        (7343, 3, 0)
    );
    assert_eq!(r.header.sample_rate_hz, Some(60.0));
    assert_eq!(r.header.calibration_area_px, Some([800.0, 600.0]));
    assert_eq!(r.header.stimulus_dimension_mm, Some([321.0, 240.0]));
    assert_eq!(r.header.head_distance_mm, Some(700.0));
    assert_eq!(
        r.header.subject, None,
        "`Subject: NA` is anonymised, not a name"
    );
    let s = &r.samples[0];
    assert_eq!(s.time_us, 2_882_291_263); // microseconds, kept as integers
    let (l, rt) = (s.left.unwrap(), s.right.unwrap());
    assert_eq!((l.x, l.y, l.pupil), (812.98, 561.38, Some(5.80)));
    assert_eq!((rt.x, rt.y), (791.19, 508.62));
    assert_eq!(
        r.messages
            .iter()
            .map(|m| m.text.as_str())
            .collect::<Vec<_>>(),
        ["9999", "81", "101"]
    );
    assert_eq!(r.messages[0].time_us, 2_886_122_672);
    // Tracking loss (smi-formats.md A.5): 110 samples have both validity flags 0; 79 more
    // carry SMI's loss value POR (0.00, 0.00) on both eyes while a flag still says valid.
    // Both count as lost: a gaze exactly on the corner pixel is not a measurement.
    let both_lost = r
        .samples
        .iter()
        .filter(|s| !s.left.unwrap().valid && !s.right.unwrap().valid)
        .count();
    assert_eq!(both_lost, 110 + 79);
    // Not uniform: a 33 ms gap is a dropped sample; the mean step is ~16.66 ms.
    let steps: Vec<i64> = r
        .samples
        .windows(2)
        .map(|w| w[1].time_us - w[0].time_us)
        .collect();
    let mean = steps.iter().sum::<i64>() as f64 / steps.len() as f64;
    assert!((mean - 16_662.5).abs() < 1.0, "mean step {mean} µs");
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn emip_samples_with_pauses_and_identical_eyes() {
    let r = read("emip__156_rawdata.tsv");
    assert_eq!((r.rows.samples, r.rows.messages), (10939, 12));
    assert_eq!(r.header.calibration_area_px, Some([1920.0, 1080.0]));
    assert_eq!(r.header.subject.as_deref(), Some("156"));
    assert!(r
        .samples
        .iter()
        .all(|s| s.left.unwrap().x == s.right.unwrap().x));
    let biggest_gap = r
        .samples
        .windows(2)
        .map(|w| w[1].time_us - w[0].time_us)
        .max()
        .unwrap();
    assert_eq!(biggest_gap / 1_000_000, 147, "the 147 s recording pause");
    assert_eq!(r.messages[0].text, "instruction_calibration.jpg");
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn didec_begaze_samples_with_event_info_and_stimulus() {
    let r = read("pymovements__didec_example.txt");
    assert_eq!(r.format, GazeFormat::BeGazeSamples);
    assert_eq!((r.rows.samples, r.rows.messages), (15, 1));
    assert_eq!(r.samples[0].stimulus.as_deref(), Some("test.bmp"));
    assert!(r
        .samples
        .iter()
        .any(|s| s.left_event.as_deref() == Some("Saccade")));
    // 250 Hz: steps of about 4 ms in µs, not 4 µs nor 4 s.
    let step = r.samples[1].time_us - r.samples[0].time_us;
    assert!((3_900..=4_100).contains(&step), "{step}");
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn hbn_events_with_tabs_turned_into_spaces_match_the_samples_clock() {
    let r = read("hbn-sccn__NDARAA075AMK_Video1_Events.txt");
    assert_eq!(r.format, GazeFormat::EventTables);
    assert!(r.notes.iter().any(|n| n.contains("spaces")));
    assert_eq!(r.rows.messages, 3);
    assert_eq!(r.rows.unusable_total(), 0);
    // Same clock as the sample file: the first saccade starts at the first sample.
    assert_eq!(r.events[0].start_us, 2_882_291_263);
    let fix: Vec<_> = r
        .events
        .iter()
        .filter(|e| e.kind == EventKind::Fixation)
        .collect();
    assert!(fix.iter().any(|e| e.eye == Eye::Left) && fix.iter().any(|e| e.eye == Eye::Right));
    assert!(fix.iter().all(|e| e.end_us - e.start_us == e.duration_us));
    // Sorted by trial and start although the file lists all L events before the R ones.
    assert!(r
        .events
        .windows(2)
        .all(|w| (w[0].trial, w[0].start_us) <= (w[1].trial, w[1].start_us)));
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn zv1n_events_87_trials_tab_separated() {
    let r = read("zv1n-pygaze__events.txt");
    assert_eq!(r.header.sample_rate_hz, Some(50.0));
    assert_eq!(
        r.header.date.map(|d| d.to_string()).as_deref(),
        Some("2014-12-08 19:19:12")
    );
    assert_eq!(r.events.iter().map(|e| e.trial).max(), Some(87));
    let first = r
        .events
        .iter()
        .find(|e| e.kind == EventKind::Fixation)
        .unwrap();
    assert_eq!(
        (first.start_us, first.duration_us),
        (3_382_446_927_630, 537_022)
    );
    assert_eq!(
        (first.x, first.y, first.dispersion_x),
        (Some(781.40), Some(400.76), Some(54.0))
    );
    assert!(r.messages.is_empty(), "the User Events section is empty");
}

#[test]
fn malformed_or_unknown_files_say_what_and_where() {
    let e = parse_recording(
        b"Trial,Event Start Trial Time [ms],Event End Trial Time [ms]\n",
        "stats.txt",
        None,
    )
    .map(|r| r.file)
    .unwrap_err()
    .to_string();
    assert_eq!(
        e,
        "stats.txt:1:1: no `Category` (or `Category Left/Right/Binocular`) column"
    );
    let e = parse_recording(b"hello\nworld\n", "notes.txt", None)
        .map(|r| r.file)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("notes.txt: not a recognized gaze recording"),
        "{e}"
    );
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn etg_begaze_raw_data_comma_reexport() {
    let r = read("xiangguo-etg__Ethan_lane_1-1-recording.csv");
    assert_eq!(r.format, GazeFormat::BeGazeRaw);
    assert_eq!((r.rows.samples, r.rows.unusable_total()), (11_111, 0));
    assert!(r.notes.iter().any(|n| n.contains("re-exported")));
    let s = &r.samples[0];
    assert_eq!(s.time_us, 86_386_700, "86386.7 ms");
    assert_eq!(s.trial, 1, "Trial001");
    let (b, rt) = (s.binocular.unwrap(), s.right.unwrap());
    assert_eq!((b.x, b.y), (140.6, 392.6));
    assert_eq!(
        (rt.x, rt.y, rt.pupil),
        (-11.9, -176.6, Some(4.0)),
        "negative POR is kept (scene camera)"
    );
    assert!(s.left.is_none(), "this export has no left-eye columns");
    assert_eq!(s.binocular_event.as_deref(), Some("Blink"));
    assert_eq!(r.header.subject.as_deref(), Some("Ethan lane 1_2"));
    let count = |c: &str| {
        r.samples
            .iter()
            .filter(|s| s.binocular_event.as_deref() == Some(c))
            .count()
    };
    assert_eq!(
        (
            count("Visual Intake"),
            count("Saccade"),
            count("Blink"),
            count("-")
        ),
        (7787, 1479, 1554, 291)
    );
}

#[test]
fn bad_rows_are_counted_with_their_position_never_dropped_silently() {
    let text = "## [iView]\n## Sample Rate:\t250\n## \nTime\tType\tTrial\tL POR X [px]\tL POR Y [px]\n\
                100\tSMP\t1\t10.5\t20.5\n104\tSMP\t1\tx\t20\n108\tSMP\t1\t11\n112\tXYZ\t1\t1\t1\n116\tMSG\t1\t# Message: a b\n";
    let r = parse_recording(text.as_bytes(), "t.txt", None).unwrap();
    assert_eq!(r.rows.samples, 1);
    assert_eq!(r.rows.messages, 1);
    assert_eq!(r.rows.unusable_total(), 3);
    assert_eq!(r.rows.accounted(), r.rows.lines);
    let bad_number = &r.rows.unusable["`L POR X [px]` is not a number"];
    assert_eq!((bad_number.line, bad_number.column), (6, 11));
    assert!(r.rows.unusable.keys().any(|k| k.contains("XYZ")));
    assert_eq!(r.messages[0].text, "a b");
}

fn real_files() -> Vec<Vec<u8>> {
    let d = common::shared_data();
    [
        "hbn-sccn__NDARAA075AMK_Video1_Samples.txt",
        "hbn-sccn__NDARAA075AMK_Video1_Events.txt",
        "emip__156_rawdata.tsv",
        "pymovements__didec_example.txt",
        "zv1n-pygaze__events.txt",
        "xiangguo-etg__Ethan_lane_1-1-recording.csv",
    ]
    .iter()
    .map(|f| {
        let b = std::fs::read(d.join("smi").join(f)).unwrap();
        b[..b.len().min(20_000)].to_vec()
    })
    .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        for f in [None, Some(GazeFormat::IdfSamples), Some(GazeFormat::EventTables), Some(GazeFormat::BeGazeRaw)] {
            let _ = parse_recording(&bytes, "fuzz", f);
        }
    }

    #[test]
    #[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
    fn mutated_real_files_never_panic_and_account_for_every_line(which in 0usize..6, seed in any::<u64>(), edits in 1usize..20) {
        let files = real_files();
        let mut b = files[which].clone();
        let mut s = seed | 1;
        let mut next = || { s ^= s << 13; s ^= s >> 7; s ^= s << 17; s };
        for _ in 0..edits {
            let i = (next() as usize) % b.len();
            b[i] = match next() % 5 { 0 => b'\t', 1 => b'\n', 2 => b'-', 3 => b' ', _ => next() as u8 };
        }
        if let Ok(r) = parse_recording(&b, "mutated", None) {
            prop_assert_eq!(r.rows.accounted(), r.rows.lines);
        }
    }
}

mod fixation_tests {
    use super::*;
    use meshgaze::gaze::fixations::{
        apply_protocol_filter, fixations, Detector, DetectorParams, EyePolicy, Fate,
    };
    use meshgaze::gaze::recording::{EyeSample, Header, RowAccount};

    /// 250 Hz samples: 300 ms at (100,100), a jump, 500 ms at (400,300), a jump, 200 ms at (700,500).
    fn synthetic() -> Recording {
        let mut samples = Vec::new();
        let mut t = 0i64;
        for &(x, y, ms) in &[
            (100.0, 100.0, 300),
            (400.0, 300.0, 500),
            (700.0, 500.0, 200),
        ] {
            for k in 0..(ms / 4) {
                let jitter = if k % 2 == 0 { 1.0 } else { -1.0 };
                let e = EyeSample {
                    x: x + jitter,
                    y,
                    pupil: Some(4.0),
                    valid: true,
                    flag_lost: false,
                };
                samples.push(common::both_eyes_sample(t, e));
                t += 4000;
            }
            t += 40_000; // a 40 ms saccade without samples
        }
        Recording {
            file: "synthetic".into(),
            format: GazeFormat::IdfSamples,
            header: Header {
                sample_rate_hz: Some(250.0),
                calibration_area_px: Some([1680.0, 1050.0]),
                ..Default::default()
            },
            columns: Vec::new(),
            samples,
            messages: Vec::new(),
            events: Vec::new(),
            rows: RowAccount::default(),
            notes: Vec::new(),
        }
    }

    #[test]
    fn dispersion_and_velocity_detectors_find_the_three_fixations() {
        let rec = synthetic();
        for detector in [Detector::IDt, Detector::IVt] {
            let f = fixations(
                &rec,
                "s1",
                detector,
                EyePolicy::Average,
                &DetectorParams::default(),
                &meshgaze::gaze::stimulus_messages::Segmentation::default(),
            )
            .unwrap();
            assert_eq!(f.len(), 3, "{detector:?}: {f:?}");
            let durations: Vec<f64> = f.iter().map(|x| x.duration_ms).collect();
            assert_eq!(durations, vec![300.0, 500.0, 200.0], "{detector:?}");
            // 125 samples jittered +1/-1 alternately: mean x = 400 + 1/125.
            assert!((f[1].x_px - (400.0 + 1.0 / 125.0)).abs() < 1e-9 && f[1].y_px == 300.0);
            assert_eq!(f[1].dispersion_px, Some(2.0));
        }
    }

    #[test]
    fn the_protocol_filter_gives_every_fixation_a_fate() {
        let rec = synthetic();
        let mut f = fixations(
            &rec,
            "s1",
            Detector::IDt,
            EyePolicy::Left,
            &DetectorParams::default(),
            &meshgaze::gaze::stimulus_messages::Segmentation::default(),
        )
        .unwrap();
        // Drop the first one and the last one, keep the single longest of what is left.
        apply_protocol_filter(&mut f, 1, 1, 1);
        let fates: Vec<Fate> = f.iter().map(|x| x.fate).collect();
        assert_eq!(
            fates,
            vec![Fate::DroppedFirst, Fate::Kept, Fate::DroppedLast]
        );
        // 20 fixations of equal length: ties go to the earlier ones.
        let mut many: Vec<_> = (0..20)
            .map(|k| {
                let mut x = f[1].clone();
                x.start_us = k * 1_000_000;
                x.fate = Fate::Kept;
                x
            })
            .collect();
        apply_protocol_filter(&mut many, 2, 2, 15);
        let kept: Vec<i64> = many
            .iter()
            .filter(|x| x.fate == Fate::Kept)
            .map(|x| x.start_us / 1_000_000)
            .collect();
        assert_eq!(kept, (2..17).collect::<Vec<_>>());
        assert_eq!(
            many.iter().filter(|x| x.fate == Fate::NotLongest).count(),
            1
        );
    }

    #[test]
    #[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
    fn fixations_from_real_event_and_sample_files_agree_in_scale() {
        let (s, e) = (
            read("hbn-sccn__NDARAA075AMK_Video1_Samples.txt"),
            read("hbn-sccn__NDARAA075AMK_Video1_Events.txt"),
        );
        // HBN's messages are bare trigger numbers (9999, 81, 101): no file name, so they
        // start a stimulus only under a pattern, as a user would give it.
        let numbered = meshgaze::gaze::stimulus_messages::Segmentation {
            pattern: Some(
                meshgaze::gaze::stimulus_messages::StimulusPattern::new(r"^(\d+)$", None).unwrap(),
            ),
            max_duration_us: None,
        };
        let from_events = fixations(
            &e,
            "hbn",
            Detector::Events,
            EyePolicy::Left,
            &DetectorParams::default(),
            &numbered,
        )
        .unwrap();
        let detected = fixations(
            &s,
            "hbn",
            Detector::IDt,
            EyePolicy::Left,
            &DetectorParams::default(),
            &numbered,
        )
        .unwrap();
        let mean = |f: &[meshgaze::gaze::fixations::Fixation]| {
            f.iter().map(|x| x.duration_ms).sum::<f64>() / f.len() as f64
        };
        let total = |f: &[meshgaze::gaze::fixations::Fixation]| {
            f.iter().map(|x| x.duration_ms).sum::<f64>() / 1000.0
        };
        eprintln!(
            "HBN: {} fixations from IDF Event Detector (mean {:.0} ms, {:.0} s in all), {} by meshgaze's I-DT (mean {:.0} ms, {:.0} s in all)",
            from_events.len(), mean(&from_events), total(&from_events), detected.len(), mean(&detected), total(&detected)
        );
        assert!(from_events.len() > 400 && detected.len() > 200);
        // The two detectors differ in thresholds (SMI's event detector merges less), so
        // counts and means differ; what must agree is the scale: time spent fixating within
        // 25% of each other, and mean durations within a factor of 2.5.
        let (te, td) = (total(&from_events), total(&detected));
        assert!(
            (te - td).abs() / te.max(td) < 0.25,
            "{te} s vs {td} s fixating"
        );
        let ratio = mean(&detected) / mean(&from_events);
        assert!((0.4..=2.5).contains(&ratio), "mean duration ratio {ratio}");
        // Both split the recording by the same stimulus messages.
        assert!(
            from_events.iter().any(|f| f.stimulus == "81")
                && detected.iter().any(|f| f.stimulus == "81")
        );
    }
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn ingest_command_writes_fixations_with_fates_quality_and_provenance() {
    let (s, e) = (
        smi("hbn-sccn__NDARAA075AMK_Video1_Samples.txt"),
        smi("hbn-sccn__NDARAA075AMK_Video1_Events.txt"),
    );
    let out = std::env::temp_dir().join(format!("meshgaze-ingest-{}", std::process::id()));
    let ingest = |files: &[&std::path::Path]| {
        std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
            .args([
                "ingest",
                "--quiet",
                "--stimulus-pattern",
                r"^(\d+)$",
                "--protocol",
            ])
            .arg(common::repo_root().join("protocols/hu2020.toml"))
            .arg("-o")
            .arg(&out)
            .args(files)
            .output()
            .unwrap()
    };
    // The sample and the event export of one recording: the same subject twice, refused.
    let both = ingest(&[&s, &e]);
    assert!(!both.status.success());
    let why = String::from_utf8_lossy(&both.stderr);
    assert!(
        why.contains("Samples.txt") && why.contains("Events.txt") && why.contains("twice"),
        "{why}"
    );
    assert!(ingest(&[&e]).status.success());
    let fix = std::fs::read_to_string(out.join("fixations.csv")).unwrap();
    let mut lines = fix.lines();
    assert_eq!(lines.next().unwrap(), "subject,stimulus,eye,trial,start_us,end_us,duration_ms,x_px,y_px,dispersion_px,pupil,onset_offset_us,fate,invalid_reason");
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(rows.iter().all(|r| r.len() == 14));
    // Per subject and stimulus: 15 kept.
    let kept_81 = rows
        .iter()
        .filter(|r| r[1] == "81" && r[12] == "kept")
        .count();
    assert_eq!(kept_81, 15);
    let quality = std::fs::read_to_string(out.join("quality.csv")).unwrap();
    assert!(quality.lines().count() >= 3);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("ingest.json")).unwrap()).unwrap();
    assert_eq!(json["files"].as_array().unwrap().len(), 1);
    assert_eq!(json["files"][0]["messages"]["stimulus"], 3);
    assert_eq!(
        json["provenance"]["inputs"][0]["sha256"]
            .as_str()
            .unwrap()
            .len(),
        64
    );
}

mod writer_round_trip {
    use super::*;
    use meshgaze::gaze::recording::{Event, EventKind, Eye, EyeSample, Header, Message, Sample};
    use meshgaze::gaze::writers::{write_events_c1, write_samples_a};

    fn header() -> Header {
        Header {
            sample_rate_hz: Some(250.0),
            calibration_area_px: Some([1680.0, 1050.0]),
            stimulus_dimension_mm: Some([473.8, 296.1]),
            head_distance_mm: Some(1020.0),
            subject: Some("virtual-03".into()),
            date: chrono::NaiveDateTime::parse_from_str("23.11.2026 10:41:00", "%d.%m.%Y %H:%M:%S")
                .ok(),
            ..Default::default()
        }
    }

    fn eye() -> impl Strategy<Value = Option<EyeSample>> {
        proptest::option::of(
            (
                1.0f64..1679.0,
                1.0f64..1049.0,
                proptest::option::of(2.0f64..8.0),
                any::<bool>(),
            )
                .prop_map(|(x, y, pupil, valid)| EyeSample {
                    x,
                    y,
                    pupil,
                    valid,
                    flag_lost: !valid,
                }),
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(60))]

        #[test]
        fn format_a_round_trips_exactly(
            eyes in proptest::collection::vec((eye(), eye(), 1u32..4), 1..60),
            texts in proptest::collection::vec("[a-z0-9_.=]{1,12}( [a-z]{1,5})?", 0..4),
        ) {
            let mut t = 1_000_000i64;
            let samples: Vec<Sample> = eyes.iter().map(|(l, r, trial)| {
                t += 4000;
                // A missing eye reads back as an invalid (0, 0) eye: write what a tracker writes.
                let fill = |e: &Option<EyeSample>| Some(e.unwrap_or(EyeSample { x: 0.0, y: 0.0, pupil: None, valid: false, flag_lost: true }));
                Sample { time_us: t, trial: *trial, left: fill(l), right: fill(r), binocular: None, binocular_event: None, left_event: None, right_event: None, stimulus: None }
            }).collect();
            let messages: Vec<Message> = texts.iter().enumerate().map(|(k, text)| Message { time_us: 1_000_000 + 10_000 * k as i64 + 1, trial: 1, text: text.clone() }).collect();
            let text = write_samples_a(&header(), &samples, &messages);
            let back = parse_recording(text.as_bytes(), "written.txt", None).unwrap();
            prop_assert_eq!(back.format, GazeFormat::IdfSamples);
            prop_assert_eq!(back.rows.unusable_total(), 0);
            prop_assert_eq!(&back.samples, &samples);
            prop_assert_eq!(&back.messages, &messages);
            let h = header();
            prop_assert_eq!((back.header.sample_rate_hz, back.header.calibration_area_px, back.header.stimulus_dimension_mm), (h.sample_rate_hz, h.calibration_area_px, h.stimulus_dimension_mm));
            prop_assert_eq!((back.header.head_distance_mm, back.header.subject, back.header.date), (h.head_distance_mm, h.subject, h.date));
        }

        #[test]
        fn format_c1_round_trips_exactly(
            raw in proptest::collection::vec((0u8..3, any::<bool>(), 1u32..3, 0i64..10_000_000, 1i64..2_000_000, 0.0f64..1680.0, 0.0f64..1050.0), 1..40),
        ) {
            let mut events: Vec<Event> = raw.iter().enumerate().map(|(k, &(kind, left, trial, start, dur, x, y))| {
                let kind = [EventKind::Fixation, EventKind::Saccade, EventKind::Blink][kind as usize];
                let located = kind != EventKind::Blink;
                Event {
                    kind, eye: if left { Eye::Left } else { Eye::Right }, trial, number: k as u64 + 1,
                    start_us: start, end_us: start + dur, duration_us: dur,
                    x: located.then_some(x), y: located.then_some(y),
                    end_x: (kind == EventKind::Saccade).then_some(y), end_y: (kind == EventKind::Saccade).then_some(x),
                    dispersion_x: (kind == EventKind::Fixation).then_some(12.0), dispersion_y: (kind == EventKind::Fixation).then_some(7.0),
                    pupil_x: (kind == EventKind::Fixation).then_some(16.5), pupil_y: (kind == EventKind::Fixation).then_some(16.25), stimulus: None,
                    stimulus_onset_us: None,
                    participant: None,
                }
            }).collect();
            let messages = vec![Message { time_us: 5, trial: 1, text: "bunny.mp4".into() }];
            let text = write_events_c1(&header(), &events, &messages);
            let back = parse_recording(text.as_bytes(), "written_events.txt", None).unwrap();
            prop_assert_eq!(back.format, GazeFormat::EventTables);
            prop_assert_eq!(back.rows.unusable_total(), 0);
            events.sort_by_key(|e| (e.trial, e.start_us, e.eye, e.number));
            prop_assert_eq!(&back.events, &events);
            prop_assert_eq!(&back.messages, &messages);
        }
    }
}

/// Format B has no real file here: these follow the column names documented in
/// shared/docs/smi-formats.md, in the two dialects users produce.
#[test]
fn begaze_event_statistics_tab_and_semicolon_decimal_comma() {
    let tab = "Trial\tStimulus\tParticipant\tCategory\tEye L/R\tEvent Start Trial Time [ms]\tEvent End Trial Time [ms]\tEvent Duration [ms]\tFixation Position X [px]\tFixation Position Y [px]\tFixation Dispersion X [px]\tFixation Dispersion Y [px]\tFixation Average Pupil Diameter [mm]\tSaccade Start Position X [px]\tSaccade Start Position Y [px]\tSaccade End Position X [px]\tSaccade End Position Y [px]\n\
Trial001\tbunny.mp4\tP07\tFixation\tLeft\t120.5\t420.5\t300.0\t812.3\t400.1\t12\t9\t3.9\t-\t-\t-\t-\n\
Trial001\tbunny.mp4\tP07\tSaccade\tLeft\t420.5\t460.5\t40.0\t-\t-\t-\t-\t-\t812.3\t400.1\t600.0\t300.0\n\
Trial001\tbunny.mp4\tP07\tSeparator\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\t-\n\
Trial002\tcow.mp4\tP07\tFixation\tRight\t10\t250\t240\t100\t200\t5\t5\t4.1\t-\t-\t-\t-\n";
    let r = parse_recording(tab.as_bytes(), "Event Statistics - Single - 01.txt", None).unwrap();
    assert_eq!(r.format, GazeFormat::EventStatistics);
    assert_eq!(
        (r.rows.events, r.rows.unusable_total(), r.rows.accounted()),
        (3, 1, r.rows.lines)
    );
    assert!(r.rows.unusable.keys().any(|k| k.contains("Separator")));
    assert_eq!(r.header.subject.as_deref(), Some("P07"));
    let f = &r.events[0];
    assert_eq!(
        (f.kind, f.eye, f.trial, f.start_us, f.end_us, f.duration_us),
        (EventKind::Fixation, Eye::Left, 1, 120_500, 420_500, 300_000)
    );
    assert_eq!(
        (f.x, f.y, f.stimulus.as_deref()),
        (Some(812.3), Some(400.1), Some("bunny.mp4"))
    );
    let s = &r.events[1];
    assert_eq!(
        (s.kind, s.x, s.end_x),
        (EventKind::Saccade, Some(812.3), Some(600.0))
    );
    assert_eq!((r.events[2].trial, r.events[2].eye), (2, Eye::Right));

    let semicolon = "Trial;Stimulus;Participant;Category Binocular;Event Start Trial Time [ms];Event End Trial Time [ms];Event Duration [ms];Fixation Position X [px];Fixation Position Y [px]\n\
Trial001;bunny.mp4;P08;Visual Intake;1000,5;1350,5;350,0;640,25;512,75\n\
Trial001;bunny.mp4;P08;-;1350,5;1400,0;49,5;-;-\n\
Trial001;bunny.mp4;P08;Fixation;1400,0;abc;1,0;1;1\n";
    let r = parse_recording(semicolon.as_bytes(), "stats.csv", None).unwrap();
    assert_eq!((r.rows.events, r.rows.unusable_total()), (1, 2));
    let e = &r.events[0];
    assert_eq!(
        (e.eye, e.start_us, e.x, e.y),
        (Eye::Binocular, 1_000_500, Some(640.25), Some(512.75)),
        "decimal comma read"
    );
    let bad = &r.rows.unusable["`Event End Trial Time [ms]` is not a number"];
    assert_eq!(bad.line, 4);
    // Fixations from a binocular-only export use the binocular stream, named by its stimulus,
    // with the trial-relative start as the offset from onset.
    use meshgaze::gaze::fixations::{fixations, Detector, DetectorParams, EyePolicy};
    let fx = fixations(
        &r,
        "P08",
        Detector::Events,
        EyePolicy::Best,
        &DetectorParams::default(),
        &meshgaze::gaze::stimulus_messages::Segmentation::default(),
    )
    .unwrap();
    assert_eq!(fx.len(), 1);
    assert_eq!(
        (fx[0].eye, fx[0].stimulus.as_str(), fx[0].onset_offset_us),
        ("binocular", "bunny.mp4", Some(1_000_500))
    );
}

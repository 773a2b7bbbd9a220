//! SMI readers on every real export in ../shared/data/smi, plus arbitrary and mutated bytes.
mod common;

use std::path::PathBuf;

use meshgaze::gaze::{parse_smi, read_smi, EventKind, Eye, Recording, SmiFormat};
use proptest::prelude::*;

fn smi(name: &str) -> Option<PathBuf> {
    common::shared_data(name).map(|d| d.join("smi").join(name))
}

fn read(name: &str) -> Option<Recording> {
    let r = read_smi(&smi(name)?, None).unwrap_or_else(|e| panic!("{e}"));
    // Nothing unaccounted for: every line is header, blank, sample, message, event or counted.
    assert_eq!(r.rows.accounted(), r.rows.lines, "{name}: {:?}", r.rows);
    Some(r)
}

#[test]
fn hbn_samples_binocular_60hz_with_anonymised_header() {
    let Some(r) = read("hbn-sccn__NDARAA075AMK_Video1_Samples.txt") else {
        return;
    };
    assert_eq!(r.format, SmiFormat::IdfSamples);
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
fn emip_samples_with_pauses_and_identical_eyes() {
    let Some(r) = read("emip__156_rawdata.tsv") else {
        return;
    };
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
fn didec_begaze_samples_with_event_info_and_stimulus() {
    let Some(r) = read("pymovements__didec_example.txt") else {
        return;
    };
    assert_eq!(r.format, SmiFormat::BeGazeSamples);
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
fn hbn_events_with_tabs_turned_into_spaces_match_the_samples_clock() {
    let Some(r) = read("hbn-sccn__NDARAA075AMK_Video1_Events.txt") else {
        return;
    };
    assert_eq!(r.format, SmiFormat::EventTables);
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
fn zv1n_events_87_trials_tab_separated() {
    let Some(r) = read("zv1n-pygaze__events.txt") else {
        return;
    };
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
fn unreadable_formats_say_what_they_are() {
    let Some(p) = smi("xiangguo-etg__Ethan_lane_1-1-recording.csv") else {
        return;
    };
    let e = read_smi(&p, None).unwrap_err().to_string();
    assert!(e.contains("C2") && e.contains("Ethan_lane"), "{e}");
}

#[test]
fn bad_rows_are_counted_with_their_position_never_dropped_silently() {
    let text = "## [iView]\n## Sample Rate:\t250\n## \nTime\tType\tTrial\tL POR X [px]\tL POR Y [px]\n\
                100\tSMP\t1\t10.5\t20.5\n104\tSMP\t1\tx\t20\n108\tSMP\t1\t11\n112\tXYZ\t1\t1\t1\n116\tMSG\t1\t# Message: a b\n";
    let r = parse_smi(text.as_bytes(), "t.txt", None).unwrap();
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
    let Some(d) = common::shared_data("fuzzing the SMI readers with real bytes") else {
        return Vec::new();
    };
    [
        "hbn-sccn__NDARAA075AMK_Video1_Samples.txt",
        "hbn-sccn__NDARAA075AMK_Video1_Events.txt",
        "emip__156_rawdata.tsv",
        "pymovements__didec_example.txt",
        "zv1n-pygaze__events.txt",
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
        for f in [None, Some(SmiFormat::IdfSamples), Some(SmiFormat::EventTables)] {
            let _ = parse_smi(&bytes, "fuzz", f);
        }
    }

    #[test]
    fn mutated_real_files_never_panic_and_account_for_every_line(which in 0usize..5, seed in any::<u64>(), edits in 1usize..20) {
        let files = real_files();
        if !files.is_empty() {
            let mut b = files[which].clone();
            let mut s = seed | 1;
            let mut next = || { s ^= s << 13; s ^= s >> 7; s ^= s << 17; s };
            for _ in 0..edits {
                let i = (next() as usize) % b.len();
                b[i] = match next() % 5 { 0 => b'\t', 1 => b'\n', 2 => b'-', 3 => b' ', _ => next() as u8 };
            }
            if let Ok(r) = parse_smi(&b, "mutated", None) {
                prop_assert_eq!(r.rows.accounted(), r.rows.lines);
            }
        }
    }
}

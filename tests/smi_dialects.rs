//! SMI dialects that real labs have on disk, read with default settings: monocular right-eye
//! event files, validity flags that are 0 in every row, the older BeGaze fixation table and
//! iView X 2.x sample files; and every way a file can yield no fixation, each with its reason.
//! The files are built here from the layouts in shared/docs/smi-formats.md and issue 30.
use std::path::PathBuf;

use meshgaze::gaze::fixations::{EyePolicy, Fate};
use meshgaze::gaze::ingest::{ingest_file, IngestParams, IngestedFile};
use meshgaze::gaze::validity::ValidityRule;
use meshgaze::gaze::{parse_recording, GazeFormat};
use meshgaze::protocol::Protocol;

fn write(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("meshgaze-dialects-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn params() -> IngestParams {
    IngestParams::from_protocol(&Protocol::builtin().0, None).unwrap()
}

fn kept(f: &IngestedFile) -> usize {
    f.fixations.iter().filter(|x| x.fate == Fate::Kept).count()
}

/// `n` fixation centres spread over a 1680x1050 screen, deterministic.
fn centres(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|k| {
            let k = k as f64;
            (200.0 + (k * 377.0) % 1200.0, 150.0 + (k * 211.0) % 700.0)
        })
        .collect()
}

/// BeGaze Event Statistics in the `Category Group, Category, Eye L/R` layout, right eye only.
fn right_eye_event_statistics(fixations: usize) -> String {
    let mut s = String::from("Category Group\tCategory\tEye L/R\tTrial\tStimulus\tParticipant\tEvent Start Trial Time [ms]\tEvent End Trial Time [ms]\tEvent Duration [ms]\tFixation Position X [px]\tFixation Position Y [px]\n");
    let mut t = 100.0;
    for (x, y) in centres(fixations) {
        let d = 250.0 + (x % 97.0);
        s += &format!("Eye\tFixation\tRight\tTrial001\tbunny.mp4\tP03\t{t:.1}\t{:.1}\t{d:.1}\t{x:.1}\t{y:.1}\n", t + d);
        s += &format!(
            "Eye\tSaccade\tRight\tTrial001\tbunny.mp4\tP03\t{:.1}\t{:.1}\t40.0\t-\t-\n",
            t + d,
            t + d + 40.0
        );
        t += d + 40.0;
    }
    s
}

#[test]
fn a_right_eye_only_event_file_gives_fixations_by_default() {
    let p = write(
        "Event Statistics - Single - right.txt",
        &right_eye_event_statistics(30),
    );
    let f = ingest_file(&p, &params()).unwrap();
    assert_eq!(f.recording.format, GazeFormat::EventStatistics);
    assert_eq!(f.fixations.len(), 30);
    assert!(f.fixations.iter().all(|x| x.eye == "right"));
    assert_eq!(kept(&f), 15);
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    // A named eye the file lacks is refused, naming the eye it has.
    let mut left = params();
    left.eye = EyePolicy::Left;
    let e = ingest_file(&p, &left).err().unwrap().to_string();
    assert!(e.contains("no left fixation events"), "{e}");
    assert!(
        e.contains("30 right fixation events") && e.contains("--eye right"),
        "{e}"
    );
}

/// An iView X sample export of a 500 Hz tracker whose `L Validity` is 0 in every row while
/// the POR moves: fixations of 300 ms at 2 ms samples, a blink-free recording.
fn dead_flag_samples(fixations: usize, por_zero: bool) -> String {
    let mut s = String::from("## [iView]\n## Sample Rate:\t500\n## Calibration Area:\t1680\t1050\n## Format:\tLEFT, POR, QUALITY\n");
    s += "Time\tType\tTrial\tL POR X [px]\tL POR Y [px]\tL Validity\n";
    let mut t: i64 = 5_000_000;
    s += &format!("{t}\tMSG\t1\t# Message: bunny.mp4\n");
    for (k, (x, y)) in centres(fixations).into_iter().enumerate() {
        let samples = 150 + 10 * (k % 7);
        for i in 0..samples {
            t += 2000;
            let (x, y) = if por_zero {
                (0.0, 0.0)
            } else {
                (x + (i % 3) as f64, y - (i % 2) as f64)
            };
            s += &format!("{t}\tSMP\t1\t{x:.2}\t{y:.2}\t0\n");
        }
        for _ in 0..15 {
            t += 2000; // a 30 ms saccade, also flagged 0
            s += &format!(
                "{t}\tSMP\t1\t{:.2}\t{:.2}\t0\n",
                if por_zero { 0.0 } else { 900.0 },
                if por_zero { 0.0 } else { 20.0 }
            );
        }
    }
    s
}

#[test]
fn validity_flags_that_are_zero_in_every_row_are_set_aside_and_said_so() {
    let p = write("dead_flags_samples.txt", &dead_flag_samples(30, false));
    let f = ingest_file(&p, &params()).unwrap();
    assert_eq!(f.recording.format, GazeFormat::IdfSamples);
    assert!(kept(&f) == 15, "{} kept of {}", kept(&f), f.fixations.len());
    assert!(
        f.recording
            .notes
            .iter()
            .any(|n| n.contains("`L Validity` is 0 in all") && n.contains("not a loss flag")),
        "{:?}",
        f.recording.notes
    );
    // --validity strict keeps the flag: nothing is tracked, and the reason says so.
    let mut strict = params();
    strict.validity = ValidityRule::Strict;
    let f = ingest_file(&p, &strict).unwrap();
    assert_eq!(kept(&f), 0);
    let w = f.warnings.join("\n");
    assert!(
        w.contains("no fixations")
            && w.contains("validity flag is 0 in every row")
            && w.contains("--validity por"),
        "{w}"
    );
    // --validity por reads the same fixations as auto here.
    let mut por = params();
    por.validity = ValidityRule::Por;
    assert_eq!(kept(&ingest_file(&p, &por).unwrap()), 15);
}

#[test]
fn a_file_whose_por_is_zero_everywhere_is_refused_with_the_reason() {
    let p = write("no_gaze_samples.txt", &dead_flag_samples(5, true));
    let e = ingest_file(&p, &params()).err().unwrap().to_string();
    assert!(
        e.contains("0.00 in all") && e.contains("no gaze position"),
        "{e}"
    );
}

/// The older BeGaze fixation export: TAB, CRLF, no `##` header, two subjects, two trials.
fn begaze_fixation_table() -> String {
    let mut s = String::from("Trial\tSubject\tColor\tStimulus\tStart Time [ms]\tEnd Time [ms]\tFixation Start [ms]\tFixation Duration [ms]\tFixation End [ms]\tPosition X\tPosition Y\tAverage Pupil Size [px] X\tAverage Pupil Size [px] Y\tAverage Pupil Diameter [mm]\tDispersion X\tDispersion Y\tEye\tNumber\r\n");
    for subject in ["ss03", "ss04"] {
        for (trial, stimulus) in [(1, "ss03-1-recording.avi"), (2, "cow.avi")] {
            let mut t = 565;
            for (k, (x, y)) in centres(20).into_iter().enumerate() {
                let d = 200 + (k as i64 * 37) % 300;
                s += &format!(
                    "Trial{trial:03}\t{subject}\tCoral\t{stimulus}\t0\t4131174\t{t}\t{d}\t{}\t{x:.1}\t{y:.1}\t71.6\t34.1\t0.0\t5.0\t12.0\tBinocular\t{}\r\n",
                    t + d,
                    k + 1
                );
                t += d + 45;
            }
        }
    }
    s
}

#[test]
fn the_begaze_fixation_table_reads_as_fixation_events_per_subject() {
    let text = begaze_fixation_table();
    let r = parse_recording(text.as_bytes(), "fixations.txt", None).unwrap();
    assert_eq!(r.format, GazeFormat::BeGazeFixations);
    assert_eq!((r.rows.events, r.rows.accounted()), (80, r.rows.lines));
    let e = &r.events[0];
    assert_eq!(
        (
            e.start_us,
            e.duration_us,
            e.x,
            e.stimulus.as_deref(),
            e.participant.as_deref()
        ),
        (
            565_000,
            200_000,
            Some(200.0),
            Some("ss03-1-recording.avi"),
            Some("ss03")
        )
    );
    let p = write("begaze_fixations.txt", &text);
    let f = ingest_file(&p, &params()).unwrap();
    assert_eq!(f.fixations.len(), 80);
    // Per subject and stimulus: 20 fixations, drop 2 + 2, keep the 15 longest of 16.
    assert_eq!(kept(&f), 4 * 15);
    let subjects: std::collections::BTreeSet<&str> =
        f.fixations.iter().map(|x| x.subject.as_str()).collect();
    assert_eq!(subjects.into_iter().collect::<Vec<_>>(), ["ss03", "ss04"]);
    // A bad row is counted with its position, not dropped silently.
    let bad = text.replacen("\t565\t200\t", "\tabc\t200\t", 1);
    let r = parse_recording(bad.as_bytes(), "bad.txt", None).unwrap();
    let first = &r.rows.unusable["`Fixation Start [ms]` is not a number"];
    assert_eq!((first.count, first.line), (1, 2));
}

/// An iView X 2.x sample file: `#` header, integer ms rows at 60 Hz, one eye.
fn iview2_samples(fixations: usize) -> String {
    let mut s = String::from("#FileVersion:\t2\n#Fileformat:\t2558\n#Subject:\t\n## Date:\tSeptember 19, 2008\n## of Pts Recorded:\t10346\n#Offset Of Calibration Area:\t0\t0\n#Size Of Calibration Area:\t800\t600\n#Sample Rate:\t60\n#\n#Time\tSet\tPupil H\tPupil V\tC.R. H\tC.R. V\tScreenH\tScreenV\tDiam H\tDiam V\n");
    let mut t = 16;
    for (k, (x, y)) in centres(fixations).into_iter().enumerate() {
        let (x, y) = ((x * 0.45) as i64, (y * 0.55) as i64);
        for i in 0..(18 + k % 5) {
            s += &format!(
                "{t}\t0\t5219\t4176\t4909\t4101\t{}\t{y}\t2020\t2203\n",
                x + (i % 2) as i64
            );
            t += 17;
        }
        s += &format!("{t}\t0\t5219\t4176\t4909\t4101\t0\t0\t0\t0\n"); // lost between fixations
        t += 17;
    }
    s
}

#[test]
fn iview_x_2_sample_files_read_and_give_fixations() {
    let text = iview2_samples(24);
    let r = parse_recording(text.as_bytes(), "subject1.txt", None).unwrap();
    assert_eq!(r.format, GazeFormat::IviewLegacy);
    assert_eq!(r.rows.accounted(), r.rows.lines);
    assert_eq!((r.rows.header_lines, r.rows.unusable_total()), (10, 0));
    assert_eq!(r.header.sample_rate_hz, Some(60.0));
    assert_eq!(r.header.calibration_area_px, Some([800.0, 600.0]));
    assert_eq!(r.samples[0].time_us, 16_000, "integer ms kept exact as µs");
    assert!(r.samples[0].right.is_none() && r.samples[0].left.unwrap().valid);
    let p = write("subject1.txt", &text);
    let f = ingest_file(&p, &params()).unwrap();
    assert!(kept(&f) > 0, "{:?}", f.warnings);
    assert_eq!(kept(&f), 15);
}

#[test]
fn a_named_eye_the_samples_lack_is_refused_naming_the_eye_they_have() {
    let p = write("subject2.txt", &iview2_samples(10));
    let mut right = params();
    right.eye = EyePolicy::Right;
    let e = ingest_file(&p, &right).err().unwrap().to_string();
    assert!(
        e.contains("--eye right: no valid right-eye sample")
            && e.contains("valid left-eye samples"),
        "{e}"
    );
}

#[test]
fn every_no_fixation_outcome_names_its_cause() {
    // Too few fixations for the protocol's filter (it drops the first two and the last two).
    let p = write("three.txt", &iview2_samples(3));
    let f = ingest_file(&p, &params()).unwrap();
    assert_eq!((f.fixations.len(), kept(&f)), (3, 0));
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("the protocol's filter kept none of the 3")),
        "{:?}",
        f.warnings
    );

    // Every fixation before the first stimulus onset.
    let mut late = dead_flag_samples(10, false).replace(
        "\tMSG\t1\t# Message: bunny.mp4\n",
        "\tMSG\t1\t# Message: status ok\n",
    );
    late += "99999999999\tMSG\t1\t# Message: bunny.mp4\n";
    let f = ingest_file(&write("late.txt", &late), &params()).unwrap();
    assert_eq!(kept(&f), 0);
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("all 10 fixations are unusable")
                && w.contains("before the first stimulus onset")),
        "{:?}",
        f.warnings
    );

    // An event file with saccades only.
    let saccades: String = right_eye_event_statistics(6)
        .lines()
        .filter(|l| !l.contains("\tFixation\t"))
        .map(|l| format!("{l}\n"))
        .collect();
    let f = ingest_file(&write("saccades.txt", &saccades), &params()).unwrap();
    assert!(
        f.warnings.iter().any(|w| w.contains("hold no fixation")),
        "{:?}",
        f.warnings
    );

    // Samples that never hold still: I-DT finds nothing, and says with which thresholds.
    let mut moving =
        String::from("#FileVersion:\t2\n#Sample Rate:\t60\n#Time\tSet\tScreenH\tScreenV\n");
    for k in 0..200 {
        moving += &format!(
            "{}\t0\t{}\t{}\n",
            16 * k,
            100 + (k * 173) % 600,
            100 + (k * 91) % 400
        );
    }
    let f = ingest_file(&write("moving.txt", &moving), &params()).unwrap();
    assert!(
        f.warnings
            .iter()
            .any(|w| w.contains("found no fixation in 200 valid samples")),
        "{:?}",
        f.warnings
    );
}

#[test]
fn files_that_are_not_gaze_data_are_refused_naming_what_was_expected() {
    let timeline =
        "time\tCalibration|Validation|Movie\tcontent\n0\tCalibration\t-\n1000\tMovie\tbunny.avi\n";
    let e = parse_recording(timeline.as_bytes(), "timeline.txt", None)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("not a recognized gaze recording") && e.contains("B-fix") && e.contains("A2"),
        "{e}"
    );
}

#[test]
fn the_command_line_prints_the_reason_and_lists_the_stimulus_column() {
    let p = write("cli_three.txt", &iview2_samples(3));
    let out = std::env::temp_dir().join(format!("meshgaze-dialects-out-{}", std::process::id()));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["ingest", p.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("no fixations: the protocol's filter kept none"),
        "{err}"
    );
    let json = std::fs::read_to_string(out.join("ingest.json")).unwrap();
    assert!(
        json.contains("\"validity\": \"auto\"") && json.contains("the protocol's filter kept none"),
        "{json}"
    );
    let t = write("cli_fix.txt", &begaze_fixation_table());
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"))
        .args(["ingest", "--list-messages", t.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("2 stimuli named by the file's `Stimulus` column")
            && text.contains("ss03-1-recording.avi"),
        "{text}"
    );
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    /// Mutates `b` at `edits` places chosen by `seed` with bytes that break tables.
    fn mutate(mut b: Vec<u8>, seed: u64, edits: usize) -> Vec<u8> {
        let mut s = seed | 1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        for _ in 0..edits {
            let i = (next() as usize) % b.len();
            b[i] = match next() % 6 {
                0 => b'\t',
                1 => b'\n',
                2 => b'-',
                3 => b'#',
                4 => b'\r',
                _ => next() as u8,
            };
        }
        b
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]

        #[test]
        fn mutated_fixation_tables_never_panic_and_account_for_every_line(seed in any::<u64>(), edits in 1usize..30) {
            let b = mutate(begaze_fixation_table().into_bytes(), seed, edits);
            for format in [None, Some(GazeFormat::BeGazeFixations)] {
                if let Ok(r) = parse_recording(&b, "mutated", format) {
                    prop_assert_eq!(r.rows.accounted(), r.rows.lines);
                    prop_assert!(r.events.iter().all(|e| e.end_us >= e.start_us));
                }
            }
        }

        #[test]
        fn mutated_iview2_files_never_panic_and_account_for_every_line(seed in any::<u64>(), edits in 1usize..30) {
            let b = mutate(iview2_samples(6).into_bytes(), seed, edits);
            for format in [None, Some(GazeFormat::IviewLegacy)] {
                if let Ok(r) = parse_recording(&b, "mutated", format) {
                    prop_assert_eq!(r.rows.accounted(), r.rows.lines);
                    prop_assert_eq!(r.samples.len(), r.rows.samples);
                }
            }
        }

        #[test]
        fn arbitrary_bytes_never_panic_in_the_new_readers(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            for f in [GazeFormat::BeGazeFixations, GazeFormat::IviewLegacy] {
                if let Ok(r) = parse_recording(&bytes, "fuzz", Some(f)) {
                    prop_assert_eq!(r.rows.accounted(), r.rows.lines);
                }
            }
        }

        /// The validity rule only ever changes which samples are valid, never drops one, and
        /// `auto` changes nothing unless the flag is 0 in every row with gaze somewhere.
        #[test]
        fn the_validity_rule_keeps_every_sample(flags in proptest::collection::vec(any::<bool>(), 1..80)) {
            let mut text = String::from("## [iView]\nTime\tType\tTrial\tL POR X [px]\tL POR Y [px]\tL Validity\n");
            for (k, lost) in flags.iter().enumerate() {
                text += &format!("{}\tSMP\t1\t{}.5\t20.0\t{}\n", 1000 * k, 100 + k, if *lost { 0 } else { 1 });
            }
            let r = parse_recording(text.as_bytes(), "v.txt", None).unwrap();
            for rule in [ValidityRule::Auto, ValidityRule::Strict, ValidityRule::Por] {
                let mut x = r.clone();
                let notes = meshgaze::gaze::validity::apply_validity_rule(&mut x, rule);
                prop_assert_eq!(x.samples.len(), r.samples.len());
                let valid = x.samples.iter().filter(|s| s.left.unwrap().valid).count();
                let expected = match rule {
                    ValidityRule::Strict => flags.iter().filter(|l| !**l).count(),
                    ValidityRule::Por => flags.len(),
                    ValidityRule::Auto if flags.iter().all(|l| *l) => flags.len(),
                    ValidityRule::Auto => flags.iter().filter(|l| !**l).count(),
                };
                prop_assert_eq!(valid, expected);
                prop_assert_eq!(notes.is_empty(), valid == flags.iter().filter(|l| !**l).count());
            }
        }
    }
}

/// A crash libFuzzer found (a duration of 1.7e18 ms overflowed the fixation's end): the row is
/// now counted as unusable with its reason.
#[test]
fn a_fixation_time_out_of_range_is_counted_not_a_panic() {
    let bytes = std::fs::read(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/data/fuzz_begaze_fixations_overflow.txt"),
    )
    .unwrap();
    let r = parse_recording(&bytes, "crash.txt", Some(GazeFormat::BeGazeFixations)).unwrap();
    assert_eq!(r.rows.accounted(), r.rows.lines);
    assert!(
        r.rows.unusable.contains_key("fixation time out of range"),
        "{:?}",
        r.rows.unusable
    );
}

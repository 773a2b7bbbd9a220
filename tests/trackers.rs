//! Real exports of current trackers (../shared/data/trackers, see its SOURCES.md), read with
//! default settings: each gives fixations, or is refused with the reason where it holds no
//! screen position. Counts are checked against the files' own lines, counted here
//! independently of the readers.
mod common;

use std::path::PathBuf;

use meshgaze::gaze::fixations::{Detector, Fate};
use meshgaze::gaze::ingest::{ingest_file, IngestParams};
use meshgaze::gaze::{EventKind, GazeFormat};
use meshgaze::protocol::Protocol;

fn params() -> IngestParams {
    IngestParams::from_protocol(&Protocol::builtin().0, None).unwrap()
}

fn tracker_files(vendor: &str, ext: &str) -> Vec<PathBuf> {
    let dir = common::shared_data().join("trackers").join(vendor);
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().ends_with(ext))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no {ext} files in {}", dir.display());
    files
}

/// Lines whose first field is `key`, counted without the reader.
fn lines_starting(text: &str, key: &str) -> usize {
    text.lines()
        .filter(|l| l.split(['\t', ' ']).next() == Some(key))
        .count()
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn every_eyelink_asc_gives_fixations_with_default_settings() {
    for path in tracker_files("eyelink", ".asc") {
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).to_string();
        let f = ingest_file(&path, &params()).unwrap_or_else(|e| panic!("{e}"));
        let r = &f.recording;
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        assert_eq!(r.format, GazeFormat::EyelinkAsc, "{name}");
        assert_eq!(
            r.rows.accounted(),
            r.rows.lines,
            "{name}: every line accounted"
        );
        assert!(
            r.rows.unusable.is_empty(),
            "{name}: unusable lines {:?}",
            r.rows.unusable
        );
        let sample_lines = text
            .lines()
            .filter(|l| l.as_bytes().first().is_some_and(u8::is_ascii_digit))
            .count();
        assert_eq!(r.samples.len(), sample_lines, "{name}: samples");
        let fixation_events = r
            .events
            .iter()
            .filter(|e| e.kind == EventKind::Fixation)
            .count();
        assert_eq!(
            fixation_events,
            lines_starting(&text, "EFIX"),
            "{name}: EFIX"
        );
        assert_eq!(
            r.messages.len(),
            lines_starting(&text, "MSG")
                + lines_starting(&text, "INPUT")
                + lines_starting(&text, "BUTTON"),
            "{name}: messages"
        );
        assert_eq!(
            f.detector,
            Detector::Events,
            "{name}: the tracker's own fixations"
        );
        // Usable: on screen, inside a stimulus. The protocol's filter (drop 2 + 2 per stimulus)
        // may then keep none of a short trial's few: that is the protocol, not the reader.
        let usable = f
            .fixations
            .iter()
            .filter(|x| x.fate != Fate::Invalid)
            .count();
        let kept = f.fixations.iter().filter(|x| x.fate == Fate::Kept).count();
        assert!(usable > 0, "{name}: no usable fixation: {:?}", f.warnings);
        assert!(
            r.header.calibration_area_px.is_some(),
            "{name}: the screen comes from GAZE_COORDS / DISPLAY_COORDS"
        );
        eprintln!(
            "{name}: {} samples, {fixation_events} fixation events, {usable} usable, {kept} kept, screen {:?}, {} Hz",
            r.samples.len(),
            r.header.calibration_area_px.unwrap(),
            r.header.sample_rate_hz.unwrap_or(f64::NAN)
        );
    }
}

mod eyelink_properties {
    use meshgaze::gaze::recording::{EyeSample, Header, Message, Sample};
    use meshgaze::gaze::writers::write_eyelink_asc;
    use meshgaze::gaze::{parse_recording, GazeFormat};
    use proptest::prelude::*;

    fn eye(x: f64, y: f64, lost: bool) -> EyeSample {
        EyeSample {
            x: if lost { 0.0 } else { x },
            y: if lost { 0.0 } else { y },
            pupil: if lost { None } else { Some(3.25) },
            valid: !lost,
            flag_lost: lost,
        }
    }

    fn header() -> Header {
        Header {
            sample_rate_hz: Some(2000.0),
            calibration_area_px: Some([1680.0, 1050.0]),
            ..Header::default()
        }
    }

    /// A small binocular recording as the writer makes it, for mutation.
    fn base_file() -> String {
        let samples: Vec<Sample> = (0..40)
            .map(|k| Sample {
                time_us: 1_000_000 + k * 500,
                trial: 1,
                left: Some(eye(100.0 + k as f64, 200.5, k % 9 == 4)),
                right: Some(eye(101.0, 199.25, k % 7 == 3)),
                binocular: None,
                binocular_event: None,
                left_event: None,
                right_event: None,
                stimulus: None,
            })
            .collect();
        let messages = vec![Message {
            time_us: 1_000_000,
            trial: 1,
            text: "bunny.mp4".into(),
        }];
        write_eyelink_asc(&header(), &samples, &[], &messages)
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// What the writer writes reads back exactly: times (half-milliseconds included),
        /// positions, lost eyes and message texts, whatever the texts say.
        #[test]
        fn written_asc_reads_back_exactly(
            points in proptest::collection::vec((0u32..4000, -50_000i32..250_000, -50_000i32..150_000, any::<bool>()), 1..60),
            texts in proptest::collection::vec("[A-Za-z0-9_./:!-]{1,12}( [A-Za-z0-9_./:!-]{1,12}){0,3}", 0..6),
        ) {
            let mut t = 5_000_000i64;
            let samples: Vec<Sample> = points.iter().map(|&(dt, x, y, lost)| {
                t += 500 + dt as i64 * 500;
                Sample {
                    time_us: t,
                    trial: 1,
                    left: Some(eye(x as f64 / 100.0, y as f64 / 100.0, lost)),
                    right: None,
                    binocular: None,
                    binocular_event: None,
                    left_event: None,
                    right_event: None,
                    stimulus: None,
                }
            }).collect();
            let messages: Vec<Message> = texts.iter().enumerate().map(|(k, text)| Message {
                time_us: 5_000_000 + k as i64 * 1500,
                trial: 1,
                text: text.clone(),
            }).collect();
            let text = write_eyelink_asc(&header(), &samples, &[], &messages);
            let r = parse_recording(text.as_bytes(), "p.asc", None).unwrap();
            prop_assert_eq!(r.format, GazeFormat::EyelinkAsc);
            prop_assert_eq!(r.rows.unusable_total(), 0);
            prop_assert_eq!(r.rows.accounted(), r.rows.lines);
            prop_assert_eq!(r.samples.len(), samples.len());
            for (a, b) in r.samples.iter().zip(&samples) {
                prop_assert_eq!(a.time_us, b.time_us);
                let (ea, eb) = (a.left.unwrap(), b.left.unwrap());
                prop_assert_eq!((ea.valid, ea.x, ea.y), (eb.valid, eb.x, eb.y));
            }
            let got: Vec<(i64, &str)> = r.messages.iter().filter(|m| !m.text.starts_with("GAZE_COORDS")).map(|m| (m.time_us, m.text.as_str())).collect();
            let want: Vec<(i64, &str)> = messages.iter().map(|m| (m.time_us, m.text.as_str())).collect();
            prop_assert_eq!(got, want);
        }

        /// Damaged files never panic, and every line is still a header, blank, sample,
        /// message, event or counted unusable line.
        #[test]
        fn damaged_asc_never_panics_and_accounts_for_every_line(
            seed in any::<u64>(),
            edits in 1usize..30,
        ) {
            let mut bytes = base_file().into_bytes();
            let mut s = seed;
            for _ in 0..edits {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let at = (s >> 33) as usize % bytes.len();
                let alphabet = b"\t\n .-5LRE*M";
                let what = alphabet[(s >> 20) as usize % alphabet.len()];
                match s % 3 {
                    0 => bytes[at] = what,
                    1 => bytes.insert(at, what),
                    _ => {
                        bytes.remove(at);
                    }
                }
            }
            if let Ok(r) = parse_recording(&bytes, "damaged.asc", Some(GazeFormat::EyelinkAsc)) {
                prop_assert_eq!(r.rows.accounted(), r.rows.lines);
                prop_assert_eq!(r.samples.len(), r.rows.samples);
            }
        }
    }
}

/// Distinct fixation indices of a Tobii table, counted here from the named columns.
fn tobii_fixation_indices(
    text: &str,
    sep: char,
    kind: &str,
    index: &str,
    sensor: Option<&str>,
) -> usize {
    let mut lines = text.trim_start_matches('\u{feff}').lines();
    let header: Vec<&str> = lines.next().unwrap().split(sep).collect();
    let col = |n: &str| header.iter().position(|c| c.trim() == n).unwrap();
    let (k, i) = (col(kind), col(index));
    let s = sensor.map(col);
    let mut seen = std::collections::BTreeSet::new();
    for l in lines {
        let f: Vec<&str> = l.split(sep).collect();
        let gaze_row = s.is_none_or(|s| f.get(s) == Some(&"Eye Tracker"));
        if gaze_row && f.get(k) == Some(&"Fixation") && !f[i].is_empty() {
            seen.insert(f[i].to_string());
        }
    }
    seen.len()
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn tobii_pro_lab_and_studio_exports_give_their_fixations() {
    let dir = common::shared_data().join("trackers/tobii");
    for (file, format, sep, kind, index, sensor) in [
        (
            "tobii-pro__all_gaze.csv",
            GazeFormat::TobiiProLab,
            ',',
            "Eye movement type",
            "Eye movement type index",
            Some("Sensor"),
        ),
        (
            "d2lab__studio_data.tsv",
            GazeFormat::TobiiStudio,
            '\t',
            "GazeEventType",
            "FixationIndex",
            None,
        ),
    ] {
        let path = dir.join(file);
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).to_string();
        let f = ingest_file(&path, &params()).unwrap_or_else(|e| panic!("{e}"));
        let r = &f.recording;
        assert_eq!(r.format, format, "{file}");
        assert_eq!(r.rows.accounted(), r.rows.lines, "{file}");
        let expected = tobii_fixation_indices(&text, sep, kind, index, sensor);
        assert_eq!(
            r.events.len(),
            expected,
            "{file}: one event per fixation index"
        );
        assert_eq!(f.detector, Detector::Events, "{file}");
        let usable = f
            .fixations
            .iter()
            .filter(|x| x.fate != Fate::Invalid)
            .count();
        let kept = f.fixations.iter().filter(|x| x.fate == Fate::Kept).count();
        assert!(
            usable > 0 && kept > 0,
            "{file}: {:?} {:?}",
            f.warnings,
            r.notes
        );
        assert!(r.header.calibration_area_px.is_some(), "{file}: the screen");
        eprintln!(
            "{file}: {} samples, {} fixations ({usable} usable, {kept} kept), unusable {:?}, notes {:?}",
            r.samples.len(),
            r.events.len(),
            r.rows.unusable.iter().map(|(k, v)| (k.as_str(), v.count)).collect::<Vec<_>>(),
            r.notes
        );
    }
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn gazepoint_exports_give_their_fixations_scaled_to_the_screen() {
    let dir = common::shared_data().join("trackers/gazepoint");
    for file in ["d2lab__User_1_all_gaze.csv", "d2lab__User_1_fixations.csv"] {
        let path = dir.join(file);
        let text = String::from_utf8_lossy(&std::fs::read(&path).unwrap()).to_string();
        // Valid fixation ids, counted here from FPOGID and FPOGV.
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |n: &str| header.iter().position(|c| *c == n).unwrap();
        let (id, valid) = (col("FPOGID"), col("FPOGV"));
        let ids: std::collections::BTreeSet<&str> = lines
            .map(|l| l.split(',').collect::<Vec<_>>())
            .filter(|f| f[valid] == "1")
            .map(|f| f[id])
            .collect();
        let f = ingest_file(&path, &params()).unwrap_or_else(|e| panic!("{e}"));
        let r = &f.recording;
        assert_eq!(r.format, GazeFormat::Gazepoint, "{file}");
        assert_eq!(r.rows.accounted(), r.rows.lines, "{file}");
        assert!(r.rows.unusable.is_empty(), "{file}: {:?}", r.rows.unusable);
        assert_eq!(
            r.events.len(),
            ids.len(),
            "{file}: one event per valid FPOGID"
        );
        // Fractions of the screen become pixels of the protocol's 1680x1050 display.
        assert_eq!(r.header.calibration_area_px, Some([1680.0, 1050.0]));
        assert!(
            r.notes.iter().any(|n| n.contains("scaled to 1680x1050")),
            "{:?}",
            r.notes
        );
        let kept = f.fixations.iter().filter(|x| x.fate == Fate::Kept).count();
        assert!(kept > 0, "{file}: {:?}", f.warnings);
        assert!(f
            .fixations
            .iter()
            .filter(|x| x.fate == Fate::Kept)
            .all(|x| x.x_px > 1.0 && x.x_px < 1680.0));
        eprintln!(
            "{file}: {} rows, {} fixations, {kept} kept; notes {:?}",
            r.rows.lines,
            r.events.len(),
            r.notes
        );
    }
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn pupil_core_surface_exports_give_fixations_and_world_camera_exports_are_refused() {
    let src = common::shared_data().join("trackers/pupil");
    // Laid out as Pupil Player writes an export: surfaces/ with its surface_events.csv.
    let export = std::env::temp_dir().join(format!("meshgaze-pupil-{}", std::process::id()));
    let surfaces = export.join("surfaces");
    std::fs::create_dir_all(&surfaces).unwrap();
    for (from, to) in [
        (
            "chblab__gaze_positions_on_surface_Surface_1.csv",
            "gaze_positions_on_surface_Surface 1.csv",
        ),
        (
            "chblab__fixations_on_surface_Surface_1.csv",
            "fixations_on_surface_Surface 1.csv",
        ),
        ("chblab__surface_events.csv", "surface_events.csv"),
    ] {
        std::fs::copy(src.join(from), surfaces.join(to)).unwrap();
    }
    for file in [
        "gaze_positions_on_surface_Surface 1.csv",
        "fixations_on_surface_Surface 1.csv",
    ] {
        let path = surfaces.join(file);
        let text = std::fs::read_to_string(&path).unwrap();
        let f = ingest_file(&path, &params()).unwrap_or_else(|e| panic!("{e}"));
        let r = &f.recording;
        assert_eq!(r.format, GazeFormat::PupilCore, "{file}");
        assert_eq!(r.rows.accounted(), r.rows.lines, "{file}");
        assert!(r.rows.unusable.is_empty(), "{file}: {:?}", r.rows.unusable);
        // surface_events.csv beside it: its two enter/exit rows are messages.
        let events_rows = std::fs::read_to_string(surfaces.join("surface_events.csv"))
            .unwrap()
            .lines()
            .count()
            - 1;
        assert_eq!(r.messages.len(), events_rows, "{file}: {:?}", r.notes);
        let kept = f.fixations.iter().filter(|x| x.fate == Fate::Kept).count();
        let usable = f
            .fixations
            .iter()
            .filter(|x| x.fate != Fate::Invalid)
            .count();
        assert!(kept > 0, "{file}: {:?}", f.warnings);
        if file.starts_with("fixations") {
            let mut lines = text.lines();
            let header: Vec<&str> = lines.next().unwrap().split(',').collect();
            let id = header.iter().position(|c| *c == "fixation_id").unwrap();
            let ids: std::collections::BTreeSet<&str> =
                lines.map(|l| l.split(',').nth(id).unwrap()).collect();
            assert_eq!(r.events.len(), ids.len(), "one event per fixation_id");
        }
        eprintln!(
            "{file}: {} samples, {} fixation events, {usable} usable, {kept} kept; notes {:?}",
            r.samples.len(),
            r.events.len(),
            r.notes
        );
    }
    let _ = std::fs::remove_dir_all(&export);
    for file in ["tutorials__gaze_positions.csv", "tutorials__fixations.csv"] {
        let e = ingest_file(&src.join(file), &params())
            .err()
            .unwrap_or_else(|| panic!("{file} accepted"))
            .to_string();
        assert!(
            e.contains("world-camera")
                && e.contains("Surface Tracker")
                && e.contains("Marker Mapper"),
            "{e}"
        );
    }
}

#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn tobii_studio_lists_give_fixations_with_their_event_lists_messages() {
    let src = common::shared_data().join("trackers/tobii");
    let dir = std::env::temp_dir().join(format!("meshgaze-tobii-lists-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Named as Studio wrote them, beside each other.
    let fixations = dir.join("P61-Fixation-Data.tsv");
    let events = dir.join("P61-Event-Data.tsv");
    std::fs::copy(src.join("emdat__P61-Fixation-Data.tsv"), &fixations).unwrap();
    std::fs::copy(src.join("emdat__P61-Event-Data.tsv"), &events).unwrap();
    let text = std::fs::read_to_string(&fixations).unwrap();
    let table_rows = text
        .lines()
        .skip_while(|l| !l.starts_with("FixationIndex"))
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .count();
    let event_text = std::fs::read_to_string(&events).unwrap();
    let event_rows = event_text
        .lines()
        .skip_while(|l| !l.starts_with("Timestamp\tEvent"))
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .count();
    let f = ingest_file(&fixations, &params()).unwrap_or_else(|e| panic!("{e}"));
    let r = &f.recording;
    assert_eq!(r.format, GazeFormat::TobiiStudioList);
    assert_eq!(r.rows.accounted(), r.rows.lines);
    assert!(r.rows.unusable.is_empty(), "{:?}", r.rows.unusable);
    assert_eq!(r.events.len(), table_rows);
    assert_eq!(r.messages.len(), event_rows, "{:?}", r.notes);
    assert_eq!(r.header.calibration_area_px, Some([1280.0, 1024.0]));
    assert_eq!(r.header.subject.as_deref(), Some("P105"));
    let kept = f.fixations.iter().filter(|x| x.fate == Fate::Kept).count();
    assert!(kept > 0, "{:?}", f.warnings);
    eprintln!(
        "{} fixations, {} messages, {kept} kept; {:?}",
        r.events.len(),
        r.messages.len(),
        r.notes
    );
    let e = ingest_file(&events, &params())
        .err()
        .expect("an event list has no gaze")
        .to_string();
    assert!(
        e.contains("event list") && e.contains("Fixation-Data"),
        "{e}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

mod table_reader_properties {
    use meshgaze::gaze::recording::{EyeSample, Header, Message, Sample};
    use meshgaze::gaze::writers::write_tobii_pro_lab_tsv;
    use meshgaze::gaze::{parse_recording, GazeFormat};
    use proptest::prelude::*;

    const GAZEPOINT: &str = "MEDIA_ID,MEDIA_NAME,CNT,TIME(2022/09/19 13:34:49.156),TIMETICK(f=10000000),FPOGX,FPOGY,FPOGS,FPOGD,FPOGID,FPOGV,BPOGX,BPOGY,BPOGV,USER,\n0,bunny.mp4,0,0.00000,35043126,0.45310,0.56713,0.00000,0.00000,1,0,0.45310,0.56713,1,,\n0,bunny.mp4,1,0.01633,35043128,0.49667,0.51520,0.00000,0.01633,1,1,0.54025,0.46328,1,START,\n0,bunny.mp4,2,0.03266,35043130,0.49667,0.51520,0.00000,0.03266,1,1,0.54025,0.46328,1,,\n";
    const PUPIL: &str = "world_timestamp,world_index,gaze_timestamp,x_norm,y_norm,x_scaled,y_scaled,on_surf,confidence\n38818.243809,1,38818.254884,0.5974,0.6,0.5974,0.6,True,0.99\n38818.275781,2,38818.267277,0.60,2.14,0.60,2.14,False,0.0\n38818.3,3,38818.29,0.61,0.62,0.61,0.62,True,0.95\n";
    const STUDIO_LIST: &str = "Data properties:\n\nSubject: P105\nScreen resolution: 1280 x 1024\n\nFixationIndex\tTimestamp\tFixationDuration\tMappedFixationPointX\tMappedFixationPointY\t\n12\t26\t633\t513\t518\t\n13\t659\t849\t595\t527\t\n";

    fn tobii_file() -> String {
        let samples: Vec<Sample> = (0..30)
            .map(|k| {
                let e = EyeSample {
                    x: 400.0 + k as f64,
                    y: 300.25,
                    pupil: Some(3.5),
                    valid: k % 11 != 5,
                    flag_lost: k % 11 == 5,
                };
                Sample {
                    time_us: 1_000 + k * 8_333,
                    trial: 1,
                    left: Some(e),
                    right: Some(e),
                    binocular: None,
                    binocular_event: None,
                    left_event: None,
                    right_event: None,
                    stimulus: None,
                }
            })
            .collect();
        let header = Header {
            calibration_area_px: Some([1680.0, 1050.0]),
            subject: Some("s01".into()),
            ..Header::default()
        };
        let messages = vec![Message {
            time_us: 1_000,
            trial: 1,
            text: "bunny.mp4".into(),
        }];
        write_tobii_pro_lab_tsv(&header, &samples, &[], &messages)
    }

    fn damage(text: &str, seed: u64, edits: usize, alphabet: &[u8]) -> Vec<u8> {
        let mut bytes = text.as_bytes().to_vec();
        let mut s = seed;
        for _ in 0..edits {
            s = s
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let at = (s >> 33) as usize % bytes.len();
            let what = alphabet[(s >> 20) as usize % alphabet.len()];
            match s % 3 {
                0 => bytes[at] = what,
                1 => bytes.insert(at, what),
                _ => {
                    bytes.remove(at);
                }
            }
        }
        bytes
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        /// Damaged Tobii, Gazepoint, Pupil and Studio-list files never panic; what reads
        /// accounts for every line, one sample per sample line.
        #[test]
        fn damaged_table_exports_never_panic_and_account_for_every_line(
            which in 0usize..5,
            seed in any::<u64>(),
            edits in 1usize..25,
        ) {
            let (base, format, alphabet): (String, GazeFormat, &[u8]) = match which {
                0 => (tobii_file(), GazeFormat::TobiiProLab, b"\t\n.,-5VxE\""),
                1 => (GAZEPOINT.to_string(), GazeFormat::Gazepoint, b",\n.-51x"),
                2 => (PUPIL.to_string(), GazeFormat::PupilCore, b",\n.-5TF"),
                3 => (STUDIO_LIST.to_string(), GazeFormat::TobiiStudioList, b"\t\n:-5x"),
                _ => (super::tobii_sdk_dump(which % 2 == 0), GazeFormat::TobiiSdk, b",\t\n.()-5T"),
            };
            let bytes = damage(&base, seed, edits, alphabet);
            if let Ok(r) = parse_recording(&bytes, "damaged", Some(format)) {
                prop_assert_eq!(r.rows.accounted(), r.rows.lines);
                prop_assert_eq!(r.samples.len(), r.rows.samples);
                prop_assert!(r.events.iter().all(|e| e.end_us >= e.start_us));
            }
        }
    }

    #[test]
    fn written_tobii_tsv_reads_back_its_samples_and_stimulus() {
        let text = tobii_file();
        let r = parse_recording(text.as_bytes(), "s01.tsv", None).unwrap();
        assert_eq!(r.format, GazeFormat::TobiiProLab);
        assert_eq!(r.rows.unusable_total(), 0, "{:?}", r.rows.unusable);
        assert_eq!(r.samples.len(), 30);
        assert_eq!(r.samples[3].time_us, 1_000 + 3 * 8_333);
        assert_eq!(r.samples[3].left.unwrap().x, 403.0);
        assert!(!r.samples[5].left.unwrap().valid);
        assert_eq!(r.samples[0].stimulus.as_deref(), Some("bunny.mp4"));
        assert_eq!(r.messages[0].text, "bunny.mp4");
        assert_eq!(r.header.calibration_area_px, Some([1680.0, 1050.0]));
    }
}

/// Found by libFuzzer: a Studio fixation list whose time is ~1e300 ms overflowed the
/// fixation's end; such a row is now counted as unusable.
#[test]
fn a_fixation_list_time_beyond_2_53_us_is_unusable_not_an_overflow() {
    let bytes = std::fs::read(common::repo_root().join("tests/data/fuzz_tobii_list_huge_time.tsv"))
        .unwrap();
    if let Ok(r) = meshgaze::gaze::parse_recording(&bytes, "crash.tsv", None) {
        assert_eq!(r.rows.accounted(), r.rows.lines);
        assert!(r.events.iter().all(|e| e.end_us >= e.start_us));
    }
}

/// Found by libFuzzer: a Gazepoint fixation whose end fell before its start.
#[test]
fn a_gazepoint_fixation_never_ends_before_it_starts() {
    let bytes =
        std::fs::read(common::repo_root().join("tests/data/fuzz_gazepoint_fixation_end.csv"))
            .unwrap();
    if let Ok(r) = meshgaze::gaze::parse_recording(&bytes, "crash.csv", Some(GazeFormat::Gazepoint))
    {
        assert_eq!(r.rows.accounted(), r.rows.lines);
        let bad: Vec<(i64, i64)> = r
            .events
            .iter()
            .filter(|e| e.end_us < e.start_us)
            .map(|e| (e.start_us, e.end_us))
            .collect();
        assert!(bad.is_empty(), "{bad:?}");
    }
}

/// A Tobii Pro SDK dump as an experiment program writes the `gaze_data` callback, built here
/// from the SDK's field names: 120 Hz, three 400 ms fixations, each ending in a lost sample.
fn tobii_sdk_dump(tuples: bool) -> String {
    let mut s = if tuples {
        String::from("device_time_stamp,system_time_stamp,left_gaze_point_on_display_area,left_gaze_point_validity,left_pupil_diameter,left_pupil_validity,right_gaze_point_on_display_area,right_gaze_point_validity,right_pupil_diameter,right_pupil_validity\n")
    } else {
        String::from("device_time_stamp\tsystem_time_stamp\tleft_gaze_point_on_display_area_x\tleft_gaze_point_on_display_area_y\tleft_gaze_point_validity\tleft_pupil_diameter\tleft_pupil_validity\tright_gaze_point_on_display_area_x\tright_gaze_point_on_display_area_y\tright_gaze_point_validity\tright_pupil_diameter\tright_pupil_validity\n")
    };
    let mut t: i64 = 5_000_000_000;
    for (cx, cy) in [(0.25, 0.30), (0.60, 0.55), (0.40, 0.80)] {
        for k in 0..48 {
            t += 8_333;
            let lost = k == 47;
            let (x, y) = (cx + 0.0005 * (k % 3) as f64, cy);
            let (v, xs, ys) = if lost {
                ("False", "nan".to_string(), "nan".to_string())
            } else {
                ("True", format!("{x}"), format!("{y}"))
            };
            if tuples {
                s += &format!(
                    "{},{t},\"({xs}, {ys})\",{v},3.1,True,\"({xs}, {ys})\",{v},3.2,True\n",
                    t - 1000
                );
            } else {
                s += &format!(
                    "{}\t{t}\t{xs}\t{ys}\t{}\t3.1\t1\t{xs}\t{ys}\t{}\t3.2\t1\n",
                    t - 1000,
                    (!lost) as u8,
                    (!lost) as u8
                );
            }
        }
        t += 60_000; // a saccade without samples
    }
    s
}

#[test]
fn a_tobii_pro_sdk_dump_gives_its_fixations_scaled_to_the_screen() {
    let dir = std::env::temp_dir().join(format!("meshgaze-tobii-sdk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for tuples in [false, true] {
        let path = dir.join(format!("s01_{tuples}.csv"));
        std::fs::write(&path, tobii_sdk_dump(tuples)).unwrap();
        let f = ingest_file(&path, &params()).unwrap_or_else(|e| panic!("{e}"));
        let r = &f.recording;
        assert_eq!(r.format, GazeFormat::TobiiSdk, "tuples {tuples}");
        assert_eq!(r.rows.accounted(), r.rows.lines);
        assert!(r.rows.unusable.is_empty(), "{:?}", r.rows.unusable);
        assert_eq!(r.samples.len(), 3 * 48);
        assert_eq!(
            r.samples.iter().filter(|s| !s.left.unwrap().valid).count(),
            3
        );
        assert_eq!(r.samples[0].time_us, 5_000_008_333, "system_time_stamp, µs");
        assert_eq!(r.header.sample_rate_hz, Some(120.0));
        let found: Vec<(f64, f64)> = f.fixations.iter().map(|x| (x.x_px, x.y_px)).collect();
        assert_eq!(found.len(), 3, "{found:?}");
        for ((x, y), (cx, cy)) in found.iter().zip([(0.25, 0.30), (0.60, 0.55), (0.40, 0.80)]) {
            assert!(
                (x - cx * 1680.0).abs() < 2.0 && (y - cy * 1050.0).abs() < 2.0,
                "{found:?}"
            );
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A Tobii Pro Lab export large enough for the readers' second thread (its rows repeated 12
/// times, times shifted, about 6 MB), ingested by the binary on rayon's default threads and
/// with `RAYON_NUM_THREADS=1`: the same fixations, messages and quality bytes.
#[test]
#[cfg_attr(no_shared_data, ignore = "needs ../shared/data")]
fn a_large_pro_lab_export_ingests_the_same_on_one_thread_and_on_two() {
    let src = tracker_files("tobii", "tobii-pro__all_gaze.csv").remove(0);
    let text = std::fs::read_to_string(&src).unwrap();
    let mut lines = text.lines();
    let head = lines.next().unwrap();
    let rows: Vec<(i64, &str)> = lines
        .filter(|l| !l.is_empty())
        .map(|l| {
            let (t, rest) = l.split_once(',').unwrap();
            (t.parse::<i64>().unwrap(), rest)
        })
        .collect();
    let span = rows.iter().map(|r| r.0).max().unwrap() - rows.iter().map(|r| r.0).min().unwrap();
    let mut big = format!("{head}\n");
    for k in 0..12 {
        for (t, rest) in &rows {
            big.push_str(&format!("{},{rest}\n", t + k * (span + 10_000)));
        }
    }
    assert!(
        big.len() > 4 << 20,
        "{} bytes: too small for the second thread",
        big.len()
    );
    let dir = std::env::temp_dir().join(format!("meshgaze-big-prolab-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("big_prolab.csv");
    std::fs::write(&input, &big).unwrap();
    let ingest = |threads: Option<&str>, out: &str| {
        let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_meshgaze"));
        c.arg("ingest").arg(&input).arg("-o").arg(dir.join(out));
        if let Some(n) = threads {
            c.env("RAYON_NUM_THREADS", n);
        }
        let done = c.output().unwrap();
        assert!(
            done.status.success(),
            "{}",
            String::from_utf8_lossy(&done.stderr)
        );
    };
    ingest(None, "default");
    ingest(Some("1"), "one");
    for file in ["fixations.csv", "messages.csv", "quality.csv"] {
        let a = std::fs::read(dir.join("default").join(file)).unwrap();
        let b = std::fs::read(dir.join("one").join(file)).unwrap();
        assert!(!a.is_empty(), "{file} is empty");
        assert!(a == b, "{file} differs between the default threads and one");
    }
    let fixations = std::fs::read_to_string(dir.join("one").join("fixations.csv")).unwrap();
    assert!(fixations.lines().count() > 12, "{fixations}");
    let _ = std::fs::remove_dir_all(&dir);
}

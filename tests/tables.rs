//! The tables the pipeline passes between stages (fixations.csv, projected.csv, targets.csv,
//! human-mark files, stimulus manifests): any bytes give rows or an error naming the place,
//! never a panic, and what meshgaze writes reads back exactly.
use proptest::prelude::*;

use meshgaze::experiments::features::marks::parse_marks;
use meshgaze::gaze::fixation_table::{parse_fixations_csv, write_fixations_csv, FixationRow};
use meshgaze::projection::table::{parse_projected_csv, write_projected_csv, ProjectedRow};
use meshgaze::projection::ProjectionFate;
use meshgaze::simulate::parse_targets_csv;
use meshgaze::stimulus::load::load_stimulus;

fn text() -> impl Strategy<Value = String> {
    // Printable text with the characters CSV quoting must survive.
    proptest::string::string_regex("[a-zA-Z0-9 ,\"._-]{0,12}").unwrap()
}

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![-1e7f64..1e7, Just(0.0), Just(-0.0), Just(1e-300)]
}

fn fixation_row() -> impl Strategy<Value = FixationRow> {
    (
        (
            text(),
            text(),
            text(),
            any::<u32>(),
            any::<i64>(),
            any::<i64>(),
        ),
        (finite(), finite(), finite(), proptest::option::of(finite())),
        (
            proptest::option::of(finite()),
            proptest::option::of(any::<i64>()),
            text(),
            text(),
        ),
    )
        .prop_map(
            |(
                (subject, stimulus, eye, trial, s, e),
                (d, x, y, disp),
                (pupil, onset, fate, invalid_reason),
            )| {
                FixationRow {
                    subject,
                    stimulus,
                    eye,
                    trial,
                    start_us: s,
                    end_us: e,
                    duration_ms: d,
                    x_px: x,
                    y_px: y,
                    dispersion_px: disp,
                    pupil,
                    onset_offset_us: onset,
                    fate,
                    invalid_reason,
                }
            },
        )
}

fn projected_row() -> impl Strategy<Value = ProjectedRow> {
    (
        (text(), any::<u32>(), finite(), finite(), finite(), finite()),
        (
            proptest::option::of(finite()),
            proptest::option::of(0usize..3),
            proptest::option::of(any::<u32>()),
        ),
        (
            0usize..7,
            any::<u32>(),
            finite(),
            finite(),
            finite(),
            proptest::option::of(finite()),
        ),
    )
        .prop_map(
            |((subject, k, s, d, x, y), (t, vp, tri), (fate, v, px, py, pz, snap))| {
                let fate = ProjectionFate::ALL[fate];
                let on = fate.on_mesh();
                ProjectedRow {
                    subject,
                    fixation: k as usize,
                    start_ms: s,
                    duration_ms: d,
                    screen_x: x,
                    screen_y: y,
                    camera_time_s: t,
                    phase: vp.map(|i| ["hold", "move", "ended"][i].to_string()),
                    viewpoint: vp,
                    triangle: tri.map(|x| x as usize),
                    vertex: on.then_some(v as usize),
                    x: on.then_some(px),
                    y: on.then_some(py),
                    z: on.then_some(pz),
                    snap_px: snap,
                    fate: fate.name().to_string(),
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn fixation_tables_round_trip(rows in proptest::collection::vec(fixation_row(), 0..6)) {
        let mut buf = Vec::new();
        write_fixations_csv(&mut buf, &rows).unwrap();
        prop_assert_eq!(parse_fixations_csv(&buf, "f").unwrap(), rows);
    }

    #[test]
    fn projected_tables_round_trip(rows in proptest::collection::vec(projected_row(), 0..6)) {
        let mut buf = Vec::new();
        write_projected_csv(&mut buf, &rows).unwrap();
        prop_assert_eq!(parse_projected_csv(&buf, "p").unwrap(), rows);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = parse_fixations_csv(&bytes, "f");
        let _ = parse_projected_csv(&bytes, "p");
        let _ = parse_targets_csv(&bytes, "t");
        let text = String::from_utf8_lossy(&bytes);
        if let Ok(v) = parse_marks(&text, "m", 100) {
            prop_assert!(v.iter().all(|&x| x < 100));
        }
    }

    #[test]
    fn mutated_tables_give_rows_or_located_errors(rows in proptest::collection::vec(fixation_row(), 1..4), at in any::<usize>(), byte in any::<u8>()) {
        let mut buf = Vec::new();
        write_fixations_csv(&mut buf, &rows).unwrap();
        let i = at % buf.len();
        buf[i] = byte;
        if let Err(e) = parse_fixations_csv(&buf, "fix.csv") {
            let e = e.to_string();
            prop_assert!(e.starts_with("fix.csv:"), "{}", e);
        }
    }

    #[test]
    fn marks_errors_name_line_and_column(prefix in "[0-9]{1,3}", junk in "[a-z]{1,5}") {
        let text = format!("# marks\nvertex\n{prefix}\n  {junk}\n");
        let e = parse_marks(&text, "s.txt", 1000).unwrap_err();
        prop_assert_eq!(e.to_string(), format!("s.txt:4:3: expected a vertex index, found `{junk}`"));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    /// A manifest that is not one is refused with its file name, never a panic.
    #[test]
    fn broken_manifests_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..300), json in any::<bool>()) {
        let dir = std::env::temp_dir().join(format!("meshgaze-manifest-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("manifest.json");
        let content = if json {
            format!("{{\"protocol_toml\": {:?}, \"protocol_sha256\": \"00\"}}", String::from_utf8_lossy(&bytes))
                .into_bytes()
        } else {
            bytes
        };
        std::fs::write(&p, content).unwrap();
        let e = load_stimulus(&p, None).err().expect("refused").to_string();
        prop_assert!(e.contains("manifest.json"), "{}", e);
    }
}

#![no_main]
//! The tables stages hand each other: fixations.csv, projected.csv, targets.csv and
//! human-mark files. Any bytes: rows or an error naming the place, never a panic; rows that
//! parse write back and re-read identically.
use libfuzzer_sys::fuzz_target;
use meshgaze::experiments::features::marks::parse_marks;
use meshgaze::gaze::fixation_table::{parse_fixations_csv, write_fixations_csv};
use meshgaze::projection::table::{parse_projected_csv, write_projected_csv};
use meshgaze::simulate::parse_targets_csv;

fuzz_target!(|data: &[u8]| {
    match parse_fixations_csv(data, "f") {
        Ok(rows) => {
            let mut buf = Vec::new();
            write_fixations_csv(&mut buf, &rows).unwrap();
            let again = parse_fixations_csv(&buf, "f").unwrap();
            assert_eq!(again.len(), rows.len());
        }
        Err(e) => assert!(e.to_string().starts_with("f:")),
    }
    match parse_projected_csv(data, "p") {
        Ok(rows) => {
            let mut buf = Vec::new();
            write_projected_csv(&mut buf, &rows).unwrap();
            assert_eq!(parse_projected_csv(&buf, "p").unwrap().len(), rows.len());
        }
        Err(e) => assert!(e.to_string().starts_with("p:")),
    }
    let _ = parse_targets_csv(data, "t");
    if let Ok(v) = parse_marks(&String::from_utf8_lossy(data), "m", 1000) {
        assert!(v.iter().all(|&x| x < 1000));
    }
});

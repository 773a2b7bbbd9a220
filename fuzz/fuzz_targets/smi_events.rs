#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::{parse_smi, SmiFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_smi(data, "fuzz", Some(SmiFormat::EventTables)) {
        // Every line is accounted for, whatever the bytes.
        assert_eq!(r.rows.accounted(), r.rows.lines);
    }
});

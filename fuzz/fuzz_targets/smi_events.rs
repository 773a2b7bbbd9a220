#![no_main]
use libfuzzer_sys::fuzz_target;
use meshgaze::gaze::{parse_recording, GazeFormat};

fuzz_target!(|data: &[u8]| {
    if let Ok(r) = parse_recording(data, "fuzz", Some(GazeFormat::EventTables)) {
        // Every line is accounted for, whatever the bytes.
        assert_eq!(r.rows.accounted(), r.rows.lines);
    }
});
